"""enc acquire: read a rig into a readings stream (continuous, steps, sweep or closure; or
replay)."""

from __future__ import annotations

import contextlib
import errno
import signal
from collections.abc import Iterator
from typing import Any

import click

from enctools.cli import options, runner


@click.command("acquire")
@options.rig
@click.option("--mode", type=click.Choice(["continuous", "steps", "sweep", "closure"]),
              default=None, help="continuous: turn and sample; steps: target positions; "
              "sweep: fine steps; closure: the polygon in every setting (simulator).")
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
@click.option("--timeout", "timeout_s", type=float, default=None,
              callback=options.bounded(0.001, 3600, unit=" s"),
              help="Instruments: seconds to wait for each reply (default: the rig's, 1).")
@click.option("--retries", type=click.IntRange(0, 100), default=None,
              help="Instruments: retries after a timeout before giving up (default: the rig's, 2).")
@click.option("--tee", "tee_path", default=None, metavar="FILE", type=click.Path(dir_okay=False),
              help="Also keep a copy of the stream in FILE (format from its extension).")
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(rig: str | None, replay_path: str | None, pace: bool, realtime: bool,
            timeout_s: float | None, retries: int | None, tee_path: str | None,
            as_json: bool, output: str | None, force: bool, fmt: str | None,
            **given: Any) -> None:
    """Acquire readings from a rig and write them as a readings stream.

    Defaults come from the rig file's [acquire] tables: `enc acquire --rig sjtu-dual`
    records 20 revolutions at 1 r/min every 5.05 ms; `enc acquire --rig ciomp-23bit
    --mode steps` the 24 polygon positions. Options > ENC_ACQUIRE_* environment >
    rig file > built-in defaults.
    """
    import time

    from enctools.cli.summary import check_json
    from enctools.data import streams

    options.distinct_outputs({"-o": output, "--tee": tee_path})
    check_json(as_json, output)
    start = time.monotonic()
    if tee_path is not None:
        streams.check_output(tee_path, force)
    if replay_path is not None:
        from enctools.hw.replay import replay

        streams.check_output(output, force, fmt)
        source = streams.open_input(replay_path, "readings")
        header = streams.with_history(source.header)
        header.meta["settings"] = dict(header.meta.get("settings", {}), replayed=replay_path,
                                       pace=pace)
        rows = _write(header, replay(source, pace), output, force, fmt, tee_path)
        _summary("replay", rows, time.monotonic() - start, output, tee_path, as_json)
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
    _summary(settings.mode, rows, time.monotonic() - start, output, tee_path, as_json)


def _summary(mode: str, rows: int, seconds: float, output: str | None, tee: str | None,
             as_json: bool) -> None:
    """The end-of-run line: mode, rows and where they went, seconds taken [s]."""
    from enctools.cli.summary import emit

    out: dict[str, Any] = {"mode": mode, "n_rows": rows, "elapsed_s": round(seconds, 3),
                           "output": output or "-"}
    if tee:
        out["tee"] = tee
    emit(out, as_json)


def _write(header: Any, batches: Iterator[Any], output: str | None, force: bool,
           fmt: str | None, tee_path: str | None) -> int:
    """Write every batch as it arrives (and to the tee); on any ending keep what was read.

    The tee is written first: a pipe closed downstream finds the batch already in it.
    SIGINT and SIGTERM are held except while waiting for the next batch (the device),
    so the files hold whole batches and a batch read is never dropped on its way.
    An output that fails (disk full) is dropped: the batch still goes to the others,
    the run stops, and the others are closed with every batch read.
    """
    from enctools.data import streams

    outs: list[Any] = []
    try:
        if tee_path:
            outs.append(streams.OutputStream(tee_path, header, force, keep_partial=True))
        outs.append(streams.OutputStream(output, header, force, fmt, keep_partial=True))
    except BaseException:
        for o in outs:
            o.abort(False)
        raise
    failed: dict[Any, BaseException] = {}
    with _SignalGuard() as guard:
        ending, rows = _pump(batches, outs, failed, guard)
        kept = _finish(outs, failed, ending)
        if ending is None and guard.pending is not None:
            ending = guard.interruption()
    broken = {o: e for o, e in failed.items() if not _closed_pipe(e)}
    if broken:
        raise _output_failure(broken, kept, rows)
    if ending is not None:
        if _closed_pipe(ending):
            runner.log.info("the pipe downstream closed after %d rows; kept in %s", rows,
                            ", ".join(kept) or "no file")
        raise ending
    return rows


