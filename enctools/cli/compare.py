"""enc compare: deviation of a device (a head or head average) against a reference."""

from __future__ import annotations

import click

from enctools.cli import options, usage

usage.FIELD_FLAGS["compare"] = {"spectrum": "--spectrum", "interval_s": "enc acquire --interval"}


@usage.renamed({"--ref": "--reference", "--ref-curve": "--reference-curve",
                "--ref-column": "--reference-curve-column"})
@click.command("compare")
@options.input_arg
@click.option("--device", required=True, callback=options.name_list, metavar="HEAD[,HEAD...]",
              shell_complete=options.complete_heads,
              help="Device channel: a head, an average channel, or heads to average.")
@click.option("--reference", "ref", default=None, callback=options.name_list,
              metavar="HEAD[,HEAD...]", shell_complete=options.complete_heads,
              help="Reference channel (its reading is the angle): a head, an average or heads.")
@options.band("Keep harmonics 1..K (0: no band limit, angle bins instead).",
              callback=options.non_negative)
@options.points("Points of the output angle grid.", 1024)
@click.option("--name", default=None, help="Name of the deviation column (default DEVICE-REF).")
@click.option("--reference-curve", "ref_curve", default=None, metavar="FILE",
              type=click.Path(dir_okay=False, allow_dash=False),
              help="Calibrated error of the reference (deviations stream) to add back.")
@click.option("--reference-curve-column", "ref_column", default=None, metavar="NAME",
              help="Column of --reference-curve (default: its first deviation column).")
@options.spectrum("Also write the spectrum to FILE (needs --band).")
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(input: str | None, device: list[str], ref: list[str], band: int, points: int,
            name: str | None, ref_curve: str | None, ref_column: str | None,
            spectrum_path: str | None, as_json: bool, unit: str, output: str | None,
            force: bool, fmt: str | None) -> None:
    """Deviation of a device against a reference over a continuous run (seed 000 eqs. 7, 8, 10).

    Averages the revolutions of the reference and keeps the first --band harmonics.
    `enc compare --device H --reference P` after `enc average-heads` is eq. (10).
    """
    from enctools.cli import runner, summary
    from enctools.data import streams
    from enctools.data.files import OutputGroup
    from enctools.methods import compare

    if not ref:  # required, given as --reference or its old spelling
        raise click.MissingParameter(ctx=click.get_current_context(), param_type="option",
                                     param_hint="'--reference'")
    settings = compare.Settings(device=tuple(device), ref=tuple(ref), band=band, points=points,
                                name=name, ref_curve=ref_curve, ref_column=ref_column,
                                spectrum=spectrum_path is not None)
    options.check_curve_outputs(output, spectrum_path, force, fmt, as_json)
    source = streams.open_input(input, "readings")
    curve = None if ref_curve is None else streams.read_table(ref_curve, "deviations")[1]
    expected = int(float((source.meta.get("settings") or {}).get("revolutions") or 0))
    progress = runner.Progress("revolutions", "rev").every(expected)
    (dh, dt), spec = compare.run(source, settings, progress, curve)
    with OutputGroup() as outputs:  # both files, or neither
        if spectrum_path is not None and spec is not None:
            streams.write_table(spectrum_path,
                                streams.with_history(spec[0], output=spectrum_path), spec[1],
                                force, group=outputs, unit=unit)
        streams.write_table(output, streams.with_history(dh, output=output), dt, force, fmt,
                            group=outputs, unit=unit)
    summary.emit({"device": ",".join(device), "reference": ",".join(ref),
                  "n_revolutions": dh.meta["settings"].get("revolutions"),
                  "curves": summary.curves(dh, dt)}, as_json, unit)
