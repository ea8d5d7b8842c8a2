"""enc acquire: read a rig into a readings stream (continuous, steps, sweep or closure; or
replay)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import click

from enctools.cli import options, runner, usage
from enctools.hw import backends

#: the options of one kind of run: shown under their heading in --help, refused in another
CONTINUOUS = "Continuous runs (--mode continuous)"
POSITIONS = "Runs of positions (--mode steps, sweep or closure)"
STEPS = "Step runs (--mode steps)"
SWEEP = "Sweep runs (--mode sweep)"
REPLAY = "Replays (--replay FILE)"
MODES = {CONTINUOUS: ("revolutions", "speed_rpm", "interval_s"),
         POSITIONS: ("settle_s", "readings", "runs", "bidirectional", "overshoot_deg",
                     "start_deg"),
         STEPS: ("positions_deg", "count"),
         SWEEP: ("range_arcsec", "step_arcsec"),
         REPLAY: ("pace",)}
#: the options that step and sweep runs both take
SHARED = {POSITIONS: (STEPS, SWEEP)}
#: closure runs refuse the options of step runs in words of their own (the polygon fixes
#: the design), so they take no group
_HEADING = {"continuous": CONTINUOUS, "steps": STEPS, "sweep": SWEEP}


def _mode_of(params: Mapping[str, Any]) -> str | None:
    """The heading of the run the options ask for: a replay, the mode given, else the rig's
    (None: closure, or a rig that does not load, refused later in its own words)."""
    if params.get("replay_path") is not None:
        return REPLAY
    mode = params.get("mode")
    if mode is None and params.get("rig") is not None:
        from enctools.data.rig import load_rig
        from enctools.errors import EncError

        try:
            mode = load_rig(params["rig"]).acquire.get("mode", "continuous")
        except EncError:
            return None
    return _HEADING.get(mode or "continuous")


def _kinds(role: str) -> str:
    return ", ".join(backends.kinds(role))


@click.command("acquire", cls=usage.ModeCommand, modes=MODES, mode_of=_mode_of, shared=SHARED)
@options.rig
@click.option("--mode", type=click.Choice(["continuous", "steps", "sweep", "closure"]),
              default=None, help="continuous: turn and sample; steps: target positions; "
              "sweep: fine steps; closure: the polygon in every setting (simulator).")
@click.option("--revolutions", type=float, default=None, callback=options.positive,
              help="Revolutions to record.")
@click.option("--speed", "speed_rpm", type=float, default=None, metavar="RPM",
              help="Speed [r/min]; negative turns backwards.")
@click.option("--interval", "interval_s", type=float, default=None, callback=options.positive,
              help="Sample interval [s].")
@click.option("--positions", "positions_deg", default=None, callback=options.float_list,
              metavar="DEG,DEG,...", help="Target positions [deg].")
@click.option("--count", type=int, default=None, callback=options.positive,
              help="N positions equally spaced over a turn (when --positions is absent).")
@click.option("--settle", "settle_s", type=float, default=None,
              help="Settling time after each move [s].")
@click.option("--readings", type=int, default=None, callback=options.positive,
              help="Readings per position.")
@click.option("--runs", type=int, default=None, callback=options.positive,
              help="Number of runs (closure: one per setting of the polygon).")
@click.option("--bidirectional/--unidirectional", default=None,
              help="Also approach every position from above (not closure).")
@click.option("--overshoot", "overshoot_deg", type=float, default=None,
              callback=options.non_negative,
              help="Approach each position from this far [deg] (not sweep).")
@click.option("--start", "start_deg", type=float, default=None, callback=options.finite,
              help="First position [deg] (steps: with --count).")
@click.option("--range", "range_arcsec", type=float, default=None, help="Range [arcsec].")
@click.option("--step", "step_arcsec", type=float, default=None, help="Step [arcsec].")
@options.heads("Record only these heads (default: all).")
@click.option("--signals/--no-signals", default=None,
              help="Also record each head's raw sin/cos signals [V] "
              f"(backend {_kinds('signals')}).")
@click.option("--seed", type=click.IntRange(0, (1 << 63) - 1), default=None,
              help="Simulator noise seed (default: the rig's).")
@click.option("--replay", "replay_path", default=None,
              type=click.Path(dir_okay=False, allow_dash=True),
              help="Re-stream a recorded readings file instead of acquiring.")
@click.option("--pace", is_flag=True, default=False,
              help="At the recorded pace (default: as fast as possible).")
@click.option("--realtime", is_flag=True, default=False,
              help="Simulator: run at wall-clock pace (live pipelines, interrupt drills).")
@click.option("--timeout", "timeout_s", type=float, default=None,
              callback=options.bounded(0.001, 3600, unit=" s"),
              help=f"Instruments ({_kinds('port')}): seconds to wait for each reply "
              "(default: the rig's, 1).")
@click.option("--retries", type=click.IntRange(0, 100), default=None,
              help=f"Instruments ({_kinds('port')}): retries after a timeout before giving "
              "up (default: the rig's, 2).")
@click.option("--tee", "tee_path", default=None, metavar="FILE", type=click.Path(dir_okay=False),
              help="Also keep a copy of the stream in FILE (format from its extension).")
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(rig: str | None, replay_path: str | None, pace: bool, realtime: bool,
            timeout_s: float | None, retries: int | None, tee_path: str | None,
            as_json: bool, unit: str, output: str | None, force: bool, fmt: str | None,
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
    from enctools.hw import backends, recording

    options.distinct_outputs({"-o": output, "--tee": tee_path})
    check_json(as_json, output)
    start = time.monotonic()
    if tee_path is not None:
        streams.check_output(tee_path, force)
    targets = ([(tee_path, None)] if tee_path else []) + [(output, fmt)]
    # the history line's paths as the first file written records them
    named = next((p for p in (output, tee_path) if p is not None and p != "-"), None)
    if replay_path is not None:
        from enctools.hw.replay import replay

        streams.check_output(output, force, fmt)
        source = streams.open_input(replay_path, "readings")
        meta = source.header.meta
        meta["settings"] = dict(meta.get("settings", {}), replayed=replay_path, pace=pace)
        header = streams.with_history(source.header, output=named)  # the path recorded too
        rows = recording.record(replay(source, pace),
                                recording.open_outputs(header, targets, force, unit))
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
    counted = "samples" if settings.mode == "continuous" else "positions"
    if realtime:
        settings.extra["realtime"] = True
    with open_session(rig_, seed=settings.seed, signals=bool(settings.signals),
                      realtime=realtime, timeout_s=timeout_s, retries=retries) as session:
        progress = runner.Progress(settings.mode, counted)
        header, batches = acq.acquire(rig_, session, settings, progress)
        measured = not backends.of_rig(rig_).simulated  # a device's run keeps its time
        header = streams.with_history(header, output=named, measured=measured)
        outs = recording.open_outputs(header, targets, force, unit)
        rows = recording.record(batches, outs)
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
