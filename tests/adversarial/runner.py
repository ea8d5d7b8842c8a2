"""Run one catalogue case in a child process and check what it promised.

Peak memory: the command is started by ``peak.py``, a small process that waits for it
with ``os.wait4``, whose ``ru_maxrss`` (KiB on Linux) is the high-water resident set of
that child *and of every descendant it waited for* (the kernel folds a reaped child's
peak into its parent's). A command forked straight from the test process would carry
that process's size in its ``ru_maxrss`` (the high-water mark survives exec). So for a
``shell`` case, ``bash -c 'enc a | enc b'`` reports the largest of bash, enc a and
enc b: the largest single process of the pipeline, not their sum. A descendant that is
not waited for (``cmd &`` left to init) is not counted. The child also runs under an address-space
limit of 2 GiB, so that a runaway allocation fails in the child (a MemoryError: an
"internal error" line, a failed case) instead of starving the machine.
"""

from __future__ import annotations

import contextlib
import fnmatch
import hashlib
import os
import re
import resource
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from adversarial import zygote_client as zygote
from adversarial.builders import DATA, RIGS, ROOT
from adversarial.catalogue import Case

#: the peak resident memory every case must stay under [MB]
MAX_MB = 500.0
#: the address-space limit of a case's process [bytes]
ADDRESS_LIMIT = 2 << 30
#: the small process that starts a case's command and reports its peak memory
PEAK = Path(__file__).with_name("peak.py")
ERROR_LINE = re.compile(r"^(enc [a-z-]+|enc-nightly): error: ")


@dataclass
class Result:
    code: int
    stdout: bytes
    stderr: bytes
    peak_mb: float
    seconds: float
    timed_out: bool
    cpu_s: float = 0.0


def _env(case: Case) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ENC_")}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{ROOT / 'bin'}{os.pathsep}" \
                  f"{env.get('PATH', '')}"
    env.update(case.env)
    return env


def _subs(text: str, folder: Path, base: Path) -> str:
    for k, v in {"data": DATA, "rigs": RIGS, "root": ROOT, "base": base, "dir": folder}.items():
        text = text.replace("{" + k + "}", str(v))
    return text


def command_line(case: Case, folder: Path, base: Path) -> list[str]:
    if case.shell is not None:
        return ["/bin/bash", "-o", "pipefail", "-c", _subs(case.shell, folder, base)]
    assert case.argv is not None
    argv = [_subs(a, folder, base) for a in case.argv]
    if argv[0] == "enc":
        argv[0] = str(Path(sys.executable).parent / "enc")
    elif argv[0] == "enc-nightly":
        argv[0] = str(ROOT / "bin" / "enc-nightly")
    return argv


#: a case's ``limits`` keys: the resource limit each sets in the command's process
LIMITS = {"fsize": resource.RLIMIT_FSIZE, "nofile": resource.RLIMIT_NOFILE,
          "cpu": resource.RLIMIT_CPU}
#: seconds of CPU between a case's ``cpu`` limit (SIGXCPU) and the hard one (SIGKILL)
CPU_GRACE = 10


def limit_pair(key: str, value: int) -> tuple[int, int]:
    """The (soft, hard) limit a case's ``limits`` key sets: both ``value``, as ``ulimit``
    sets them, but for ``cpu``, whose hard limit is SIGKILL's: ``ulimit -St`` then."""
    return (value, value + CPU_GRACE) if key == "cpu" else (value, value)


def _limits(case: Case) -> Callable[[], None]:
    """What the child runs before the command: the address-space limit, and the case's
    own (``limits = {fsize = BYTES, nofile = N, cpu = S}``, as ``ulimit -f``/``-n``/``-St``
    set them)."""
    def apply() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_LIMIT, ADDRESS_LIMIT))
        for key, value in case.limits.items():
            resource.setrlimit(LIMITS[key], limit_pair(key, value))
    return apply


def _send_signal(case: Case, pid: int, folder: Path) -> None:
    """Once the signal's ``when`` glob matches in the folder (or at once), wait ``delay``
    seconds and send it to ``pid`` (which passes it on to the command)."""
    assert case.signal is not None
    deadline = time.monotonic() + case.timeout / 2
    when = case.signal.get("when")
    while when and not list(folder.glob(when)) and time.monotonic() < deadline:
        time.sleep(0.005)
    time.sleep(float(case.signal.get("delay", 0.0)))
    with contextlib.suppress(ProcessLookupError):  # not send_signal: it reaps an ended child
        os.kill(pid, signal_number(case.signal["sig"]))


