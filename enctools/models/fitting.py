"""Fitting an error model to calibration points (enc fit-rbf): the RBF network of
seed 001 (eqs. 5-7) or a Fourier series, with its training, leave-one-out and
hold-out residuals [arcsec].
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from enctools.data.statistics import figures_or_nan
from enctools.errors import SettingsError
from enctools.methods.points import figures_meta
from enctools.models import gain as gains
from enctools.models.correction_u import CorrectionU, correction_u
from enctools.models.fourier import (
    COND_LIMIT,
    DEFAULT_MAX_ORDER,
    FourierModel,
    blocked_residuals,
    choose_order,
    fit_with_loo,
)
from enctools.models.rbf import SMOOTHING, RBFModel, choose_network, fit_smoothed
from enctools.models.rbfdense import SEARCH_POINTS, choose_dense

KERNELS = ("rbf", "fourier")
#: the ranges of the options [deg], [arcsec], harmonic orders (bounds included): a
#: spread below a thousandth of a degree underflows every unit, a larger order than
#: MAX_HARMONICS allocates (2K+1)^2 words and no set of points determines it
SPREAD_DEG = (0.001, 360.0)
GOAL_ARCSEC = (0.0, 3600.0)
MAX_HARMONICS = 1024
#: a model fitted to at most this many points keeps, per point, its prediction refitted
#: without it (``residuals.held_out``): what a certificate's column after the correction
#: gives of each calibrated position (enc-report(1))
HELD_OUT_POINTS = 400
#: the smoother alternative a model is compared with: a Fourier series of at most this
#: order, chosen by leave-one-out
LOW_ORDER = 4
#: the alternative is named when its prediction residual is below this fraction of the
#: model's (a clear difference, not the search's scatter)
ALTERNATIVE_BETTER = 0.9


@dataclass(frozen=True)
class Settings:
    """How enc fit-rbf fits a model, checked when made.

    kernel : ``rbf`` (seed 001 eqs. 5-7) or ``fourier``.
    spread_deg : rbf: spread [deg]; None chooses it by leave-one-out.
    goal_arcsec : rbf: the training goal of seed 001's newrb, largest |residual|
        [arcsec]; None: the smoothed network chosen by leave-one-out.
    harmonics : fourier: order K (None: chosen by leave-one-out).
    holdout : the file of the points never used in the fit (None: none).
    """

    kernel: str = "rbf"
    spread_deg: float | None = None
    goal_arcsec: float | None = None
    harmonics: int | None = None
    holdout: str | None = None

    def __post_init__(self) -> None:
        if self.kernel not in KERNELS:
            msg = f"`kernel` must be one of {', '.join(KERNELS)}, not {self.kernel!r}"
            raise SettingsError(msg)
        if self.goal_arcsec is not None and not GOAL_ARCSEC[0] <= self.goal_arcsec <= \
                GOAL_ARCSEC[1]:
            msg = f"`goal_arcsec` must be 0..3600 arcsec, not {self.goal_arcsec}"
            raise SettingsError(msg)
        if self.spread_deg is not None and not SPREAD_DEG[0] <= self.spread_deg <= SPREAD_DEG[1]:
            msg = f"`spread_deg` must be 0.001..360 deg, not {self.spread_deg}"
            raise SettingsError(msg)
        if self.harmonics is not None and not 0 <= self.harmonics <= MAX_HARMONICS:
            msg = f"`harmonics` must be 0..{MAX_HARMONICS}, not {self.harmonics}"
            raise SettingsError(msg)
        if self.kernel == "rbf" and self.harmonics is not None:
            msg = ("`harmonics` applies to `kernel` fourier (the rbf kernel: `spread_deg`, "
                   "`goal_arcsec`)")
            raise SettingsError(msg)
        if self.kernel == "fourier" and (self.spread_deg, self.goal_arcsec) != (None, None):
            which = "`spread_deg`" if self.spread_deg is not None else "`goal_arcsec`"
            msg = f"{which} applies to `kernel` rbf (the fourier kernel: `harmonics`)"
            raise SettingsError(msg)

    def to_meta(self) -> dict[str, Any]:
        """The ``settings`` metadata of the model stream."""
        return {"kernel": self.kernel, "spread_deg": self.spread_deg,
                "goal_arcsec": self.goal_arcsec, "harmonics": self.harmonics,
                "holdout": self.holdout}


@dataclass
class Fit:
    """A model fitted to points, with its residuals (all in arcsec)."""

    model: RBFModel | FourierModel
    points: dict[str, Any]
    training: dict[str, Any]
    loo: dict[str, Any]
    holdout: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)
    choice: dict[str, Any] = field(default_factory=dict)
    gain: gains.Gain | None = None
    #: each point's residual against the model refitted without its block [arcsec], when
    #: the fit computed them itself (a dense table's network: rbfdense)
    blocked: np.ndarray | None = None
    #: each point's position [deg] and the model's prediction there refitted without it
    #: [arcsec] (None: more than HELD_OUT_POINTS points, or no leave-one-out)
    held_out: tuple[np.ndarray, np.ndarray] | None = None
    #: the model's uncertainty at any angle (held-out and band-limit terms [arcsec])
    correction_u: CorrectionU | None = None

    def residuals(self) -> dict[str, Any]:
        """The ``residuals`` metadata of the model stream."""
        out = {"points": self.points, "training": self.training, "leave_one_out": self.loo}
        if self.holdout is not None:
            out["holdout"] = self.holdout
        if self.gain is not None:
            out["gain"] = self.gain.to_meta()
        if self.held_out is not None:
            out["held_out"] = {"position_deg": self.held_out[0].tolist(),
                               "prediction_arcsec": self.held_out[1].tolist()}
        if self.correction_u is not None:
            out["correction_u"] = self.correction_u.to_meta()
        return out


def fit_points(angle_deg: np.ndarray, error_arcsec: np.ndarray, settings: Settings,
               holdout: tuple[np.ndarray, np.ndarray] | None = None,
               progress: Callable[[int, int], object] | None = None) -> Fit:
    """Fit an RBF network or a Fourier series to distinct points; report its residuals.

    Parameters
    ----------
    angle_deg, error_arcsec : distinct positions [deg] and deviations [arcsec].
    settings : the kernel and its parameters.
    holdout : other points (positions [deg], deviations [arcsec]) never used in the
        fit (seed 001 table 3). Their deviations may carry any constant offset (a
        run is referenced to its own first position): the residuals are reported
        about their mean.

    Returns
    -------
    Fit: training residuals (max |r|), leave-one-out residuals (each point
    predicted by the model fitted without it) and hold-out residuals, each with
    the Bessel standard deviation of seed 001 eq. (8).
    """
    x = np.asarray(angle_deg, dtype=np.float64)
    y = np.asarray(error_arcsec, dtype=np.float64)
    model, loo, choice, blocked = _model_and_loo(x, y, settings, progress)
    train, left_out = figures_or_nan(y - model(x)), figures_or_nan(loo)
    fit = Fit(model, figures_meta(figures_or_nan(y)),
              {"max_abs_arcsec": train.max_abs, "rms_arcsec": train.rms},
              {"max_abs_arcsec": left_out.max_abs, "rms_arcsec": left_out.rms,
               "bessel_std_arcsec": left_out.std}, choice=choice, blocked=blocked)
    if x.size <= HELD_OUT_POINTS and np.all(np.isfinite(loo)):
        fit.held_out = (x.copy(), y - loo)
    fit.correction_u = correction_u(x, y, loo)
    if holdout is not None:
        hx, hy = (np.asarray(v, dtype=np.float64) for v in holdout)
        r = hy - model(hx)
        before, after = figures_or_nan(hy), figures_or_nan(r - r.mean())
        fit.holdout = {"n": after.n, "before_bessel_std_arcsec": before.std,
                       "before_peak_to_peak_arcsec": before.pp,
                       "bessel_std_arcsec": after.std, "peak_to_peak_arcsec": after.pp,
                       "max_abs_arcsec": after.max_abs, "rms_arcsec": after.rms}
    if x.size >= 3:
        fit.gain = _gain(x, y, fit, settings, loo)
    fit.notes = _notes(fit, settings, x.size) + _gain_notes(fit.gain)
    return fit


def _refit(model: RBFModel | FourierModel, smoothing: float | None) -> gains.Refit:
    """The model's kind refitted with its settings (spread, smoothing, centres; order) to
    other points [deg, arcsec]: the blocked hold-out's refits."""
    if isinstance(model, RBFModel):
        spread, centres, lam = model.spread_deg, model.centres_deg, float(smoothing or 0.0)
        return lambda xs, ys: fit_smoothed(xs, ys, spread, lam, centres)
    order = int(model.n.max(initial=0))
    return lambda xs, ys: fit_with_loo(xs, ys, order)[0]


