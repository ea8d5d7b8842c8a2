"""enc interp-check: interpolation error within a signal period (seed 000 sec. 4).

Against probes or another encoder's head (counts mode), or from the heads' raw
sin/cos signals by a Heydemann ellipse fit (--signals). Writes a deviations stream:
the error of each device against its phase within the signal period.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import click

from enctools.cli import options, runner, usage

if TYPE_CHECKING:
    from enctools.data.files import OutputGroup

SIGNALS = "Signals mode (--signals)"
REFERENCE = "Reference mode (without --signals)"
#: the options of one mode: the other ignores them, or refuses them
MODES = {REFERENCE: ("average", "reference", "reference_file", "probes", "arm_m", "keep",
                     "reference_harmonics", "window_arcsec"),
         SIGNALS: ("min_arc_deg", "allow_excluded_pct", "rails_v", "corrected", "column_cos",
                   "column_sin", "periods_per_rev", "decimal_comma", "signal_period_m")}
usage.FIELD_FLAGS["interp-check"] = {"signals": "--signals",
                                     "interval_s": "enc acquire --interval"}


def _length(ctx: click.Context, param: click.Parameter, value: str | None) -> float | None:
    """--signal-period LENGTH (20um, 0.02mm, 316.5nm) in metres, within 1 nm..1 m."""
    from enctools.methods.interp.lengths import check_period
    from enctools.units import length_m

    if value is None:
        return None
    try:
        metres = length_m(value)
        check_period(metres)
    except ValueError as exc:
        raise click.BadParameter(str(exc)) from None
    return metres


def _int_list(ctx: click.Context, param: click.Parameter, value: str | None) -> list[int] | None:
    if value is None:
        return None
    try:
        out = [int(v) for v in value.split(",") if v.strip()]
    except ValueError:
        msg = f"expected harmonic orders separated by commas, not {value!r}"
        raise click.BadParameter(msg) from None
    if not out or min(out) < 1:
        msg = f"harmonic orders are integers >= 1, not {value!r}"
        raise click.BadParameter(msg)
    return out


@usage.renamed({"--ref": "--reference", "--ref-file": "--reference-file",
                "--ref-band": "--reference-band", "--average": "--mean-of-heads"})
@click.command("interp-check", context_settings={"auto_envvar_prefix": "ENC_INTERP_CHECK"},
               cls=usage.ModeCommand, modes=MODES,
               mode_of=lambda p: SIGNALS if p.get("signals_mode") else REFERENCE)
@options.input_arg
@options.heads("Heads to check (default: every head but the reference; with "
               "--signals every head with signals).")
@click.option("--mean-of-heads", "average", is_flag=True, default=False,
              help="Check the mean of --heads (one encoder) as one device.")
@click.option("--reference", "reference", default="probes", show_default=True,
              metavar="probes|HEAD", shell_complete=options.complete_heads,
              help="Reference: the averaged probes (psi = side h / L) or a head.")
@click.option("--reference-file", "reference_file", default=None,
              type=click.Path(dir_okay=False), metavar="FILE",
              help="Take the reference from this readings file, matched by time t.")
@click.option("--probes", default=None, callback=options.name_list, metavar="S1,S2",
              help="Probe columns to average (default: every probe).")
@click.option("--arm", "arm_m", type=float, default=None,
              help="Probe arm length L [m] (default: each probe's arm_m).")
@options.band("Harmonics 1..K of the signal period fitted (default 4; against an encoder "
              "of another period, the highest --keep).", default=None, dest="harmonics")
@click.option("--keep", default=None, callback=_int_list, metavar="N,N,...",
              help="Harmonics kept in the error curve (default: 1,2 against an encoder "
                   "of another signal period, else all fitted).")
@click.option("--reference-band", "reference_harmonics", type=click.IntRange(0, 8), default=2,
              show_default=True, metavar="J",
              help="Harmonics 1..J of the reference encoder's own period fitted alongside "
                   "(0: the seed's plain filter).")
@click.option("--trend", "trend_degree", type=click.IntRange(0, 5), default=1, show_default=True,
              help="Degree of the polynomial in angle removed per run (per window).")
@click.option("--window", "window_arcsec", type=float, default=None, metavar="ARCSEC",
              callback=options.positive,
              help="Span of angle with its own trend [arcsec] (default for a continuous "
                   "run: 1800, 0.5 deg; a sweep: one trend per run).")
@options.points("Points of the output curve per signal period.", 256, minimum=8)
@click.option("--signals", "signals_mode", is_flag=True, default=False,
              help="Raw-signal mode: Heydemann ellipse fit of each head's sin/cos signals.")
@click.option("--min-arc", "min_arc_deg", type=float, default=270.0,
              callback=options.bounded(10, 360, unit=" deg"), show_default=True,
              help="Refuse a fit whose samples cover a shorter arc of the "
                   "phase [deg] (the default: no quadrant missing).")
@click.option("--allow-excluded", "allow_excluded_pct", type=float, default=20.0,
              callback=options.bounded(0, 100, unit=" %"), show_default=True, metavar="PCT",
              help="The largest share of the samples [%] that may be clipped "
                   "or radius outliers, left out of the fit; beyond, it is refused.")
@click.option("--rails", "rails_v", default=None, callback=options.float_list,
              metavar="LOW,HIGH",
              help="The ADC's rails of every signal channel [V] (default: the "
                   "columns' rail_low_v/rail_high_v, else flat tops detected).")
@click.option("--cos", "column_cos", default=None, metavar="COL",
              help="A table of signals: the cosine's column (title or number; default: found "
                   "by its title, cos, cosine, I, A, Ua1).")
@click.option("--sin", "column_sin", default=None, metavar="COL",
              help="A table of signals: the sine's column (title or number; default: found "
                   "by its title, sin, sine, Q, B, Ua2).")
@click.option("--periods-per-rev", "periods_per_rev", type=int, default=None, metavar="N",
              help="A table of signals: the encoder's signal periods a revolution.")
@click.option("--decimal-comma", is_flag=True, default=False,
              help="A text table's numbers have a decimal comma (1,25); its columns are then "
                   "separated by tabs, semicolons or blanks.")
@click.option("--signal-period", "signal_period_m", default=None, callback=_length,
              metavar="LENGTH",
              help="A linear scale's signal period (20um, 0.02mm, 316.5nm): the error in nm "
                   "of travel, not arcsec (a table then needs no --periods-per-rev).")
@click.option("--corrected", default=None, type=click.Path(dir_okay=False),
              help="Also write the readings with each head's counts "
                   "re-interpolated from the corrected phase.")
@options.spectrum("Also write the harmonics (per signal period) as a spectrum stream.")
@options.threshold("--max-pm", "Exit 1 when any curve's +/- (half its peak-to-peak) "
                   "exceeds this [arcsec; nm with --signal-period].", dest="tolerance")
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(input: str | None, heads: list[str] | None, average: bool, reference: str,
            reference_file: str | None, probes: list[str] | None, arm_m: float | None,
            harmonics: int | None, keep: list[int] | None, reference_harmonics: int,
            trend_degree: int, window_arcsec: float | None, points: int, signals_mode: bool,
            min_arc_deg: float, allow_excluded_pct: float, rails_v: list[float] | None,
            column_cos: str | None, column_sin: str | None, periods_per_rev: int | None,
            decimal_comma: bool, signal_period_m: float | None, corrected: str | None,
            spectrum_path: str | None, tolerance: float | None, as_json: bool, unit: str,
            output: str | None, force: bool, fmt: str | None) -> None:
    """Interpolation error of heads within their signal period (seed 000 sec. 4).

    Reads a readings stream of a small-angle sweep (enc acquire --mode sweep) or a
    continuous run (a trend per --window of angle; read batch by batch, in
    constant memory) and writes a deviations stream: for each head, its error
    [arcsec; a linear scale's, --signal-period, nm] against the phase within its signal
    period [rad], with its standard uncertainty. Figures (p-p, +/-) and harmonics go
    to stderr and into the output's metadata.
    """
    from enctools.cli.summary import emit
    from enctools.cli.usage import UsageError
    from enctools.data import streams
    from enctools.data.files import OutputGroup
    from enctools.methods.interp import Settings, check

    table = (column_cos, column_sin, periods_per_rev, decimal_comma or None)
    _check_length(signal_period_m, periods_per_rev, spectrum_path)

    settings = Settings(
        heads=heads, average=average, reference=reference, reference_file=reference_file,
        probes=probes, arm_m=arm_m, harmonics=harmonics, keep=keep,
        reference_harmonics=reference_harmonics, trend_degree=trend_degree,
        window_arcsec=window_arcsec, points=points, signals=signals_mode,
        min_arc_deg=min_arc_deg, allow_excluded_pct=allow_excluded_pct,
        rails_v=None if rails_v is None else tuple(rails_v), corrected=bool(corrected))
    _check_outputs(output, spectrum_path, corrected, (force, fmt, as_json))
    source = _open(input, signals_mode, heads, table, corrected, signal_period_m)
    ref_stream = None if reference_file is None else streams.open_input(reference_file, "readings")
    checked = check.run(runner.RowsRead(source), settings, ref_stream)
    curves = _as_lengths(checked, signal_period_m, source.header.schema, spectrum_path)
    if not curves:
        msg = "no curve: the heads with signals carry no encoder geometry"
        raise UsageError(msg)

    header, out_table = _deviations(source.header, curves, checked.settings, checked.signals)
    for c in curves:
        for w in c.warnings:
            runner.log.warning("%s", w)
    with OutputGroup() as outputs:  # every file, or none
        if spectrum_path:
            sh, st = _spectrum(source.header, curves, checked.settings)
            streams.write_table(spectrum_path, streams.with_history(sh, output=spectrum_path),
                                st, force, None, group=outputs, unit=unit)
        if checked.corrected is not None and corrected:
            _write_corrected(source.header, checked.corrected, [c.name for c in curves],
                             corrected, force, outputs, unit)
        streams.write_table(output, streams.with_history(header, output=output), out_table,
                            force, fmt, group=outputs, unit=unit)
    emit({"curves": [_summary(c) for c in curves]}, as_json, unit)
    if tolerance is not None:
        _check_tolerance(curves, tolerance)


def _check_length(signal_period_m: float | None, periods_per_rev: int | None,
                  spectrum_path: str | None) -> None:
    """A scale's signal period (a length) refuses an encoder's periods a revolution and a
    spectrum stream (in arcsec), before any work."""
    from enctools.cli.usage import UsageError

    if signal_period_m is None:
        return
    if periods_per_rev is not None:
        msg = ("--periods-per-rev and --signal-period: a rotary encoder's periods a "
               "revolution (arcsec) or a linear scale's signal period (nm), not both")
        raise UsageError(msg)
    if spectrum_path is not None:
        msg = ("--spectrum: a spectrum stream is in arcsec; a scale's harmonics [nm] are in "
               "the deviations stream's metadata and the --json summary")
        raise UsageError(msg)


def _as_lengths(checked: Any, signal_period_m: float | None, schema: Any,
                spectrum_path: str | None) -> list:
    """The checked curves in nm of a scale of ``signal_period_m`` [m] (--signal-period),
    else of the period each head's signal columns declare (``schema``'s field metadata
    ``signal_period_nm``), else an encoder's in arcsec as they are (enc-interp-check(1),
    LINEAR SCALES); the output's settings record the period given [nm]."""
    from enctools.errors import DataError
    from enctools.methods.interp.lengths import NM_PER_M, declared_periods, to_length

    curves, settings = checked.curves, checked.settings
    declared = declared_periods(schema) if signal_period_m is None else {}
    if signal_period_m is None and not declared:
        return curves
    missing = [c.name for c in curves if signal_period_m is None and c.name not in declared]
    if missing:
        msg = (f"input: head(s) {', '.join(missing)} state no signal_period_nm beside "
               f"{', '.join(declared)} that do: give the scale's `signal_period`")
        raise DataError(msg)
    _check_length(1.0, None, spectrum_path)  # a spectrum stream is in arcsec
    if signal_period_m is not None:
        settings["signal_period_nm"] = signal_period_m * NM_PER_M
    # the arc of the phase the samples must cover, as a share of the period, not in deg
    settings["min_arc_percent"] = settings.pop("min_arc_deg") / 3.6
    return [to_length(c, signal_period_m or declared[c.name]) for c in curves]


