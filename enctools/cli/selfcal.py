"""enc selfcal: graduation error (and radial motion) of a scale from several of its heads."""

from __future__ import annotations

import click

from enctools.cli import options, runner


@click.command("selfcal")
@options.input_arg
@click.option("--method", type=click.Choice(["fourier", "eda", "esa"]), default=None,
              help="fourier: basic transfer-function method; eda: equal-division averaging; "
                   "esa: four-head error separation (default with 4 heads).")
@options.ref("Reference head (default: the encoder's head nearest 0 deg).")
@options.heads("The other heads (default: the encoder's heads that do not measure).")
@options.heads("Heads whose mean is the angle coordinate (default: the encoder's measuring "
               "heads, else the reference).", flag="--angle-from", dest="angle_from")
@options.band("Highest harmonic K solved for.")
@options.points("Points of the output angle grid.", 1024)
@options.min_transfer("Harmonics whose normalised |W(n)| is below this are ill-conditioned.")
@options.strict
@options.spectrum("Also write the spectrum (|W(n)|, u per harmonic) to FILE.")
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(input: str | None, method: str | None, ref: str | None, heads: list[str] | None,
            angle_from: list[str] | None, band: int, points: int, min_transfer: float,
            strict: bool, spectrum_path: str | None, as_json: bool, unit: str,
            output: str | None, force: bool, fmt: str | None) -> None:
    """Self-calibrate a scale's graduation error from a continuous run of its heads.

    Reads a readings stream, averages the revolutions and writes a deviations
    stream: the graduation error [arcsec] on a uniform grid of the scale angle, its
    standard uncertainty, and with esa the spindle's radial error motion x, y [nm].
    """
    from enctools.cli import summary
    from enctools.data import streams
    from enctools.data.files import OutputGroup
    from enctools.methods import selfcal

    settings = selfcal.Settings(method=method, ref=ref,
                                heads=None if heads is None else tuple(heads),
                                angle_from=None if angle_from is None else tuple(angle_from),
                                band=band, points=points, min_transfer=min_transfer,
                                strict=strict)
    options.distinct_outputs({"-o": output, "--spectrum": spectrum_path})
    summary.check_json(as_json, output)
    streams.check_output(output, force, fmt)
    if spectrum_path is not None:
        streams.check_output(spectrum_path, force)
    source = streams.open_input(input, "readings")
    deviations, spectrum = selfcal.run(source, settings, runner.Progress("revolutions", "rev"))
    with OutputGroup() as outputs:  # both files, or neither
        if spectrum_path is not None:
            streams.write_table(spectrum_path, streams.with_history(spectrum[0]), spectrum[1],
                                force, group=outputs)
        streams.write_table(output, streams.with_history(deviations[0]), deviations[1], force,
                            fmt, group=outputs)
    meta = deviations[0].meta
    summary.emit({"method": meta["settings"].get("method"),
                  "n_revolutions": meta["settings"].get("revolutions"),
                  "blind": list(meta.get("blind", [])),
                  "ill_conditioned": list(meta.get("ill_conditioned", [])),
                  "blind_radial": (list(meta["blind_radial"]) if "blind_radial" in meta
                                   else None),
                  "n_iterations": sum(meta["iterations"][k] for k in ("first_revolution", "mean")),
                  "last_change_arcsec": meta["iterations"]["last_change_arcsec"],
                  "curves": summary.curves(*deviations)}, as_json, unit)
