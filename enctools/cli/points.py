"""enc points: a steps-mode readings stream (polygon + autocollimator) or a CSV file -> points."""

from __future__ import annotations

import click

from enctools.cli import options, runner


@click.command("points")
@options.input_arg
@options.heads("Heads averaged into the encoder reading (default: the rig's measuring heads).")
@click.option("--autocollimator", default=None, metavar="COLUMN",
              help="Autocollimator column (default: the only one).")
@click.option("--faces", type=int, default=None, callback=options.positive,
              help="Faces of the polygon (default: the rig's).")
@options.outputs
@options.verbosity
def command(input: str | None, heads: list[str] | None, autocollimator: str | None,
            faces: int | None, output: str | None, force: bool, fmt: str | None) -> None:
    """Turn a polygon step run, or a CSV table, into a points stream.

    INPUT is a readings stream from `enc acquire --mode steps` on a rig with a
    polygon and an autocollimator (one point per position: mean of the measuring
    heads relative to the first position, against the polygon angle), or a CSV file
    position_deg,deviation_arcsec[,direction,run] with # comment lines.
    """
    from enctools.data import streams
    from enctools.data.streams import Header, with_history
    from enctools.errors import UsageError
    from enctools.methods import points as pts

    streams.check_output(output, force, fmt)
    settings = {"heads": heads, "autocollimator": autocollimator, "faces": faces}
    if pts.is_csv_file(input):
        given = [o for o, v in (("--heads", heads), ("--autocollimator", autocollimator),
                                ("--faces", faces)) if v is not None]
        if given:
            raise UsageError(f"{', '.join(given)}: for a steps run; {input} is a CSV table")
        p = pts.points_from_csv(input)
        header = Header("points", pts.points_schema(),
                        {"source": f"CSV {input}", "history": []})
    else:
        src = streams.open_input(input, "readings")
        table = src.read_all()
        p = pts.points_from_steps(src.header, table, heads, autocollimator, faces, src.source)
        header = src.header.derive("points", pts.points_schema(),
                                   source=f"steps run {src.source}")
    header.meta["settings"] = settings
    fig = pts.figures(pts.distinct(p)[1])
    header.meta["figures"] = fig.to_dict()
    runner.log.info("%d points; at %d distinct positions: Bessel s %.3f arcsec, p-p %.3f arcsec",
                    len(p), fig.n, fig.bessel_std, fig.peak_to_peak)
    streams.write_table(output, with_history(header), p.table(), force, fmt)