def _check_outputs(output: str | None, spectrum_path: str | None, corrected: str | None,
                   how: tuple[bool, str | None, bool]) -> None:
    """Refuse outputs that are one file, exist without --force, or a JSON summary where
    the stream goes to stdout (``how``: --force, --format, --json), before any work."""
    from enctools.cli.summary import check_json
    from enctools.data import streams

    force, fmt, as_json = how
    options.distinct_outputs({"-o": output, "--spectrum": spectrum_path, "--corrected": corrected})
    check_json(as_json, output)
    streams.check_output(output, force, fmt)
    for extra in filter(None, (spectrum_path, corrected)):
        streams.check_output(extra, force, None)


def _open(input: str | None, signals_mode: bool, heads: list[str] | None,
          table: tuple[str | None, str | None, int | None, bool | None], corrected: str | None,
          signal_period_m: float | None = None) -> Any:
    """The readings stream, or (--signals) a user's table of one head's sin/cos signals
    read as its signal columns (``table``: --cos, --sin, --periods-per-rev,
    --decimal-comma; with ``signal_period_m``, a scale's, its phase read as one period
    a "revolution" before the curve is put in nm)."""
    from enctools.cli.usage import UsageError
    from enctools.data import signaltable, streams, usertables

    if input is None or not usertables.is_table_file(input):
        given = [o for o, v in zip(("--cos", "--sin", "--periods-per-rev", "--decimal-comma"),
                                   table, strict=True) if v is not None]
        if given:
            msg = f"{', '.join(given)}: for a table of signals; {input or 'stdin'} is a stream"
            raise UsageError(msg)
        return streams.open_input(input, "readings")
    if not signals_mode:
        msg = f"{input} is a table: a table of sin/cos signals is read with --signals"
        raise UsageError(msg)
    if corrected:
        msg = f"--corrected: {input} is a table of signals, without the heads' counts"
        raise UsageError(msg)
    if heads is not None and len(heads) != 1:
        msg = f"--heads: a table of signals holds one head, not {len(heads)}"
        raise UsageError(msg)
    ppr = 1 if signal_period_m is not None else table[2]
    mapping = signaltable.SignalMapping(table[0], table[1], ppr, head=heads[0] if heads else "H1")
    meta, rows = signaltable.signal_readings(usertables.read(input, bool(table[3])).raw,
                                             mapping)
    return streams.InputStream(streams.Header("readings", rows.schema, meta),
                               iter(rows.to_batches()), input, "table")


