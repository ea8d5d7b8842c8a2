"""enc-nightly's campaigns (:class:`enctools.report.nightly.Campaign`): the default one run
in this process through the library, a user's script run as a process of its own."""

from __future__ import annotations

import contextlib
import os
import subprocess
from pathlib import Path

from enctools.report.nightly import RESULT, Campaign, CampaignFailed, signals_held

#: what the default campaign does, said as the pipeline it stands for (the history's
#: ``campaign`` of a night that ran it)
DEFAULT_TEXT = 'enc acquire --rig "$RIG" --mode steps | enc points -o "$OUT/result.parquet"'


def polygon_check(rig: str, folder: Path, run_id: str) -> None:
    """The default campaign, the polygon check of seed 001, as ``enc acquire --rig RIG
    --mode steps | enc points`` does it: a step run on ``rig`` (its own settings), its
    points written to ``folder``/result.parquet."""
    from enctools.data import streams
    from enctools.data.rig import load_rig
    from enctools.hw import acquire, open_session, recording
    from enctools.methods import points

    rig_ = load_rig(rig)
    settings = acquire.resolve(rig_, {"mode": "steps"})
    readings = folder / "readings.arrows"  # the pipe's stream, removed once read
    with open_session(rig_, seed=settings.seed, signals=bool(settings.signals)) as session:
        header, batches = acquire.acquire(rig_, session, settings)
        outs = recording.open_outputs(streams.with_history(header), [(str(readings), None)],
                                      force=True)
        recording.record(batches, outs)
    try:
        header, found = points.make_points(streams.open_input(str(readings), "readings"),
                                           points.Settings())
        streams.write_table(str(folder / RESULT), streams.with_history(header), found.table(),
                            force=True)
    finally:
        readings.unlink(missing_ok=True)


DEFAULT = Campaign(polygon_check, DEFAULT_TEXT)


def script(command: str, timeout_s: float | None = None) -> Campaign:
    """A user's campaign: a shell command with ``RIG``, ``OUT`` (the night's folder) and
    ``ENC_NIGHTLY_RUN`` in its environment that leaves ``$OUT/result.parquet``; run in a
    process group of its own, stopped whole when the night is (a signal) or after
    ``timeout_s`` [s] (None: no limit)."""
    def run(rig: str, folder: Path, run_id: str) -> None:
        env = dict(os.environ, RIG=rig, OUT=str(folder), ENC_NIGHTLY_RUN=run_id)
        code, err = run_script(command, env, timeout_s)
        if code:
            last = (err.decode(errors="replace").strip().splitlines() or ["-"])[-1]
            raise CampaignFailed(f"campaign failed with exit {code}: {last}", code)

    return Campaign(run, command)


def run_script(command: str, env: dict[str, str], timeout_s: float | None = None
               ) -> tuple[int, bytes]:
    """Run a shell command in a process group of its own; its status and stderr.

    Whatever stops the wait (SIGTERM, SIGINT, ``timeout_s`` run out) stops the whole
    campaign first, every process of its pipeline: SIGTERM, then SIGKILL for those still
    there after 5 s. A timeout is a :class:`CampaignFailed` of exit 3 (a device that no
    longer answers, most often).
    """
    proc: subprocess.Popen[bytes] | None = None
    try:
        with signals_held():  # a signal is acted on once ``proc`` is known
            proc = subprocess.Popen(["/bin/bash", "-o", "pipefail", "-c", command], env=env,
                                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.PIPE, start_new_session=True)
        _, err = proc.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        assert proc is not None  # the wait timed out: it was started
        with signals_held():
            stop_group(proc)
        msg = f"campaign stopped after {timeout_s:g} s (its time limit)"
        raise CampaignFailed(msg, 3) from None
    except BaseException:
        if proc is not None:
            with signals_held():
                stop_group(proc)
        raise
    return proc.returncode, err


def stop_group(proc: subprocess.Popen[bytes]) -> None:
    """SIGTERM to the process group of ``proc``, SIGKILL to what is left after 5 s."""
    import signal
    import time

    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGTERM)
    deadline = time.monotonic() + 5.0
    with contextlib.suppress(subprocess.TimeoutExpired):
        proc.wait(timeout=5.0)
    while time.monotonic() < deadline:
        try:
            os.killpg(proc.pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.05)
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    if proc.stderr is not None:
        proc.stderr.close()
