"""Shared fixtures: the enc executable, a runner for real subprocess pipelines, an
in-process runner for usage errors and small cases, and the simulator runs that several
files read, made once per test session (once across xdist workers too).

Tiers: ``make check`` runs the library's quick tests: neither ``slow`` nor ``command``
nor ``heavy`` (about 10 s on two quiet cores, the load printed first); ``make test`` runs
every test but the ``slow`` ones, ``make test-slow`` those (CI runs both). A test is
marked ``command`` here, at collection, when it runs a command or the simulator (itself,
through its module's helpers or a fixture); it is marked ``slow`` by hand when it runs a
full-size simulation, many subprocesses or a long in-process computation, ``heavy`` by
hand when it runs in process but takes over a tenth of a second on a quiet core (or is
the first of its file to pay for a scan or a render the others share).
"""

from __future__ import annotations

import contextlib
import fcntl
import importlib.util
import io
import logging
import os
import shlex
import signal
import subprocess
import sys
import tempfile
import threading
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DATA = Path(__file__).resolve().parent / "data"

# One BLAS thread in the test process and every command it starts, as the enc driver
# takes for itself (enctools/cli/tuning.py), unless the environment says otherwise: the
# library's tests run on two workers sharing two cores, and each worker's idle OpenBLAS
# threads spinning around small matrix products cost many times the work (fit-rbf's
# search and blocked hold-out on 48 points: 0.89 s of CPU against 0.043 s, on a loaded
# machine). Set before numpy is first imported (no plugin of the suite imports it).
if "OMP_NUM_THREADS" not in os.environ:
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
if "numpy" in sys.modules:  # a plugin imported it first: the setting came too late
    warnings.warn("numpy was imported before tests/conftest.py: OpenBLAS keeps its threads",
                  stacklevel=1)

# Compiled bytecode kept in the venv (pycache/) for the test processes and every command
# they start, when the environment says not to write it beside the sources
# (PYTHONDONTWRITEBYTECODE, as in this machine's shells) and names no place of its own:
# else each of the suite's thousands of commands compiled every enctools module it
# imports, ~0.1 s of CPU a command, a third of a catalogue case's. An installed enctools
# has its bytecode; nothing is written into the source tree.
if os.environ.get("PYTHONDONTWRITEBYTECODE") and "PYTHONPYCACHEPREFIX" not in os.environ \
        and sys.prefix != sys.base_prefix:
    del os.environ["PYTHONDONTWRITEBYTECODE"]
    os.environ["PYTHONPYCACHEPREFIX"] = sys.pycache_prefix = str(Path(sys.prefix) / "pycache")
    sys.dont_write_bytecode = False

# A shell starts a background job (CI's runner may be one) with SIGINT and SIGQUIT
# ignored, and the commands keep a signal they were started with ignored (nohup, a
# background job: errors.ending_signals). The suite's commands are stopped as from a
# terminal: those signals go back to their defaults here, for the commands started below.
for _sig in (signal.SIGINT, signal.SIGQUIT, signal.SIGHUP):
    if signal.getsignal(_sig) == signal.SIG_IGN:
        signal.signal(_sig, signal.default_int_handler if _sig == signal.SIGINT
                      else signal.SIG_DFL)


def enc_exe() -> str:
    """The enc executable of this environment (the venv's console script)."""
    exe = Path(sys.executable).parent / "enc"
    if not exe.exists():
        pytest.fail(f"enc is not installed beside {sys.executable}; run make test")
    return str(exe)


def skip_without(module: str) -> None:
    """Skip the calling test module when ``module`` is not installed, without importing it
    (``pytest.importorskip`` imports it: moto costs each worker's collection 0.5 s of CPU,
    in every tier, ``make check`` too, where no test of that module runs)."""
    if importlib.util.find_spec(module) is None:
        pytest.skip(f"{module} is not installed", allow_module_level=True)


@pytest.fixture(scope="session")
def enc() -> str:
    return enc_exe()