def _check_tolerance(curves: list[Any], tolerance: float) -> None:
    """CheckFailed when the worst curve's +/- exceeds ``tolerance`` [arcsec; nm of a
    scale's] (--max-pm)."""
    from enctools.errors import CheckFailed

    worst = max(curves, key=lambda c: c.meta["figures"]["plus_minus"])
    pm = worst.meta["figures"]["plus_minus"]
    mark = " nm" if worst.meta.get("unit") == "nm" else '"'
    if pm > tolerance:
        msg = (f"{worst.name}: interpolation error +/-{pm:.4f}{mark} exceeds --max-pm "
               f"{tolerance:g}{mark}")
        raise CheckFailed(msg)


def _summary(c: Any) -> dict[str, Any]:
    """A curve's figures [arcsec; a scale's nm], largest u, harmonics and reference
    (enc-streams(5))."""
    import numpy as np

    from enctools.data.statistics import curve_figures
    from enctools.data.summaries import figure_dict

    h = c.harmonics
    u = h.amplitude_u if h.cov.size and np.any(h.cov) else np.full(h.orders.size, np.nan)
    unit = c.meta.get("unit", "arcsec")
    out: dict[str, Any] = {"name": c.name}
    out |= figure_dict(curve_figures(c.error), unit, ("pm", "pp", "rms"))
    out |= {f"u_max_{unit}": float(c.u.max()) if c.u.size else None,
            f"period_{unit}": c.meta[f"period_{unit}"], "reference": c.meta.get("reference", "")}
    if "screen" in c.meta:  # --signals: what was left out of the ellipse fit, and why
        out["signal_faults"] = {k: v for k, v in c.meta["screen"].items() if k != "channels"}
        if unit == "nm":    # a scale's: the arc of the phase covered as a share of the period
            out["signal_faults"]["arc_percent"] = out["signal_faults"].pop("arc_deg") / 3.6
    if "period_ratio" in c.meta:
        out |= {"period_ratio": c.meta["period_ratio"], "kept": list(c.meta.get("kept", []))}
    out["harmonics"] = [{"n": int(n), f"amplitude_{unit}": float(a), "phase_rad": float(p),
                         f"u_amplitude_{unit}": float(uu)}
                        for n, a, p, uu in zip(h.orders, h.amplitude, h.phase, u, strict=True)]
    return out


