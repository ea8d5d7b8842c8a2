"""enc design: analyse a head arrangement for self-calibration, or search for the best."""

from __future__ import annotations

import click

from enctools.cli import options
from enctools.units import DEG


@click.command("design")
@click.option("--angles", default=None, callback=options.float_list, metavar="DEG,DEG,...",
              help="Head angles [deg], the reference first (e.g. 0,60,135,228).")
@click.option("--method", type=click.Choice(["esa", "fourier", "average"]), default=None,
              help="Transfer function to analyse (default: esa for 4 heads, else fourier).")
@options.band("Highest harmonic K analysed.")
@options.min_transfer()
@click.option("--mounting-error", "mounting_error", type=float, default=0.01, show_default=True,
              callback=options.bounded(0.0, 10.0, unit=" deg"),
              help="RMS error of each head's mounting angle [deg] for the sensitivity.")
@click.option("--search", "search_heads", type=int, default=None, metavar="M",
              help="Search the arrangement of M heads maximising min |W(n)|.")
@click.option("--step", "step_deg", type=float, default=1.0, show_default=True,
              callback=options.bounded(0.01, 60.0, unit=" deg"),
              help="search: grid step [deg] before refinement.")
@click.option("--min-gap", "min_gap", type=float, default=10.0, show_default=True,
              callback=options.bounded(0.0, 180.0, unit=" deg"),
              help="search: least angle between neighbouring heads [deg].")
@click.option("--criterion", type=click.Choice(["w", "gain"]), default="w", show_default=True,
              help="search (esa): maximise min |W(n)| (w, as Jiao 2017) or min |W|/noise norm.")
@click.option("--table", is_flag=True, default=False,
              help="Print n, |W(n)|, normalised |W(n)|, noise gain, sensitivity as TSV.")
@options.strict
@options.verbosity
def command(angles: list[float] | None, method: str | None, band: int, min_transfer: float,
            mounting_error: float, search_heads: int | None, step_deg: float, min_gap: float,
            criterion: str, table: bool, strict: bool) -> None:
    """Transfer function |W(n)|, blind harmonics, noise gain and mounting sensitivity
    of a head arrangement; with --search, the arrangement that maximises min |W(n)|."""
    from enctools.methods import design

    settings = design.Settings(angles_deg=None if angles is None else tuple(angles),
                               method=method, band=band, min_transfer=min_transfer,
                               mounting_error_deg=mounting_error, search_heads=search_heads,
                               step_deg=step_deg, min_gap_deg=min_gap, criterion=criterion,
                               strict=strict)
    res = design.run(settings)
    if res.search is not None:
        click.echo(f"best {search_heads}-head arrangement for n <= {band}: "
                   f"{'/'.join(f'{a:g}' for a in res.search.angles_deg)} deg "
                   f"({res.search.evaluated} arrangements scored, criterion {criterion})")
    a = res.analysis
    if table:
        click.echo("n\ttransfer\tnormalised\tgain\tsensitivity_per_deg")
        for k in range(1, band + 1):
            click.echo(f"{k}\t{a.transfer[k]:.6g}\t{a.normalised[k]:.6g}\t{a.gain[k]:.6g}\t"
                       f"{a.sensitivity[k] * DEG:.6g}")
    else:
        click.echo(design.report(a, mounting_error))
    design.refuse_or_warn(a, strict)
