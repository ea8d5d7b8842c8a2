"""enc acquire: read a rig into a readings stream (continuous, steps or sweep; or replay)."""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator
from typing import Any

import click

from enctools.cli import options, runner


@click.command("acquire")
@options.rig
@click.option("--mode", type=click.Choice(["continuous", "steps", "sweep"]), default=None,
              help="continuous: turn and sample; steps: target positions; sweep: fine steps.")
@click.option("--revolutions", type=float, default=None, callback=options.positive,
              help="continuous: revolutions to record.")
@click.option("--speed", "speed_rpm", type=float, default=None, metavar="RPM",
              help="continuous: speed [r/min]; negative turns backwards.")
@click.option("--interval", "interval_s", type=float, default=None, callback=options.positive,
              help="continuous: sample interval [s].")
@click.option("--positions", "positions_deg", default=None, callback=options.float_list,
              metavar="DEG,DEG,...", help="steps: target positions [deg].")
@click.option("--count", type=int, default=None, callback=options.positive,
              help="steps: N positions equally spaced over a turn (when --positions is absent).")
@click.option("--settle", "settle_s", type=float, default=None,
              help="steps/sweep: settling time [s].")
@click.option("--readings", type=int, default=None, callback=options.positive,
              help="steps/sweep: readings per position.")
@click.option("--runs", type=int, default=None, callback=options.positive,
              help="steps/sweep: number of runs.")
@click.option("--bidirectional/--unidirectional", default=None,
              help="steps: also approach every position from above.")
@click.option("--overshoot", "overshoot_deg", type=float, default=None,
              callback=options.non_negative,
              help="steps: approach each position from this far [deg].")
@click.option("--start", "start_deg", type=float, default=None, callback=options.finite,
              help="sweep (and steps with --count): first position [deg].")
@click.option("--range", "range_arcsec", type=float, default=None, help="sweep: range [arcsec].")
@click.option("--step", "step_arcsec", type=float, default=None, help="sweep: step [arcsec].")
@options.heads("Record only these heads (default: all).")
@click.option("--signals/--no-signals", default=None,
              help="Also record each head's raw sin/cos signals [V] (simulator).")
@click.option("--seed", type=click.IntRange(0, (1 << 63) - 1), default=None,
              help="Simulator noise seed (default: the rig's).")
@click.option("--replay", "replay_path", default=None,
              type=click.Path(dir_okay=False, allow_dash=True),
              help="Re-stream a recorded readings file instead of acquiring.")
@click.option("--pace", is_flag=True, default=False,
              help="replay: at the recorded pace (default: as fast as possible).")
@click.option("--realtime", is_flag=True, default=False,
              help="Simulator: run at wall-clock pace (live pipelines, interrupt drills).")
@click.option("--timeout", "timeout_s", type=click.FloatRange(0.001, 3600), default=None,
              help="Instruments: seconds to wait for each reply (default: the rig's, 1).")
@click.option("--retries", type=click.IntRange(0, 100), default=None,
              help="Instruments: retries after a timeout before giving up (default: the rig's, 2).")
@click.option("--tee", "tee_path", default=None, metavar="FILE", type=click.Path(dir_okay=False),
              help="Also keep a copy of the stream in FILE (format from its extension).")
@options.outputs
@options.verbosity
def command(rig: str | None, replay_path: str | None, pace: bool, realtime: bool,
            timeout_s: float | None, retries: int | None, tee_path: str | None,
            output: str | None, force: bool, fmt: str | None, **given: Any) -> None:
    """Acquire readings from a rig and write them as a readings stream.

    Defaults come from the rig file's [acquire] tables: `enc acquire --rig sjtu-dual`
    records 20 revolutions at 1 r/min every 3 ms; `enc acquire --rig ciomp-23bit
    --mode steps` the 24 polygon positions. Options > ENC_ACQUIRE_* environment >
    rig file > built-in defaults.
    """
    from enctools.data import streams

    options.distinct_outputs({"-o": output, "--tee": tee_path})
    if tee_path is not None:
        streams.check_output(tee_path, force)
    if replay_path is not None:
        from enctools.hw.replay import replay

        streams.check_output(output, force, fmt)
        source = streams.open_input(replay_path, "readings")
        header = streams.with_history(source.header)
        header.meta["settings"] = dict(header.meta.get("settings", {}), replayed=replay_path,
                                       pace=pace)
        _write(header, replay(source, pace), output, force, fmt, tee_path)
        return

    if rig is None:
        raise click.UsageError("give --rig NAME|PATH (or ENC_RIG), or --replay FILE")
    from enctools.data.rig import load_rig
    from enctools.hw import acquire as acq
    from enctools.hw import open_session

    rig_ = load_rig(rig)
    settings = acq.resolve(rig_, given)
    streams.check_output(output, force, fmt)
    unit = "samples" if settings.mode == "continuous" else "positions"
    if realtime:
        settings.extra["realtime"] = True
    with open_session(rig_, seed=settings.seed, signals=bool(settings.signals),
                      realtime=realtime, timeout_s=timeout_s, retries=retries) as session:
        header, batches = acq.acquire(rig_, session, settings, runner.Progress(settings.mode, unit))
        rows = _write(streams.with_history(header), batches, output, force, fmt, tee_path)
    runner.log.info("%d rows written to %s", rows, output or "stdout")


def _write(header: Any, batches: Iterator[Any], output: str | None, force: bool,
           fmt: str | None, tee_path: str | None) -> int:
    """Write every batch as it arrives (and to the tee); on any ending keep what was read.

    SIGINT and SIGTERM are held while a batch is being written, so the files hold
    whole batches; they stop the run between batches (or inside a device wait).
    """
    from enctools.data import streams

    with contextlib.ExitStack() as stack:
        out = stack.enter_context(streams.OutputStream(output, header, force, fmt,
                                                       keep_partial=True))
        tee = (stack.enter_context(streams.OutputStream(tee_path, header, force,
                                                        keep_partial=True))
               if tee_path else None)
        guard = stack.enter_context(_SignalGuard())
        for batch in batches:
            with guard.held():
                if tee is not None:
                    tee.write(batch)
                out.write(batch)
        return out.rows


class _SignalGuard:
    """SIGINT -> KeyboardInterrupt (130), SIGTERM -> Interrupted (143), deferred while held."""

    def __init__(self) -> None:
        self._held = False
        self._pending: int | None = None
        self._old: dict[int, Any] = {}

    def __enter__(self) -> _SignalGuard:
        for sig in (signal.SIGINT, signal.SIGTERM):
            self._old[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)

    def _raise(self, signum: int) -> None:
        from enctools.errors import Interrupted

        if signum == signal.SIGTERM:
            raise Interrupted("terminated", exit_code=143)
        raise KeyboardInterrupt

    def _handle(self, signum: int, frame: Any) -> None:
        if self._held:
            self._pending = signum
            return
        self._raise(signum)

    @contextlib.contextmanager
    def held(self) -> Iterator[None]:
        self._held = True
        try:
            yield
        finally:
            self._held = False
            if self._pending is not None:
                signum, self._pending = self._pending, None
                self._raise(signum)