def _figure(x: np.ndarray, y: np.ndarray, loo: np.ndarray, model: RBFModel | FourierModel,
            smoothing: float | None, dense: bool) -> gains.Figure:
    """:func:`gains.figure` of a model refitted by its kind (:func:`_refit`); of a
    Fourier series on a dense table, the blocked hold-out from each block's R
    (:func:`fourier.blocked_residuals`: no refit over the points)."""
    if dense and isinstance(model, FourierModel):
        order = int(model.n.max(initial=0))
        held = blocked_residuals(x, y, gains.block_index(x), order)
        return gains.Figure(gains.rms(loo), gains.rms(held))
    return gains.figure(x, y, loo, _refit(model, smoothing), dense)


def _gain(x: np.ndarray, y: np.ndarray, fit: Fit, settings: Settings, loo: np.ndarray
          ) -> gains.Gain:
    """Whether the model beats no correction (enctools.models.gain), beside a smoother
    alternative (a Fourier series of order <= LOW_ORDER), and where the search ended on
    the edge of its grid."""
    dense = gains.is_dense(x)
    if fit.blocked is not None and dense:
        model = gains.Figure(gains.rms(loo), gains.rms(fit.blocked))
    else:
        model = _figure(x, y, loo, fit.model, fit.choice.get("smoothing"), dense)
    baseline = gains.figure(x, y, (y - y.mean()) * x.size / (x.size - 1),
                            gains.constant_refit, dense)
    g = gains.Gain(model, baseline, int(x.size), edges=_edges(fit, settings))
    if fit.holdout is not None:
        g.holdout = (fit.holdout["bessel_std_arcsec"], fit.holdout["before_bessel_std_arcsec"])
    order = int(fit.model.n.max(initial=0)) if isinstance(fit.model, FourierModel) else None
    if order is None or order > LOW_ORDER:
        smooth, smooth_loo = choose_order(x, y, most=LOW_ORDER)
        k = int(smooth.n.max(initial=0))
        alt = _figure(x, y, smooth_loo, smooth, None, dense)
        g.alternative = {"kernel": "fourier", "n_harmonics": k} | alt.to_meta()
    return g


