"""enc latency: dynamic error and code-skip speed (seed 001 eqs. 1-4); measured lag of runs."""

from __future__ import annotations

from typing import TYPE_CHECKING

import click

from enctools.cli import options, usage
from enctools.units import factor

if TYPE_CHECKING:
    from enctools.methods.latency import RunLag


#: the most speeds, and the largest |speed| [r/min], a latency table states
MAX_SPEEDS = 1000
MAX_RPM = 1e6


def _speeds(ctx: click.Context, param: click.Parameter, value: str | None) -> list[float] | None:
    speeds = options.float_list(ctx, param, value)
    if speeds is not None and (len(speeds) > MAX_SPEEDS
                               or any(abs(v) > MAX_RPM for v in speeds)):
        msg = (f"at most {MAX_SPEEDS} speeds, each -1000000..1000000 r/min, not {value!r}"
               if len(value or "") < 80 else
               f"at most {MAX_SPEEDS} speeds, each -1000000..1000000 r/min")
        raise click.BadParameter(msg)
    return speeds


@usage.renamed({"--ref": "--reference", "--speed": "--speeds"})
@click.command("latency")
@click.argument("inputs", nargs=-1, type=click.Path(dir_okay=False, allow_dash=True),
                metavar="[RUN]...")
@click.option("--bits", type=int, default=None,
              help="Bits n of the code (default: from the run's rig).")
@click.option("--delay", "delay_s", type=float, default=None,
              callback=options.bounded(0.0, 1.0, low_open=True, unit=" s"),
              help="Readout delay t_d [s] (seed 001 eq. 1); default: the measured lag.")
@click.option("--speeds", "speeds", default=None, callback=_speeds, metavar="RPM,...",
              help="Speeds [r/min] at which to state the dynamic error (seed 001 eq. 2).")
@options.heads("Runs: heads averaged into the device reading (default: the rig's measuring heads).")
@click.option("--reference", "reference", default=None, metavar="truth|H1,...",
              callback=options.name_list, shell_complete=options.complete_heads,
              help="Runs: the reference angle: 'truth' (simulator) or heads of a reference "
                   "encoder.")
@click.option("--fit-offset", is_flag=True, default=False,
              help="Runs at several speeds: fit the zero offset too, instead of assuming it is 0.")
@options.as_json
@options.verbosity
def command(inputs: tuple[str, ...], bits: int | None, delay_s: float | None,
            speeds: list[float] | None, heads: list[str] | None, reference: list[str] | None,
            fit_offset: bool, as_json: bool) -> None:
    """Dynamic error t_d*v and the code-skip speed 360/(2^n t_d) of an encoder.

    Without RUN: from --bits and --delay. With continuous runs (enc acquire
    --mode continuous) at known speeds: the measured readout lag of the device
    heads against a reference (the simulator's truth or another encoder's heads),
    then the same figures from it.
    """
    from enctools.cli.usage import UsageError
    from enctools.methods import latency as lat

    out: dict = {}
    if inputs:
        runs, rig_bits = _measure(inputs, heads, reference)
        lag, offset = lat.lag_from_runs(runs, None if fit_offset else 0.0)
        out["runs"] = [{"speed_deg_s": r.speed_deg_s,
                        "mean_difference_arcsec": r.mean_difference_arcsec,
                        "n_revolutions": r.turns, "n_samples": r.samples} for r in runs]
        out["measured_lag_s"] = lag
        out["offset_arcsec"] = offset
        bits = bits or rig_bits
        if delay_s is None:
            delay_s = lag
    if bits is None or delay_s is None:
        raise UsageError("give --bits and --delay, or continuous runs to measure the lag from")
    if not 1 <= bits <= 64:
        raise UsageError(f"--bits must be 1..64, not {bits}")
    if not delay_s > 0:
        raise UsageError(f"the readout delay must be > 0 s (measured {delay_s:.3g} s); "
                         "is the reference right?")
    skip = lat.code_skip_speed_deg_s(bits, delay_s)
    out |= {"bits": bits, "delay_s": delay_s,
            "resolution_arcsec": lat.resolution_deg(bits) * factor("deg", "arcsec"),
            "code_skip_speed_deg_s": skip, "code_skip_speed_rev_s": skip / 360.0,
            "code_skip_speed_rpm": skip / 6.0}
    rows = []
    for rpm in speeds or []:
        v = rpm * 6.0
        err = lat.dynamic_error_deg(delay_s, v) * factor("deg", "arcsec")
        rows.append({"speed_rpm": rpm, "dynamic_error_arcsec": err,
                     "dynamic_error_codes": err / out["resolution_arcsec"],
                     "skips_codes": abs(v) > skip})
    out["speeds"] = rows
    if as_json:
        from enctools.cli.summary import emit

        emit(out, as_json=True)
    else:
        _echo_text(out, fit_offset)


def _echo_text(out: dict, fit_offset: bool) -> None:
    """The figures of ``out`` (as --json prints them) as lines of text."""
    for r in out.get("runs", []):
        click.echo(f"run: {r['speed_deg_s'] / 6:.6g} r/min over {r['n_revolutions']:.3g} turns, "
                   f"device - reference {r['mean_difference_arcsec']:.6g} arcsec")
    if "measured_lag_s" in out:
        click.echo(f"measured lag: {out['measured_lag_s']:.6g} s "
                   f"(offset {out['offset_arcsec']:.4g} arcsec"
                   f"{', fitted' if fit_offset else ', assumed'})")
    skip, delay_s = out["code_skip_speed_deg_s"], out["delay_s"]
    click.echo(f"resolution: {out['resolution_arcsec']:.6g} arcsec ({out['bits']} bits, "
               "seed 001 eq. 3)")
    click.echo(f"code-skip speed: {skip:.9g} deg/s = {skip / 360:.6g} r/s = {skip / 6:.6g} r/min "
               f"(t_d {delay_s:.6g} s, seed 001 eq. 4)")
    for r in out["speeds"]:
        skipped = " (codes skipped)" if r["skips_codes"] else ""
        click.echo(f"at {r['speed_rpm']:g} r/min: dynamic error "
                   f"{r['dynamic_error_arcsec']:.6g} arcsec "
                   f"= {r['dynamic_error_codes']:.4g} codes{skipped}")


def _measure(inputs: tuple[str, ...], heads: list[str] | None,
             reference: list[str] | None) -> tuple[list[RunLag], int | None]:
    """The device-minus-reference difference of each run, and the bits of a 2^n-count
    device (None otherwise)."""
    from enctools.data.readings import head_info, measuring_heads
    from enctools.data.streams import open_input
    from enctools.errors import DataError
    from enctools.methods import latency as lat
    from enctools.methods.reference_angle import mean_reading, reference_angle, times

    runs: list[RunLag] = []
    bits: int | None = None
    for path in inputs:
        src = open_input(path, "readings")
        table = src.read_all()
        if "step" in table.column_names:
            raise DataError(f"{src.source}: a steps run; the lag needs a continuous run")
        schema, meta = src.header.schema, src.header.meta
        dev_heads = heads or measuring_heads(schema, meta, src.source)
        t = times(table, src.source)
        device = mean_reading(table, schema, dev_heads, src.source)
        info = head_info(schema, dev_heads[0], src.source)
        cpr = info.counts_per_rev
        if cpr & (cpr - 1) == 0:
            bits = bits or cpr.bit_length() - 1
        ref = reference_angle(table, schema, meta, t, reference, src.source)
        runs.append(lat.run_difference(t, device, ref))
    return runs, bits

