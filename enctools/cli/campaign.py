"""enc-nightly's campaigns (:class:`enctools.report.nightly.Campaign`): the default one run
in this process through the library, a user's script run as a process of its own."""

from __future__ import annotations

import contextlib
import os
import subprocess
from pathlib import Path

from enctools.errors import signals_held
from enctools.report.nightly import (
    RESULT,
    WORK_LOCK,
    Campaign,
    CampaignFailed,
    record_campaign,
)

#: what the default campaign does, said as the pipeline it stands for (the history's
#: ``campaign`` of a night that ran it)
DEFAULT_TEXT = 'enc acquire --rig "$RIG" --mode steps | enc points -o "$OUT/result.parquet"'


def polygon_check(rig: str, folder: Path, run_id: str) -> None:
    """The default campaign, the polygon check of seed 001, as ``enc acquire --rig RIG
    --mode steps | enc points`` does it: a step run on ``rig`` (its own settings), its
    points written to ``folder``/result.parquet, each stream's history recording the
    command it stands for (not enc-nightly's own line)."""
    from enctools.data import streams
    from enctools.data.header import history_line
    from enctools.data.rig import load_rig
    from enctools.hw import acquire, backends, open_session, recording
    from enctools.methods import points

    rig_ = load_rig(rig)
    settings = acquire.resolve(rig_, {"mode": "steps"})
    readings = folder / "readings.arrows"  # the pipe's stream, removed once read
    with open_session(rig_, seed=settings.seed, signals=bool(settings.signals)) as session:
        header, batches = acquire.acquire(rig_, session, settings)
        measured = not backends.of_rig(rig_).simulated  # a device's run keeps its time
        line = history_line(["enc", "acquire", "--rig", rig, "--mode", "steps"],
                            output=str(readings), measured=measured)
        header = streams.with_history(header, line, output=str(readings))
        outs = recording.open_outputs(header, [(str(readings), None)], force=True)
        recording.record(batches, outs)
    try:
        header, found = points.make_points(streams.open_input(str(readings), "readings"),
                                           points.Settings())
        result = str(folder / RESULT)
        line = history_line(["enc", "points", "-o", result], output=result)
        header = streams.with_history(header, line, output=result, read=(str(readings),))
        streams.write_table(result, header, found.table(), force=True)
    finally:
        readings.unlink(missing_ok=True)


DEFAULT = Campaign(polygon_check, DEFAULT_TEXT)


def script(command: str, timeout_s: float | None = None) -> Campaign:
    """A user's campaign: a shell command with ``RIG``, ``OUT`` (the night's folder) and
    ``ENC_NIGHTLY_RUN`` in its environment that leaves ``$OUT/result.parquet``; run in a
    process group of its own, stopped whole once its first process ends, when the night
    is (a signal) or after ``timeout_s`` [s] (None: no limit): :func:`run_script`."""
    def run(rig: str, folder: Path, run_id: str) -> None:
        env = dict(os.environ, RIG=rig, OUT=str(folder), ENC_NIGHTLY_RUN=run_id)
        lock = folder / WORK_LOCK
        code, err = run_script(command, env, timeout_s, lock if lock.exists() else None)
        if code:
            last = (err.decode(errors="replace").strip().splitlines() or ["-"])[-1]
            raise CampaignFailed(f"campaign failed with exit {code}: {last}", code)

    return Campaign(run, command)


#: how long a campaign's processes have to end after SIGTERM before SIGKILL [s]
GRACE_S = 5.0
#: the most of a campaign's stderr kept for its error line [bytes]
STDERR_TAIL = 1 << 16


def _started(command: str, env: dict[str, str], lock: Path | None
             ) -> tuple[subprocess.Popen[bytes], StderrTail]:
    """The campaign's shell, started in a process group of its own and its stderr read;
    the group told to ``lock`` before the shell is let go to run ``command`` (it waits for
    the word on a pipe, then becomes ``bash -o pipefail -c command``, the same process).
    A night killed before the word leaves a shell that ends without running anything."""
    go_r, go_w = os.pipe()
    try:
        waited = (f"read -r -u {go_r} _ || exit 1; exec {go_r}<&-; "
                  'exec /bin/bash -o pipefail -c "$1"')
        proc = subprocess.Popen(["/bin/bash", "-c", waited, "/bin/bash", command], env=env,
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, start_new_session=True,
                                pass_fds=(go_r,))
    except BaseException:
        os.close(go_w)
        raise
    finally:
        os.close(go_r)
    try:                 # on an error here the shell, given no word, ends on its own
        tail = StderrTail(proc)
        if lock is not None:
            record_campaign(lock, proc.pid)
        with contextlib.suppress(BrokenPipeError):  # a shell already ended (bad syntax)
            os.write(go_w, b"\n")
    finally:
        os.close(go_w)
    return proc, tail