def _edges(fit: Fit, settings: Settings) -> list[str]:
    """Where the model's search ended on the edge of its grid: the largest smoothing, the
    narrowest spread or the widest one short of 180 deg, the highest order tried."""
    model, choice, out = fit.model, fit.choice, []
    if isinstance(model, RBFModel):
        if choice.get("smoothing") == float(SMOOTHING[-1]):
            out.append(f"smoothing {SMOOTHING[-1]:g} (largest tried)")
        lo, hi = choice.get("spread_range", (np.nan, np.nan))
        if settings.spread_deg is None and model.spread_deg == lo:
            out.append(f"spread {lo:.5g} deg (narrowest tried)")
        elif settings.spread_deg is None and model.spread_deg == hi and hi < 180.0:
            out.append(f"spread {hi:.5g} deg (widest tried)")
    elif settings.harmonics is None:
        order, tried = int(model.n.max(initial=0)), choice.get("highest_order_tried")
        if tried is not None and order == tried and order > 0:
            out.append(f"order {order} (highest tried)")
    return out


def _gain_notes(g: gains.Gain | None) -> list[str]:
    """No gain over no correction, a search ended on its grid's edge, a smoother model
    that predicts better: each said once."""
    if g is None:
        return []
    notes = []
    if not g.helps:
        notes.append(f"no gain: {g.why_not()}; enc make-rom refuses this model unless "
                     "given `allow_no_gain`")
    if g.edges:
        notes.append("the search ended on the edge of its grid (" + "; ".join(g.edges)
                     + "): a better model may lie beyond it")
    alt = g.alternative
    if alt is not None and g.helps:
        worst = gains.Figure(alt["leave_one_out_rms_arcsec"], alt.get("blocked_rms_arcsec")).worst
        if worst < ALTERNATIVE_BETTER * g.model.worst:
            notes.append(f"a Fourier series of order {alt['n_harmonics']} predicts better: "
                         f"{worst:.4g} arcsec against {g.model.worst:.4g} "
                         f"(`kernel` fourier `harmonics` {alt['n_harmonics']})")
    return notes


