"""enc fit-rbf: fit an RBF network (seed 001 eqs. 5-7) or a Fourier series to calibration points."""

from __future__ import annotations

from typing import Any

import click

from enctools.cli import options, runner, usage
from enctools.units import factor

#: the options of one kernel, under its heading in --help (fitting.Settings refuses them
#: with the other kernel)
MODES = {"The rbf kernel": ("spread_deg", "goal"), "The fourier kernel": ("harmonics",)}


@usage.renamed(options.TABLE_RENAMED)
@click.command("fit-rbf", cls=usage.ModeCommand, modes=MODES)
@options.input_arg
@click.option("--kernel", type=click.Choice(["rbf", "fourier"]), default="rbf", show_default=True,
              help="rbf: Gaussian RBF network on the circle; fourier: trigonometric least "
                   "squares.")
@click.option("--spread", "spread_deg", type=float, default=None, callback=options.positive,
              help="rbf: arc [deg] at which a unit's output falls to 1/2 (default: by "
                   "leave-one-out).")
@click.option("--goal", type=float, default=None,
              help="rbf: train seed 001's network (newrb) until every residual is within "
                   "this [arcsec], e.g. 0.0001 (default: a smoothed network chosen by "
                   "leave-one-out).")
@options.band("fourier: highest harmonic order K (default: by leave-one-out, within the "
              "orders the positions condition).", default=None, dest="harmonics")
@click.option("--holdout", "holdout_path", default=None, type=click.Path(dir_okay=False),
              help="Points never used in the fit (a points stream or table, mapped alike): "
                   "report their residuals.")
@options.table_columns
@options.threshold("--max-std", "Exit 1 when the hold-out (else leave-one-out) Bessel s "
                   "exceeds this [arcsec].", dest="check_arcsec")
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(input: str | None, kernel: str, spread_deg: float | None, goal: float | None,
            harmonics: int | None, holdout_path: str | None, check_arcsec: float | None,
            mapping: Any, as_json: bool, unit: str, output: str | None, force: bool,
            fmt: str | None) -> None:
    """Fit an error model to sparse calibration points and write it as a model stream.

    INPUT is a points stream (`enc points`) or a table, its columns mapped as by `enc
    points` (a point's position is the indicated angle).
    The visits of one target (runs, directions, 0 and 360 deg) are one point: the model
    goes through each target's mean, and leave-one-out leaves out a target. The
    summary on stderr gives the targets, visits and measured range, the Bessel s and
    p-p of the targets (seed 001 eq. 8) and the training, leave-one-out and hold-out
    residuals.
    """
    from enctools.cli.summary import check_json, emit
    from enctools.data import streams, usertables
    from enctools.data.streams import with_history
    from enctools.errors import CheckFailed, EncError
    from enctools.methods.points import distinct, read_points, target_means
    from enctools.models import fitting
    from enctools.models.curve_model import model_table

    settings = fitting.Settings(kernel, spread_deg, goal, harmonics, holdout_path)
    check_json(as_json, output)
    streams.check_output(output, force, fmt)
    comma = bool(mapping.decimal_comma)
    header, pts = read_points(usertables.open_input(input, "points", comma), mapping)
    means = target_means(pts, header.meta.get("source", "input"), header.meta)
    if means.spread > 0:
        runner.log.info("visits of one target differ by up to %.4f arcsec; fitted the mean per "
                        "target", means.spread)
    hold = None
    if holdout_path is not None:
        hh, hp = read_points(usertables.open_input(holdout_path, "points", comma), mapping)
        hold = distinct(hp, holdout_path, hh.meta)[:2]
    fit = fitting.fit_points(means.position_deg, means.mean, settings, hold,
                             runner.Progress("spread search", "spreads"))
    for note in fit.notes:  # the settings a note names, as this command's options
        runner.log.warning("%s", usage.message(EncError(note), click.get_current_context().command,
                                               "fit-rbf"))
    table, meta = model_table(fit.model)
    meta |= {"selection": fit.choice, "targets": means.targets.meta(),
             "domain": means.measured().meta()}
    out = header.derive("model", table.schema, model=meta, residuals=fit.residuals(),
                        settings=settings.to_meta())
    streams.write_table(output, with_history(out, output=output), table, force, fmt, unit=unit)
    emit(_summary(fit, meta), as_json, unit)
    if check_arcsec is not None:
        which = "holdout" if fit.holdout else "leave_one_out"
        s = fit.residuals()[which]["bessel_std_arcsec"]
        if s > check_arcsec:
            msg = f"{which} Bessel s {s:.4f} arcsec exceeds --max-std {check_arcsec}"
            raise CheckFailed(msg)


def _summary(fit: Any, meta: dict[str, Any]) -> dict[str, Any]:
    """The model, the points' figures and the residuals [arcsec] (enc-streams(5))."""
    from enctools.data.summaries import from_meta

    model: dict[str, Any] = {"kernel": meta["kernel"]}
    if meta["kernel"] == "rbf":
        model |= {"n_units": meta["units"], "spread_deg": meta["spread_deg"]}
    else:
        model["n_harmonics"] = meta["harmonics"]
    model |= {k: v for k, v in fit.choice.items() if k not in ("tried", "spread_range")}
    t = meta["targets"]
    out: dict[str, Any] = {"model": model, "targets": {
        "n_targets": t["targets"], "n_visits": t["visits"],
        "tolerance_arcsec": t["tolerance_deg"] * factor("deg", "arcsec"), "step_deg": t["step_deg"],
        "domain": _domain_text(meta["domain"])}, "points": from_meta(fit.points),
                           "training": from_meta(fit.training),
                           "leave_one_out": from_meta(fit.loo)}
    if fit.holdout:
        h = from_meta(fit.holdout)
        h["before"] = {k[len("before_"):]: h.pop(k) for k in list(h) if k.startswith("before_")}
        out["holdout"] = h
    # the residuals side by side: through the points, predicting each left out, and other points
    out["rms"] = {"training_arcsec": fit.training["rms_arcsec"],
                  "leave_one_out_arcsec": fit.loo["rms_arcsec"]}
    if fit.holdout:
        out["rms"]["holdout_arcsec"] = fit.holdout["rms_arcsec"]
    for key in ("undetermined", "ill_conditioned"):
        if meta.get(key):
            out[key] = list(meta[key])
    if fit.gain is not None:  # against no correction: whether enc make-rom takes it
        out["gain"] = fit.gain.to_meta()
    return out


def _domain_text(domain: dict[str, Any]) -> str:
    """The model's measured range as the summary words it."""
    from enctools.methods.targets import MeasuredRange

    return MeasuredRange.from_meta(domain).text()