def _deviations(header: Any, curves: list, settings: dict, fits: dict | None) -> tuple[Any, Any]:
    import pyarrow as pa

    from enctools.data.arrays import arrow_array
    from enctools.data.columns import uncertainty_name
    from enctools.data.schemas import make_field

    fields = [make_field("theta", pa.float64(), "rad")]
    arrays = [arrow_array(curves[0].phase, pa.float64())]
    for c in curves:
        unit = c.meta.get("unit", "arcsec")
        period = ({"periods_per_rev": c.periods_per_rev,
                   "period_arcsec": repr(c.meta["period_arcsec"])} if unit == "arcsec" else
                  {"signal_period_nm": repr(c.meta["period_nm"])})
        fields.append(make_field(c.name, pa.float64(), unit, "deviation", encoder=c.encoder,
                                 **period, reference=c.meta.get("reference", "")))
        arrays.append(arrow_array(c.error, pa.float64()))
        fields.append(make_field(uncertainty_name(c.name), pa.float64(), unit,
                                 "uncertainty", of=c.name))
        arrays.append(arrow_array(c.u, pa.float64()))
    schema = pa.schema(fields)
    periods = {c.meta.get("period_arcsec", c.meta.get("period_nm")) for c in curves}
    meta: dict[str, Any] = {
        "settings": settings, "domain": "signal period: theta is the phase the head reads",
        "curves": {c.name: c.meta for c in curves}}
    if len(periods) == 1:  # a scale's in nm (every curve of a check is in one unit)
        meta["period" if "period_arcsec" in curves[0].meta else "period_nm"] = periods.pop()
    if fits is not None:
        meta["signals"] = fits
    return header.derive("deviations", schema, **meta), pa.Table.from_arrays(arrays, schema=schema)


