"""enc fit-rbf: fit an RBF network (seed 001 eqs. 5-7) or a Fourier series to calibration points."""

from __future__ import annotations

import click

from enctools.cli import options, runner


@click.command("fit-rbf")
@options.input_arg
@click.option("--kernel", type=click.Choice(["rbf", "fourier"]), default="rbf", show_default=True,
              help="rbf: Gaussian RBF network on the circle; fourier: trigonometric least "
                   "squares.")
@click.option("--spread", "spread_deg", type=float, default=None, callback=options.positive,
              help="rbf: arc [deg] at which a unit's output falls to 1/2 (default: by "
                   "leave-one-out).")
@click.option("--goal", type=float, default=1e-4, show_default=True,
              help="rbf: training goal, largest |residual| [arcsec].")
@options.band("fourier: highest harmonic order K (default: half the distinct positions).",
              default=None, dest="harmonics")
@click.option("--holdout", "holdout_path", default=None, type=click.Path(dir_okay=False),
              help="Points never used in the fit (a points stream or CSV): report their residuals.")
@options.threshold("--max-std", "Exit 1 when the hold-out (else leave-one-out) Bessel s "
                   "exceeds this [arcsec].", dest="check_arcsec")
@options.outputs
@options.verbosity
def command(input: str | None, kernel: str, spread_deg: float | None, goal: float,
            harmonics: int | None, holdout_path: str | None, check_arcsec: float | None,
            output: str | None, force: bool, fmt: str | None) -> None:
    """Fit an error model to sparse calibration points and write it as a model stream.

    INPUT is a points stream (`enc points`) or a CSV file position_deg,deviation_arcsec.
    Points at the same angle (0 and 360 deg, repeated runs) are averaged. The summary
    on stderr gives the Bessel s and p-p of the points (seed 001 eq. 8) and the
    training, leave-one-out and hold-out residuals.
    """
    from enctools.data import streams
    from enctools.data.streams import with_history
    from enctools.errors import CheckFailed
    from enctools.methods.points import distinct, read_points
    from enctools.models import fitting
    from enctools.models.curve_model import model_table

    settings = fitting.Settings(kernel, spread_deg, goal, harmonics, holdout_path)
    streams.check_output(output, force, fmt)
    header, pts = read_points(input)
    x, y, closure = distinct(pts, source=header.meta.get("source", "input"))
    if closure > 0:
        runner.log.info("points at the same angle differ by up to %.4f arcsec; fitted their mean",
                        closure)
    hold = None
    if holdout_path is not None:
        _, hp = read_points(holdout_path)
        hold = distinct(hp, source=holdout_path)[:2]
    fit = fitting.fit_points(x, y, settings, hold)
    table, meta = model_table(fit.model)
    out = header.derive("model", table.schema, model=meta, residuals=fit.residuals(),
                        settings=settings.to_meta())
    streams.write_table(output, with_history(out), table, force, fmt)
    _summary(fit, meta)
    if check_arcsec is not None:
        which = "holdout" if fit.holdout else "leave_one_out"
        s = fit.residuals()[which]["bessel_std_arcsec"]
        if s > check_arcsec:
            msg = f"{which} Bessel s {s:.4f} arcsec exceeds --max-std {check_arcsec}"
            raise CheckFailed(msg)


def _summary(fit, meta) -> None:
    if runner.is_quiet():
        return
    import sys
    p, t, lo = fit.points, fit.training, fit.loo
    kern = (f"rbf, {meta['units']} units, spread {meta['spread_deg']:.4g} deg"
            if meta["kernel"] == "rbf" else f"fourier, harmonics 0..{meta['harmonics']}")
    lines = [f"model: {kern}",
             f"points: {p['n']} positions, Bessel s {p['bessel_std_arcsec']:.4f} arcsec, "
             f"p-p {p['peak_to_peak_arcsec']:.4f} arcsec",
             f"training: max |residual| {t['max_abs_arcsec']:.3g} arcsec",
             f"leave-one-out: rms {lo['rms_arcsec']:.4f} arcsec, "
             f"max {lo['max_abs_arcsec']:.4f} arcsec"]
    if fit.holdout:
        h = fit.holdout
        lines.append(f"hold-out: {h['n']} positions, Bessel s {h['before_bessel_std_arcsec']:.4f}"
                     f" -> {h['bessel_std_arcsec']:.4f} arcsec, "
                     f"p-p {h['peak_to_peak_arcsec']:.4f} arcsec")
    if meta.get("undetermined"):
        lines.append("undetermined by the points (set to 0): " + ", ".join(meta["undetermined"]))
    for ln in lines:
        sys.stderr.write(f"enc fit-rbf: {ln}\n")