@pytest.fixture(params=["compiled", "numpy"])
def kernel_path(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """Run the test with the compiled kernel (skipped where it is not built) and with the
    numpy passes (ENCTOOLS_KERNEL=numpy, for this process and the commands it starts)."""
    from enctools import kernel

    kernel.library.cache_clear()
    if request.param == "numpy":
        monkeypatch.setenv(kernel.ENV, "numpy")
    else:
        monkeypatch.delenv(kernel.ENV, raising=False)
        if kernel.library() is None:
            pytest.skip("the compiled kernel is not built here")
    request.addfinalizer(kernel.library.cache_clear)
    return str(request.param)


def run(cmd: str | list[str], cwd: Path | None = None, input: bytes | None = None,
        env: dict[str, str] | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run a command (a shell pipeline when given a string) with enc on PATH.

    The command runs in a process group of its own: at its ``timeout`` [s] (or when the
    test is interrupted) the whole group is killed, the commands a shell started with
    it, not the shell alone (``subprocess.run`` kills only its child: the pipeline's
    commands were left running, orphans holding the output pipes)."""
    e = dict(os.environ)
    e["PATH"] = f"{Path(enc_exe()).parent}{os.pathsep}{e.get('PATH', '')}"
    e.pop("ENC_DEBUG", None)
    if env:
        e.update(env)
    shell = isinstance(cmd, str)
    with subprocess.Popen(cmd, shell=shell, cwd=cwd, env=e, process_group=0,
                          stdin=subprocess.PIPE if input is not None else None,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          executable="/bin/bash" if shell else None) as proc:
        try:
            out, err = proc.communicate(input, timeout=timeout)
        except BaseException:  # the timeout, or the test interrupted: none left running
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            raise
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


# ------------------------------------------------------------------ in-process runner

@contextlib.contextmanager
def _as_a_process(stdin: io.TextIOWrapper, stdout: io.TextIOWrapper,
                  stderr: io.TextIOWrapper, env: dict[str, str] | None,
                  cwd: Path | None) -> Iterator[None]:
    """Standard streams, environment, cwd, signal handlers, logging and warning filters as
    a fresh ``enc`` process has them; everything put back afterwards (enc-nightly ends by
    ignoring the ending signals: left so, the commands started later would inherit it)."""
    from enctools.cli import runner
    from enctools.errors import ending_signal_numbers

    saved_streams = sys.stdin, sys.stdout, sys.stderr
    saved_env = dict(os.environ)
    saved_cwd = os.getcwd()
    saved_signals = {sig: signal.getsignal(sig) for sig in ending_signal_numbers()}
    saved_state = dict(getattr(runner, "_state", {}))
    log = logging.getLogger("enctools")
    saved_log = log.handlers[:], log.level, log.propagate
    os.environ.pop("ENC_DEBUG", None)
    os.environ.update(env or {})
    try:
        if cwd is not None:
            os.chdir(cwd)
        sys.stdin, sys.stdout, sys.stderr = stdin, stdout, stderr
        with warnings.catch_warnings():
            _fresh_warning_filters()
            warnings.showwarning = _show_on_stderr
            yield
    finally:
        sys.stdin, sys.stdout, sys.stderr = saved_streams
        os.environ.clear()
        os.environ.update(saved_env)
        os.chdir(saved_cwd)
        for sig, handler in saved_signals.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)
        if hasattr(runner, "_state"):
            runner._state.clear()
            runner._state.update(saved_state)
        log.handlers[:], log.level, log.propagate = saved_log


def _fresh_warning_filters() -> None:
    """The warning filters of a fresh interpreter (pytest's would hide what enc shows)."""
    warnings.resetwarnings()
    for category in (ResourceWarning, ImportWarning, PendingDeprecationWarning,
                     DeprecationWarning):
        warnings.filterwarnings("ignore", category=category)
    warnings.filterwarnings("default", category=DeprecationWarning, module="__main__")


def _show_on_stderr(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                    file: object = None, line: str | None = None) -> None:
    sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))


class _Captured(io.BytesIO):
    """A captured stdout/stderr; closing it (as a command may close its output) keeps what
    was written."""

    def close(self) -> None:
        pass


def _exit_status(main: Callable[[list[str]], None], argv: list[str]) -> int:
    """The status ``main(argv)`` exits with, as the interpreter would make it."""
    try:
        main(argv)
    except SystemExit as exc:
        if exc.code is None or isinstance(exc.code, int):
            return exc.code or 0
        sys.stderr.write(f"{exc.code}\n")
        return 1
    return 0


def run_in_process(args: str | list[str], input: bytes | None = None,
                   env: dict[str, str] | None = None,
                   cwd: Path | None = None) -> subprocess.CompletedProcess:
    """Run one ``enc`` command inside this process; the result reads like :func:`run`'s.

    ``args``: the command line (``"enc info x.parquet"`` or a list, with or without the
    leading ``enc``); no shell, no pipes. stdin holds ``input`` (empty by default, like
    /dev/null); stdout and stderr are captured as bytes; the exit status is the one
    ``enctools.cli.main.main`` ends with. For usage errors and small cases: it saves the
    interpreter's start-up (~0.3 s a command). Pipelines and signals need :func:`run`.
    """
    from enctools.cli.main import main

    if threading.current_thread() is not threading.main_thread():
        pytest.fail("in-process commands install a SIGTERM handler: they need the main "
                    "thread (pytest-xdist >= 3.6 runs the tests there)")
    argv = shlex.split(args) if isinstance(args, str) else [str(a) for a in args]
    if argv[:1] == ["enc"]:
        argv = argv[1:]
    out, err = _Captured(), _Captured()
    with tempfile.TemporaryFile() as raw_in:
        raw_in.write(input or b"")
        raw_in.seek(0)
        stdin, stdout, stderr = (io.TextIOWrapper(f, encoding="utf-8", write_through=True)
                                 for f in (raw_in, out, err))
        with _as_a_process(stdin, stdout, stderr, env, cwd):
            code = _exit_status(main, argv)
            sys.stdout.flush()
            sys.stderr.flush()
        for stream in (stdin, stdout, stderr):
            stream.detach()
    return subprocess.CompletedProcess(["enc", *argv], code, out.getvalue(), err.getvalue())


def one_error_line(r: subprocess.CompletedProcess, code: int, cmd: str = "enc acquire") -> str:
    """The one error line of a failed command (warnings, e.g. logged retries, may precede it)."""
    err = r.stderr.decode()
    assert r.returncode == code, err
    lines = [ln for ln in err.splitlines() if "error:" in ln]
    assert len(lines) == 1 and lines[0].startswith(f"{cmd}: error: "), err
    assert "Traceback" not in err
    return lines[0]


# ------------------------------------------------------------- shared simulator runs


def _shared_dir(factory: pytest.TempPathFactory) -> Path:
    """A folder every xdist worker of this session sees (the session's base temp's parent
    under xdist, the base temp itself without)."""
    base = factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


def made_once(factory: pytest.TempPathFactory, name: str, make: Callable[[Path], None]) -> Path:
    """``name`` in the shared folder, made by ``make(path)`` by the first worker that asks
    (the others wait for it on a lock): each simulator run once per test session."""
    path = _shared_dir(factory) / "shared" / name
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.parent / f".{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not path.exists():
            make(path)
    return path


def _acquire(*args: str) -> Callable[[Path], None]:
    """``enc acquire ARGS -o PATH`` (the file appears only once complete)."""
    def make(path: Path) -> None:
        r = run(["enc", "acquire", *args, "-o", str(path)])
        assert r.returncode == 0, r.stderr.decode()
    return make


@pytest.fixture(scope="session")
def sjtu_raw(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The default sjtu-dual run (20 revolutions, 9 heads) as Parquet."""
    return made_once(tmp_path_factory, "sjtu-raw.parquet", _acquire("--rig", "sjtu-dual"))


@pytest.fixture(scope="session")
def ciomp_steps(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The default ciomp-23bit polygon run (24 positions) as Parquet."""
    return made_once(tmp_path_factory, "ciomp-steps.parquet",
                     _acquire("--rig", "ciomp-23bit", "--mode", "steps"))


# ------------------------------------------------------------ in-process simulation

def simulate(rig_name: str, seed: int, **given) -> tuple:
    """A run of a bundled rig simulated in-process: (header, list of batches); ``given``
    are acquisition settings as options name them (revolutions, interval_s, heads...)."""
    from enctools.data.rig import load_rig
    from enctools.hw import acquire as acq
    from enctools.hw import open_session

    rig = load_rig(rig_name)
    s = acq.resolve(rig, {**given, "seed": seed})
    with open_session(rig, seed=seed) as session:
        header, batches = acq.acquire(rig, session, s)
        return header, list(batches)


# ------------------------------------------------------------------ a full disk

@contextlib.contextmanager
def small_tmpfs(mnt: Path, size: str) -> Iterator[Path]:
    """A tmpfs of ``size`` ("64k") mounted on a new folder ``mnt`` (root and mount
    permitted; the test is skipped otherwise), unmounted afterwards."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(mnt)],
                      capture_output=True).returncode != 0:
        pytest.skip("mount is not permitted here")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


@pytest.fixture
def full_tmpfs(tmp_path):
    """A small tmpfs, filled up, with an empty folder ``h`` in it."""
    with small_tmpfs(tmp_path / "full", "256k") as mnt:
        (mnt / "h").mkdir()
        with open(mnt / "fill", "wb", buffering=0) as f, pytest.raises(OSError):
            while True:
                f.write(b"\0" * 4096)
        yield mnt


# ------------------------------------------------------------ the adversarial catalogue

def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:
    """One line on the catalogue's cases run (tests/test_adversarial*.py): how many per
    category and the largest peak memory, over all of them and over those that passed
    (each case's properties come back from the xdist workers in its report)."""
    per_category: dict[str, int] = {}
    peak: dict[str, tuple[float, str]] = {"all": (0.0, ""), "passed": (0.0, "")}
    seconds = cpu = 0.0
    for reports in terminalreporter.stats.values():
        for rep in reports:
            props = dict(getattr(rep, "user_properties", None) or [])
            if getattr(rep, "when", "") != "call" or "adv_id" not in props:
                continue
            cat = str(props["adv_category"])
            per_category[cat] = per_category.get(cat, 0) + 1
            seconds += float(props["adv_seconds"])
            cpu += float(props.get("adv_cpu_s", 0.0))
            mb, case = float(props["adv_peak_mb"]), str(props["adv_id"])
            for key in ("all", "passed") if rep.passed and not hasattr(rep, "wasxfail") \
                    else ("all",):
                if mb > peak[key][0]:
                    peak[key] = (mb, case)
    if per_category:
        cats = ", ".join(f"{k}: {v}" for k, v in sorted(per_category.items()))
        terminalreporter.write_line(
            f"adversarial catalogue: {sum(per_category.values())} cases ({cats}), "
            f"peak memory max {peak['all'][0]:.0f} MB in case {peak['all'][1]} "
            f"(of the passing cases: {peak['passed'][0]:.0f} MB in {peak['passed'][1]}); "
            f"children: {seconds:.0f} s, {cpu:.0f} s of CPU")


# ------------------------------------------------------------ where the time goes

#: ENCTOOLS_TEST_TIMES=FILE: every test's wall and CPU seconds appended to FILE, a JSON line
#: each (``make durations`` reads them into the README's table of the slowest tests)
_TIMES = os.environ.get("ENCTOOLS_TEST_TIMES")


def _cpu_seconds() -> tuple[float, float]:
    """CPU seconds (user + system) of this process and of the children it has waited for."""
    import resource

    own, kids = resource.getrusage(resource.RUSAGE_SELF), \
        resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime, kids.ru_utime + kids.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """With ENCTOOLS_TEST_TIMES, one line per test: its node id, tier, wall seconds and
    CPU seconds (setup, call and teardown; the commands it waited for included)."""
    if not _TIMES:
        yield
        return
    import json
    import time

    wall, (own, kids) = time.perf_counter(), _cpu_seconds()
    yield
    wall, (own2, kids2) = time.perf_counter() - wall, _cpu_seconds()
    tier = "slow" if item.get_closest_marker("slow") else \
        "heavy" if item.get_closest_marker("heavy") else "test"
    line = json.dumps({"test": item.nodeid, "tier": tier, "wall_s": round(wall, 4),
                       "cpu_s": round(own2 - own, 4), "children_cpu_s": round(kids2 - kids, 4),
                       "load": round(os.getloadavg()[0], 2)})
    with open(_TIMES, "a", encoding="utf-8") as f:  # one short write: whole in O_APPEND
        f.write(line + "\n")


# ------------------------------------------------------------ the tiers

#: calls that run a command (a subprocess, or enc in this process) or the simulator
COMMAND_CALLS = {"run", "run_in_process", "Popen", "check_output", "check_call", "simulate",
                 "made_once", "pty_run", "spawn"}
#: fixtures that run commands to make their files
COMMAND_FIXTURES = {"sjtu_raw", "ciomp_steps", "enc", "full_tmpfs"}
#: the key of the walks kept in pytest's cache (.pytest_cache): a file's runners are taken
#: from it while the file's bytes and the two sets above are unchanged
_RUNNERS_KEY = "enctools/command-runners"


def _command_runners(source: bytes) -> set[str]:
    """The functions of a test module (its ``source``) that run a command, directly or
    through the module's own helpers and fixtures (its call graph, closed)."""
    import ast

    tree = ast.parse(source)
    calls: dict[str, set[str]] = {}
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            names = {n.func.id if isinstance(n.func, ast.Name) else n.func.attr
                     for n in ast.walk(node) if isinstance(n, ast.Call)
                     and isinstance(n.func, (ast.Name, ast.Attribute))}
            names |= {a.arg for a in node.args.args}  # fixtures it asks for
            calls[node.name] = calls.get(node.name, set()) | names
    runners = {f for f, names in calls.items() if names & (COMMAND_CALLS | COMMAND_FIXTURES)}
    while True:
        more = {f for f, names in calls.items() if names & runners} - runners
        if not more:
            break
        runners |= more
    return runners


def _runners_by_file(config: pytest.Config, paths: set[str]) -> dict[str, set[str]]:
    """:func:`_command_runners` of each test module, walked again only when its bytes have
    changed since pytest's cache kept the walk: the walk of the suite's 131 modules costs
    each xdist worker 0.6 s of CPU at every ``make check``, reading and hashing them 0.01 s."""
    import hashlib

    cache = getattr(config, "cache", None)  # None with -p no:cacheprovider
    version = hashlib.sha256(repr((sorted(COMMAND_CALLS), sorted(COMMAND_FIXTURES)))
                             .encode()).hexdigest()[:16]
    kept = cache.get(_RUNNERS_KEY, {}) if cache is not None else {}
    files = kept.get("files", {}) if isinstance(kept, dict) and \
        kept.get("version") == version else {}
    out, changed = {}, False
    for path in paths:
        source = Path(path).read_bytes()
        digest = hashlib.blake2b(source, digest_size=16).hexdigest()
        entry = files.get(path)
        if not (isinstance(entry, list) and len(entry) == 2 and entry[0] == digest):
            entry, changed = [digest, sorted(_command_runners(source))], True
            files[path] = entry
        out[path] = set(entry[1])
    if changed and cache is not None:
        cache.set(_RUNNERS_KEY, {"version": version, "files": files})
    return out


@pytest.hookimpl(tryfirst=True)  # before xdist reads the groups (its hook names them)
def pytest_collection_modifyitems(config, items) -> None:
    """Mark ``command`` each test that runs a command or the simulator (itself, through
    its module's helpers, or through a fixture that does), when the marker expression
    names ``command``: ``make check`` leaves them out with the ``slow`` and ``heavy``
    ones, keeping the library's quick tests. Then group the tests
    for the two workers (:func:`_group_for_workers`)."""
    # read by the marker expression alone (make check's): 0.6 s of CPU a worker otherwise
    if "command" in (config.getoption("markexpr", "") or ""):
        by_file = _runners_by_file(config, {str(item.path) for item in items})
        for item in items:
            function = getattr(item, "originalname", None) or item.name.split("[")[0]
            runners = by_file[str(item.path)]
            if function in runners or set(item.fixturenames) & (COMMAND_FIXTURES | runners):
                item.add_marker(pytest.mark.command)
    # a worker's own option says "no": xdist tells it of loadgroup by option.loadgroup
    if config.getoption("dist", "no") == "loadgroup" or getattr(config.option, "loadgroup",
                                                                 False):
        _group_for_workers(items)


@pytest.hookimpl(wrapper=True)
def pytest_collection(session) -> Iterator[object]:
    """Collection without the cyclic garbage collector, whose objects are then frozen
    (``gc.freeze``): importing the test modules and the libraries they test leaves some
    200,000 objects that live as long as the process, and every full collection walked
    them all again, during collection and then through the tests (0.5 to 0.9 s of CPU a
    process in ``make check``; 0.1 s each at pytest's last collections). The garbage of
    the tests themselves is collected as before, with the thresholds left as they were."""
    import gc

    enabled = gc.isenabled()
    gc.disable()
    try:
        return (yield)
    finally:
        gc.freeze()
        if enabled:
            gc.enable()


# ------------------------------------------------------------ two workers, no tail

class _GroupsTaken:
    """Fails the run at collection when ``--dist loadgroup`` would not group: xdist marks a
    grouped test by a suffix of its node id (``...::test@group``), which pytest 9.2 no
    longer takes (pytest-dev/pytest-xdist#1386). Without this check the tests of a file
    that share a fixture spread over both workers and make it twice, silently."""

    @pytest.hookimpl(trylast=True)
    def pytest_collection_modifyitems(self, config, items) -> None:
        if not getattr(config.option, "loadgroup", False):
            return
        lost = [i.nodeid for i in items if i.get_closest_marker("xdist_group")
                and "@" not in i.nodeid]
        if lost:
            msg = (f"--dist loadgroup does not group {len(lost)} test(s), e.g. {lost[0]}: "
                   f"pytest {pytest.__version__} with this pytest-xdist drops the group "
                   "(pytest-dev/pytest-xdist#1386); install the versions pyproject.toml allows")
            raise pytest.UsageError(msg)


def pytest_configure(config) -> None:
    config.pluginmanager.register(_GroupsTaken(), "enctools-groups-taken")



#: the scopes of a fixture made once for several tests of one file
_FILE_SCOPES = {"module", "class", "package"}


def _shares_a_file_fixture(item: pytest.Item) -> bool:
    """Whether the test uses a fixture made once for its module (or class): a simulator
    run, a fitted model..."""
    info = getattr(item, "_fixtureinfo", None)
    return info is not None and any(
        d.scope in _FILE_SCOPES for defs in info.name2fixturedefs.values() for d in defs)


def _group_for_workers(items: list[pytest.Item]) -> None:
    """``--dist loadgroup`` (make test): the tests of a file that share a module's fixture
    go to one worker together (``xdist_group`` named by the file: the fixture is made
    once), every other test is a unit of its own, the catalogue's cases included, so the
    two workers share every file and neither waits for the other at the end. The slow
    tests come first, those of small families before the catalogue's hundreds of short
    cases, so no long test starts last (xdist hands the groups out first, then the single
    tests in this order)."""
    family: dict[tuple[str, str], int] = {}
    for item in items:
        if _shares_a_file_fixture(item):
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
        key = (str(item.path), getattr(item, "originalname", item.name))
        family[key] = family.get(key, 0) + 1
    items.sort(key=lambda item: (item.get_closest_marker("slow") is None,
                                 family[str(item.path), getattr(item, "originalname",
                                                                item.name)]))