def run_script(command: str, env: dict[str, str], timeout_s: float | None = None,
               lock: Path | None = None) -> tuple[int, bytes]:
    """Run a shell command in a process group of its own; its status and (the end of) its
    stderr.

    The night waits for the command's first process, never for its stderr to close: a
    process the campaign left in the background may hold it open for hours. Whatever
    ends the wait (that process ending, a signal, ``timeout_s`` run out) stops the whole
    group, every process of its pipelines and what they left running: SIGTERM, then
    SIGKILL for those still there after :data:`GRACE_S`. A timeout is a
    :class:`CampaignFailed` of exit 3 (a device that no longer answers, most often).
    ``lock``: the night's lock file, told the group (a ``kill -9`` of the night leaves it
    for the next night to stop). The command starts only once the group is told
    (:func:`_started`).
    """
    proc: subprocess.Popen[bytes] | None = None
    tail: StderrTail | None = None
    try:
        with signals_held():  # a signal is acted on once ``proc`` is known
            proc, tail = _started(command, env, lock)
        code: int | None = proc.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        code = None
    except BaseException:
        if proc is not None:
            with signals_held():
                stop_group(proc)
                if tail is not None:
                    tail.close()
        raise
    assert proc is not None and tail is not None  # the process was started
    with signals_held():
        left = stop_group(proc)
        err = tail.close()
    if code is None:
        msg = f"campaign stopped after {timeout_s:g} s (its time limit)"
        raise CampaignFailed(msg, 3, status="timeout")
    if left:
        import logging

        logging.getLogger("enctools").warning("the campaign left processes running; "
                                              "they were stopped with it")
    return code, err


def stop_group(proc: subprocess.Popen[bytes]) -> bool:
    """Stop the process group of ``proc``: SIGTERM, SIGKILL to what is left after
    :data:`GRACE_S`; True when something of it was still running."""
    import signal

    if not _group_alive(proc):
        return False
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signal.SIGTERM)
    if not _group_ends(proc, GRACE_S):
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, signal.SIGKILL)
        _group_ends(proc, 2.0)
    return True


def _group_ends(proc: subprocess.Popen[bytes], within_s: float) -> bool:
    """True once no process of ``proc``'s group is left (within ``within_s`` [s])."""
    import time

    deadline = time.monotonic() + within_s
    while _group_alive(proc):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


def _group_alive(proc: subprocess.Popen[bytes]) -> bool:
    """Whether a process of ``proc``'s group still runs; its ended processes that are this
    process's children (``proc``, and orphans adopted: :func:`adopt_orphans`) are reaped
    first, so that no zombie counts."""
    proc.poll()
    with contextlib.suppress(ChildProcessError):
        while os.waitpid(-proc.pid, os.WNOHANG)[0]:
            pass
    try:
        os.killpg(proc.pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # a process of the group this user cannot signal
        return True
    return True


_ADOPTING: list[bool] = []


def adopt_orphans() -> None:
    """Make this process the reaper of its orphaned descendants (Linux's child subreaper):
    a process a campaign left running becomes this process's child when its parent ends,
    so that once stopped it is reaped here, not left a zombie of a process 1 that reaps
    nothing (a container's), which would keep its group counted as alive. Elsewhere,
    nothing. For enc-nightly's own process only: in a program that calls the library,
    every orphan of its other children would come to it too."""
    if _ADOPTING or not os.path.exists("/proc/self"):
        return
    import ctypes

    _ADOPTING.append(True)
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)  # PR_SET_CHILD_SUBREAPER


class StderrTail:
    """The end of a process's stderr (its last :data:`STDERR_TAIL` bytes), read by a
    thread of its own as it comes, so that the campaign never blocks on a full pipe and
    the night never waits for the pipe to close."""

    def __init__(self, proc: subprocess.Popen[bytes]) -> None:
        import threading

        assert proc.stderr is not None
        self._pipe = proc.stderr
        self._data = bytearray()
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._read, name="campaign-stderr",
                                        daemon=True)
        self._thread.start()

    def _read(self) -> None:
        import select

        fd = self._pipe.fileno()
        while True:
            ready, _, _ = select.select([fd], [], [], 0.1)
            if not ready:
                if self._done.is_set():
                    return
                continue
            chunk = os.read(fd, 65536)
            if not chunk:
                return
            self._data += chunk
            del self._data[:-STDERR_TAIL]

    def close(self) -> bytes:
        """What was read (the group is stopped: the rest is there or never comes)."""
        self._done.set()
        self._thread.join(timeout=1.0)
        if not self._thread.is_alive():
            self._pipe.close()
        return bytes(self._data)