def _notes(fit: Fit, settings: Settings, n: int) -> list[str]:
    """What the user must be told about the fit: an unreachable or noise-fitting goal,
    terms left out, leave-one-out far above the training residual."""
    notes = []
    model, goal = fit.model, settings.goal_arcsec
    if isinstance(model, RBFModel) and goal is not None:
        worst = fit.training["max_abs_arcsec"]
        loo, best = fit.loo["rms_arcsec"], fit.choice["best_leave_one_out_rms_arcsec"]
        if worst > goal:
            notes.append(f"`goal_arcsec` {goal:g} arcsec is not reached: no spread and "
                         f"smoothing of {model.centres_deg.size} units (with weights a model "
                         f"stream holds) gets every training residual within it; the network "
                         f"that predicts best leaves {worst:.4g} arcsec")
        elif n > 2 and loo > 1.1 * best:
            notes.append(f"`goal_arcsec` {goal:g} arcsec is reached by fitting the noise: "
                         f"{fit.choice['effective_parameters']:.4g} effective parameters for "
                         f"{n} points, leave-one-out rms {loo:.4g} arcsec against {best:.4g} "
                         "for the network that predicts best (without `goal_arcsec`)")
    tried, ceiling = fit.choice.get("highest_order_tried"), fit.choice.get("order_ceiling")
    if tried is not None and ceiling is not None and tried < ceiling:
        notes.append(f"orders {tried + 1}..{ceiling} are past the condition limit of these "
                     f"positions (condition number {COND_LIMIT:g}): not tried")
    if n > 2 and not np.isfinite(fit.loo["rms_arcsec"]):
        notes.append(f"no leave-one-out residuals: the {n} points each fix a term of the "
                     "series (it interpolates them); a lower `harmonics` leaves some to check it")
    if isinstance(model, FourierModel):
        for what, names in (("undetermined by these positions", model.undetermined),
                            (f"past the condition limit (order {model.limit}, condition "
                             f"number {COND_LIMIT:g})", model.ill_conditioned)):
            if names:
                notes.append(f"terms {_names(names)} are {what}: left out (0)")
    return notes


def _names(names: list[str], most: int = 6) -> str:
    shown = ", ".join(names[:most])
    return shown + (f" ... {names[-1]} ({len(names)} terms)" if len(names) > most else "")


def _model_and_loo(x: np.ndarray, y: np.ndarray, settings: Settings,
                   progress: Callable[[int, int], object] | None = None
                   ) -> tuple[RBFModel | FourierModel, np.ndarray, dict[str, Any],
                              np.ndarray | None]:
    """The model fitted to points [deg, arcsec], its leave-one-out residuals [arcsec]
    (NaN for fewer than 3 points), how it was chosen, and the blocked hold-out residuals
    [arcsec] when the fit gave them (a dense table's network, by blocks)."""
    n = x.size
    if settings.kernel == "rbf":
        return _network(x, y, settings, progress)
    if settings.harmonics is None:
        model, loo = choose_order(x, y)
        ceiling = min(DEFAULT_MAX_ORDER, (n - 1) // 2)
        how = {"selection": "leave-one-out, closed form", "highest_order_tried": model.limit,
               "order_ceiling": ceiling}
    else:
        k = int(settings.harmonics)
        if k > n:
            msg = (f"`harmonics` {k}: more harmonics than the {n} distinct positions can determine "
                   f"(at most {n})")
            raise SettingsError(msg)
        model, loo = fit_with_loo(x, y, k)
        how = {"selection": "the order given"}
    return model, (loo if n > 2 else np.full(n, np.nan)), how, None


def _network(x: np.ndarray, y: np.ndarray, settings: Settings,
             progress: Callable[[int, int], object] | None = None
             ) -> tuple[RBFModel, np.ndarray, dict[str, Any], np.ndarray | None]:
    """The rbf kernel's network: every point searched at once (choose_network) up to
    rbfdense.SEARCH_POINTS points, by blocks beyond (rbfdense.choose_dense)."""
    n, blocked = x.size, None
    how: dict[str, Any]
    if n > SEARCH_POINTS:
        dense = choose_dense(x, y, settings.spread_deg, progress, settings.goal_arcsec)
        network, choice, blocked = dense.model, dense.choice, dense.blocked
        how = {"selection": "leave-one-out, closed form" + (
            "" if settings.spread_deg is not None else
            f" (the spread on an even {SEARCH_POINTS} of the {n} points)")}
    else:
        network, choice = choose_network(x, y, settings.spread_deg, progress,
                                         settings.goal_arcsec)
        how = {"selection": "leave-one-out, closed form"}
    how |= {"tried": choice.tried, "smoothing": choice.smoothing,
            "effective_parameters": choice.effective, "spread_range": choice.spread_range}
    if choice.reached is not None:
        how |= {"selection": how["selection"].replace(
                    "leave-one-out, closed form", "leave-one-out among those within the goal"),
                "goal_reached": choice.reached,
                "best_leave_one_out_rms_arcsec": choice.best_rms}
    return network, (choice.loo if n > 2 else np.full(n, np.nan)), how, blocked