def signal_number(name: str) -> int:
    """A signal by its name without SIG, as kill(1) takes it: HUP, XCPU, RTMIN+3, RTMAX."""
    rt = re.fullmatch(r"RT(MIN|MAX)([+-][0-9]+)?", name)
    if rt:
        return int(signal.SIGRTMIN if rt[1] == "MIN" else signal.SIGRTMAX) + int(rt[2] or 0)
    return int(getattr(signal, f"SIG{name}"))


def forked(case: Case) -> bool:
    """Whether the case's command is forked from the zygote: an ``enc`` command, unless
    ``ENC_CATALOGUE_EXEC=1`` asks for every command to be started by exec."""
    return (case.argv is not None and case.argv[0] == "enc"
            and os.environ.get("ENC_CATALOGUE_EXEC", "") in ("", "0"))


def run(case: Case, folder: Path, base: Path) -> Result:
    """Run the case's command in ``folder`` and wait for it (killed at its timeout)."""
    stdin = open(folder / case.stdin, "rb") if case.stdin else open(os.devnull, "rb")  # noqa: SIM115
    report, write_end = os.pipe()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err, stdin:
        start = time.monotonic()
        argv = command_line(case, folder, base)
        if forked(case):
            pid = zygote.start(argv, folder, _env(case), {"as": ADDRESS_LIMIT, **case.limits},
                               [stdin.fileno(), out.fileno(), err.fileno(), write_end])
        else:
            pid = subprocess.Popen([sys.executable, "-I", "-S", str(PEAK), str(write_end),
                                    *argv], cwd=folder, env=_env(case), stdin=stdin, stdout=out,
                                   stderr=err, preexec_fn=_limits(case), start_new_session=True,
                                   pass_fds=(write_end,)).pid
        os.close(write_end)
        code, peak_kib, cpu_s, timed_out = _wait(case, pid, report, folder, not forked(case))
        seconds = time.monotonic() - start
        out.seek(0)
        err.seek(0)
        return Result(code, out.read(), err.read(), peak_kib / 1024, seconds, timed_out, cpu_s)


def _wait(case: Case, pid: int, report: int, folder: Path,
          child: bool) -> tuple[int, float, float, bool]:
    """Wait for the minder ``pid`` (peak.py, our ``child``; or the zygote's) to report the
    command's peak [KiB], CPU [s] (and, the zygote's, its wait status), killing the
    minder's group at the case's timeout."""
    timed_out = threading.Event()

    def kill() -> None:
        timed_out.set()
        with contextlib.suppress(ProcessLookupError):
            os.killpg(pid, signal.SIGKILL)

    timer = threading.Timer(case.timeout, kill)
    timer.start()
    try:
        if case.signal:
            _send_signal(case, pid, folder)
        with os.fdopen(report, "rb") as f:
            words = f.read().split()
        if child:
            _, status, _ = os.wait4(pid, 0)
            code = os.waitstatus_to_exitcode(status)
        else:  # killed at the timeout: no report
            code = os.waitstatus_to_exitcode(int(words[2])) if len(words) == 3 else -9
    finally:
        timer.cancel()
    with contextlib.suppress(ProcessLookupError):
        os.killpg(pid, signal.SIGKILL)  # what the command left running
    peak_kib, cpu_s = (float(x) for x in (words[:2] or [0, 0]))
    return code, peak_kib, cpu_s, timed_out.is_set()


# ------------------------------------------------------------------ the folder

def _digest(path: Path) -> str:
    st = os.lstat(path)
    if stat.S_ISREG(st.st_mode):
        return hashlib.sha256(path.read_bytes()).hexdigest()
    if stat.S_ISLNK(st.st_mode):
        return "link:" + os.readlink(path)
    return f"mode:{stat.S_IFMT(st.st_mode):o}"


def snapshot(folder: Path) -> dict[str, str]:
    """Every entry under the folder: its relative path -> what kind it is (not its content;
    a FIFO is never opened)."""
    out = {}
    for p in folder.rglob("*"):
        st = os.lstat(p)
        out[str(p.relative_to(folder))] = f"mode:{stat.S_IFMT(st.st_mode):o}"
    return out


def digests(folder: Path, names: list[str]) -> dict[str, str]:
    return {n: _digest(folder / n) for n in names}


# ------------------------------------------------------------------ the checks