def _spectrum(header: Any, curves: list, settings: dict) -> tuple[Any, Any]:
    import numpy as np
    import pyarrow as pa

    from enctools.data.columns import uncertainty_name
    from enctools.data.schemas import make_field

    u_name = uncertainty_name("amplitude")
    rows: dict[str, list] = {k: [] for k in ("n", "amplitude", "phase", "re", "im", u_name,
                                             "curve")}
    for c in curves:
        h = c.harmonics
        u = h.amplitude_u if h.cov.size and np.any(h.cov) else np.full(h.orders.size, np.nan)
        for n, coef, uu in zip(h.orders, h.coef, u, strict=True):
            rows["n"].append(int(n))
            rows["amplitude"].append(float(abs(coef)))
            rows["phase"].append(float(np.angle(coef)))
            rows["re"].append(float(coef.real))
            rows["im"].append(float(coef.imag))
            rows[u_name].append(float(uu))
            rows["curve"].append(c.name)
    schema = pa.schema([make_field("n", pa.int64(), ""),
                        make_field("amplitude", pa.float64(), "arcsec"),
                        make_field("phase", pa.float64(), "rad"),
                        make_field("re", pa.float64(), "arcsec"),
                        make_field("im", pa.float64(), "arcsec"),
                        make_field(u_name, pa.float64(), "arcsec", "uncertainty",
                                   of="amplitude"),
                        make_field("curve", pa.string(), "")])
    table = pa.Table.from_pydict(rows, schema=schema)
    return header.derive("spectrum", schema, settings=settings,
                         domain="harmonics per signal period"), table


def _write_corrected(header: Any, table: Any, names: list[str], path: str, force: bool,
                     group: OutputGroup, unit: str) -> None:
    from enctools.data import streams

    meta = dict(header.meta)
    meta["settings"] = dict(meta.get("settings", {}), heydemann_corrected=names)
    h = streams.Header("readings", table.schema, meta)
    streams.write_table(path, streams.with_history(h, output=path), table, force, None, group=group,
                        unit=unit)
