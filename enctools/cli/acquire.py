"""enc acquire: read a rig into a readings stream (continuous, steps or sweep; or replay)."""

from __future__ import annotations

from typing import Any

import click

from . import options, runner


@click.command("acquire")
@options.rig
@click.option("--mode", type=click.Choice(["continuous", "steps", "sweep"]), default=None,
              help="continuous: turn and sample; steps: target positions; sweep: fine steps.")
@click.option("--revolutions", type=float, default=None, callback=options.positive,
              help="continuous: revolutions to record.")
@click.option("--speed", "speed_rpm", type=float, default=None,
              help="continuous: speed [r/min]; negative turns backwards.")
@click.option("--interval", "interval_s", type=float, default=None, callback=options.positive,
              help="continuous: sample interval [s].")
@click.option("--positions", "positions_deg", default=None, callback=options.float_list,
              metavar="DEG,DEG,...", help="steps: target positions [deg].")
@click.option("--count", type=int, default=None, callback=options.positive,
              help="steps: N positions equally spaced over a turn (when --positions is absent).")
@click.option("--settle", "settle_s", type=float, default=None, help="steps/sweep: settling time [s].")
@click.option("--readings", type=int, default=None, callback=options.positive,
              help="steps/sweep: readings per position.")
@click.option("--runs", type=int, default=None, callback=options.positive,
              help="steps/sweep: number of runs.")
@click.option("--bidirectional/--unidirectional", default=None,
              help="steps: also approach every position from above.")
@click.option("--overshoot", "overshoot_deg", type=float, default=None,
              help="steps: approach each position from this far [deg].")
@click.option("--start", "start_deg", type=float, default=None,
              help="sweep (and steps with --count): first position [deg].")
@click.option("--range", "range_arcsec", type=float, default=None, help="sweep: range [arcsec].")
@click.option("--step", "step_arcsec", type=float, default=None, help="sweep: step [arcsec].")
@click.option("--heads", default=None, callback=options.name_list, metavar="H1,H2,...",
              help="Record only these heads (default: all).")
@click.option("--signals/--no-signals", default=None,
              help="Also record each head's raw sin/cos signals [V] (simulator).")
@click.option("--seed", type=int, default=None, help="Simulator noise seed (default: the rig's).")
@click.option("--replay", "replay_path", default=None, type=click.Path(dir_okay=False, allow_dash=True),
              help="Re-stream a recorded readings file instead of acquiring.")
@click.option("--pace", is_flag=True, default=False,
              help="replay: at the recorded pace (default: as fast as possible).")
@options.outputs
@options.verbosity
def command(rig: str | None, replay_path: str | None, pace: bool, output: str | None,
            force: bool, fmt: str | None, verbose: int, quiet: int, debug: bool,
            **given: Any) -> None:
    """Acquire readings from a rig and write them as a readings stream.

    Defaults come from the rig file's [acquire] tables: `enc acquire --rig sjtu-dual`
    records 20 revolutions at 1 r/min every 3 ms; `enc acquire --rig ciomp-23bit
    --mode steps` the 24 polygon positions. Options > ENC_ACQUIRE_* environment >
    rig file > built-in defaults.
    """
    runner.setup_logging(verbose, quiet)
    runner.install_sigterm()
    from .. import streams

    if replay_path is not None:
        from ..hw.replay import replay

        streams.check_output(output, force, fmt)
        source = streams.open_input(replay_path, "readings")
        header = streams.with_history(source.header)
        header.meta["settings"] = dict(header.meta.get("settings", {}), replayed=replay_path,
                                       pace=pace)
        with streams.OutputStream(output, header, force, fmt, keep_partial=True) as out:
            for batch in replay(source, pace):
                out.write(batch)
        return

    if rig is None:
        raise click.UsageError("give --rig NAME|PATH (or ENC_RIG), or --replay FILE")
    from .. import acquire as acq
    from ..hw import open_session
    from ..rig import load_rig

    rig_ = load_rig(rig)
    settings = acq.resolve(rig_, given)
    streams.check_output(output, force, fmt)
    unit = "samples" if settings.mode == "continuous" else "positions"
    with open_session(rig_, seed=settings.seed, signals=bool(settings.signals)) as session:
        header, batches = acq.acquire(rig_, session, settings, runner.Progress(settings.mode, unit))
        with streams.OutputStream(output, streams.with_history(header), force, fmt,
                                  keep_partial=True) as out:
            for batch in batches:
                out.write(batch)
    runner.log.info("%d rows written to %s", out.rows, output or "stdout")