def problems(case: Case, r: Result, folder: Path, before: dict[str, str],
             kept: dict[str, str], base: Path | None = None) -> list[str]:
    """What the case promised and the run did not do (empty: it passed)."""
    err = r.stderr.decode("utf-8", "replace")
    bad = []
    if r.timed_out:
        bad.append(f"timed out after {case.timeout:g} s")
    if r.code not in case.exit:
        bad.append(f"exit {r.code}, expected {' or '.join(map(str, case.exit))}")
    if r.peak_mb >= MAX_MB:
        bad.append(f"peak memory {r.peak_mb:.0f} MB >= {MAX_MB:.0f} MB")
    if "internal error" in err.lower() or "Traceback" in err:
        bad.append("an internal error or a traceback")
    if r.code not in (0, 1):
        lines = [ln for ln in err.splitlines() if "error:" in ln]
        want = f"{case.command()}: error: "
        if len(lines) != 1 or not lines[0].startswith(want):
            bad.append(f"not exactly one line starting {want!r}")
    if case.stderr and not re.search(case.stderr, err):
        bad.append(f"stderr does not match {case.stderr!r}")
    bad += _file_problems(case, r, folder, before, kept)
    if case.check:
        bad += _check(case, folder, base)
    for s in case.stdout_lacks:
        if s.encode() in r.stdout or s.encode() in r.stderr:
            bad.append(f"the output holds {s!r}")
    return bad


def _file_problems(case: Case, r: Result, folder: Path, before: dict[str, str],
                   kept: dict[str, str]) -> list[str]:
    bad = []
    bad += [f"{f} is missing" for f in case.files if not _exists(folder, f)]
    bad += [f"{f} exists" for f in case.absent if os.path.lexists(folder / f)]
    bad += [f"{f} was changed" for f, d in kept.items()
            if not os.path.lexists(folder / f) or _digest(folder / f) != d]
    temporaries = [str(p.relative_to(folder)) for p in folder.rglob(".*.tmp")]
    if temporaries:
        bad.append(f"temporary files left: {temporaries}")
    if r.code != 0:
        new = [p for p in sorted(set(snapshot(folder)) - set(before))
               if not any(fnmatch.fnmatch(p, f) or fnmatch.fnmatch(p, f"{f}/*")
                          or any(fnmatch.fnmatch(q, f) for q in _under(folder, p))
                          for f in case.files)]
        if new:
            bad.append(f"a failed command left {new}")
    for name in case.readable:
        bad += _unreadable(folder / name)
    for rule in case.file_lacks:
        p = folder / rule["file"]
        if p.exists() and re.search(rule["regex"], p.read_text("utf-8", "replace"), re.M):
            bad.append(f"{rule['file']} holds a line matching {rule['regex']!r}")
    return bad


def _check(case: Case, folder: Path, base: Path | None) -> list[str]:
    """The row's ``check``, a bash command run in the folder right after the case: what
    the command left (a process it should have stopped, a file's mode, the history's
    status) told by its exit status."""
    assert case.check is not None
    script = _subs(case.check, folder, base or folder)
    try:
        r = subprocess.run(["/bin/bash", "-o", "pipefail", "-c", script], cwd=folder,
                           env=_env(case), capture_output=True, timeout=60)
    except subprocess.TimeoutExpired:
        return [f"check {case.check!r} timed out"]
    if r.returncode != 0:
        said = (r.stdout + r.stderr).decode("utf-8", "replace").strip()[-300:]
        return [f"check {case.check!r} failed (exit {r.returncode}){': ' + said if said else ''}"]
    return []


def _exists(folder: Path, name: str) -> bool:
    """Whether ``name`` (a glob: ``hist/run-*.parquet``) names something in the folder."""
    return os.path.lexists(folder / name) or any(True for _ in folder.glob(name))


def _under(folder: Path, rel: str) -> list[str]:
    """The entries below a new folder (a failed command may leave a folder holding a file
    it is allowed to leave)."""
    p = folder / rel
    return [str(q.relative_to(folder)) for q in p.rglob("*")] if p.is_dir() else []


def _unreadable(path: Path) -> list[str]:
    """Nothing when ``path`` is a complete stream (no rows is complete: an interruption
    before the first batch); else what is wrong."""
    from enctools.data import streams
    from enctools.errors import EncError

    try:
        with streams.open_input(str(path)) as s:
            for _ in s.batches():
                pass
    except (EncError, OSError) as exc:
        return [f"{path.name} is not a readable stream: {exc}"]
    return []
