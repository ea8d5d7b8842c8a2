"""enc design: analyse a head arrangement for self-calibration, or search for the best."""

from __future__ import annotations

from typing import Any

import click

from enctools.cli import options, usage
from enctools.cli.selfcal import method_option
from enctools.units import DEG

usage.FIELD_FLAGS["design"] = {"angles_deg": "--angles", "min_gap_deg": "--min-gap",
                               "mounting_error_deg": "--mounting-error"}


@usage.renamed({"--table": "--tsv", "--step": "--search-step"})
@click.command("design")
@click.option("--angles", default=None, callback=options.float_list, metavar="DEG,DEG,...",
              help="Head angles [deg], the reference first (e.g. 0,60,135,228).")
@method_option("design", "the transfer function analysed; default: esa for 4 heads, "
                         "else fourier")
@options.band("Highest harmonic K analysed.")
@options.min_transfer()
@click.option("--mounting-error", "mounting_error", type=float, default=0.01, show_default=True,
              callback=options.bounded(0.0, 10.0, unit=" deg"),
              help="RMS error of each head's mounting angle [deg] for the sensitivity.")
@click.option("--search", "search_heads", type=int, default=None, metavar="M",
              help="Search the arrangement of M heads maximising min |W(n)|.")
@click.option("--search-step", "step_deg", type=float, default=1.0, show_default=True,
              callback=options.bounded(0.01, 60.0, unit=" deg"),
              help="search: grid step [deg] before refinement.")
@click.option("--min-gap", "min_gap", type=float, default=10.0, show_default=True,
              callback=options.bounded(0.0, 180.0, unit=" deg"),
              help="search: least angle between neighbouring heads [deg].")
@click.option("--max-candidates", "max_candidates", type=int, default=2_000_000,
              show_default=True, callback=options.bounded(1, 1e12),
              help="search: the most arrangements scored, grid and refinement together; "
                   "a search that may need more is refused before it starts.")
@click.option("--criterion", type=click.Choice(["w", "gain"]), default="w", show_default=True,
              help="search (esa): maximise min |W(n)| (w, as Jiao 2017) or min |W|/noise norm.")
@click.option("--tsv", "table", is_flag=True, default=False,
              help="Print n, |W(n)|, normalised |W(n)|, noise gain, sensitivity as TSV.")
@options.strict
@options.as_json
@options.verbosity
def command(angles: list[float] | None, method: str | None, band: int, min_transfer: float,
            mounting_error: float, search_heads: int | None, step_deg: float, min_gap: float,
            max_candidates: int, criterion: str, table: bool, strict: bool,
            as_json: bool) -> None:
    """Transfer function |W(n)|, blind harmonics, noise gain and mounting sensitivity
    of a head arrangement; with --search, the arrangement that maximises min |W(n)|."""
    from enctools.methods import design

    settings = design.Settings(angles_deg=None if angles is None else tuple(angles),
                               method=method, band=band, min_transfer=min_transfer,
                               mounting_error_deg=mounting_error, search_heads=search_heads,
                               step_deg=step_deg, min_gap_deg=min_gap, criterion=criterion,
                               strict=strict, max_candidates=max_candidates)
    res = design.run(settings, _announce(settings))
    if as_json:
        from enctools.cli.summary import emit

        emit(_summary(res, mounting_error, table), as_json=True)
        design.refuse_or_warn(res.analysis, strict)
        return
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


def _announce(settings: Any) -> Any:
    """Before a search: say on stderr (not with -q) how many arrangements it scores at most
    and about how long that takes; the progress line to give it (None: no search)."""
    from enctools.cli import runner
    from enctools.methods import design

    if settings.search_heads is None:
        return None
    method = settings.search_method
    plan = design.plan_search(settings.search_heads, settings.band, method,
                              settings.step_deg, settings.min_gap_deg)
    if not runner.is_quiet():
        seconds = design.estimate_seconds(plan, method, settings.criterion)
        click.echo(f"{runner.command_name()}: scoring at most {plan.total} arrangements of "
                   f"{plan.heads} heads ({plan.grid} on a {plan.step_deg:g} deg grid, at most "
                   f"{plan.refine} refining), about {seconds:.0f} s at most", err=True)
    return runner.Progress("search", "arrangements")


def _summary(res: Any, mounting_error_deg: float, table: bool) -> dict[str, Any]:
    """The arrangement, its worst |W(n)|, blind and ill-conditioned harmonics, noise gain
    and mounting sensitivity; the search's result; with ``table``, every harmonic."""
    import numpy as np

    a = res.analysis
    w, nw = a.worst
    g, ng = a.max_gain
    out: dict[str, Any] = {"angles_deg": list(a.angles_deg), "method": a.method,
                           "n_first": a.first, "band": a.band, "min_transfer": w,
                           "min_transfer_n": nw, "blind": list(a.blind),
                           "ill_conditioned": list(a.ill),
                           "blind_radial": None if a.blind_radial is None
                           else list(a.blind_radial), "max_noise_gain": g,
                           "max_noise_gain_n": ng}
    sens = a.sensitivity[a.first:] * (mounting_error_deg * DEG)
    fin = np.isfinite(sens)
    out |= {"mounting_error_deg": mounting_error_deg,
            "max_relative_error": float(np.max(sens[fin])) if fin.any() else None}
    if res.search is not None:
        s = res.search
        out["search"] = {"angles_deg": list(s.angles_deg), "score": s.score,
                         "criterion": s.criterion, "n_evaluated": s.evaluated}
    if table:
        out["harmonics"] = [{"n": k, "transfer": a.transfer[k], "normalised": a.normalised[k],
                             "noise_gain": a.gain[k],
                             "sensitivity_per_deg": a.sensitivity[k] * DEG}
                            for k in range(1, a.band + 1)]
    return out