def _closed_pipe(exc: BaseException) -> bool:
    return isinstance(exc, BrokenPipeError) or (isinstance(exc, OSError)
                                                and exc.errno == errno.EPIPE)


def _pump(batches: Iterator[Any], outs: list[Any], failed: dict[Any, BaseException],
          guard: _SignalGuard) -> tuple[BaseException | None, int]:
    """Write the batches to every output until the end: the exception that ended the run
    (None: all read) and the rows read. ``failed``: the outputs that failed, with why."""
    it = iter(batches)
    rows = 0
    batch = None  # read, not yet written (a signal just as the wait ends)
    try:
        while True:
            with guard.released():
                batch = next(it, None)
            if batch is None:
                return None, rows
            got, batch = batch, None
            rows += _to_all(outs, got, failed)
            if failed:
                raise next(iter(failed.values()))
    except BaseException as exc:  # noqa: BLE001 - every ending closes the outputs first
        guard.hold()
        if batch is not None:
            rows += _to_all(outs, batch, failed)
        with contextlib.suppress(Exception):
            close = getattr(it, "close", None)
            if close is not None:
                close()  # stop the table and the sampling
        return exc, rows


def _to_all(outs: list[Any], batch: Any, failed: dict[Any, BaseException]) -> int:
    """Write a batch to every output that has not failed; its rows."""
    for o in outs:
        if o not in failed:
            try:
                o.write(batch)
            except Exception as exc:  # noqa: BLE001 - the batch still goes to the others
                failed[o] = exc
    return int(batch.num_rows)


def _finish(outs: list[Any], failed: dict[Any, BaseException],
            ending: BaseException | None) -> list[str]:
    """Close the outputs: the failed ones leave nothing, the others keep what they hold
    (unless the ending is bad usage or input). The names of the outputs kept."""
    kept = []
    for o in outs:
        if o in failed:
            o.abort(False)
        elif ending is None or o.keeps(ending):
            try:
                o.close()
            except Exception as exc:  # noqa: BLE001 - reported with the others' failures
                failed[o] = exc
                o.abort(False)
                continue
            kept.append(o.path or "stdout")
        else:
            o.abort(False)
    return kept


def _output_failure(failed: dict[Any, BaseException], kept: list[str], rows: int) -> Exception:
    """One error for outputs that could not be written: which, why, and where the rows are."""
    from enctools.errors import OutputError

    why = "; ".join(str(e) if isinstance(e, OutputError)
                    else f"output {o.path or 'stdout'}: {e}" for o, e in failed.items())
    where = (f"the {rows} rows read are kept in {' and '.join(kept)}" if kept
             else "no output could keep them")
    return OutputError(f"{why}; {where}", next(iter(failed)).path)


class _SignalGuard:
    """SIGINT -> KeyboardInterrupt (130), SIGTERM -> Interrupted (143); held (deferred)
    except inside :meth:`released`."""

    def __init__(self) -> None:
        self._held = True
        self.pending: int | None = None
        self._old: dict[int, Any] = {}

    def __enter__(self) -> _SignalGuard:
        for sig in (signal.SIGINT, signal.SIGTERM):
            self._old[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)

    def interruption(self) -> BaseException:
        """The exception of the signal received."""
        from enctools.errors import Interrupted

        if self.pending == signal.SIGTERM:
            return Interrupted("terminated", exit_code=143)
        return KeyboardInterrupt()

    def _handle(self, signum: int, frame: Any) -> None:
        if self.pending is None:
            self.pending = signum
        if not self._held:
            raise self.interruption()

    def hold(self) -> None:
        """Defer signals again (the end of a wait that a signal cut short)."""
        self._held = True

    @contextlib.contextmanager
    def released(self) -> Iterator[None]:
        """Let a signal stop the run at once (a wait for the device)."""
        if self.pending is not None:
            raise self.interruption()
        self._held = False
        try:
            yield
        finally:
            self._held = True
