"""Whether a correction helps: an error model's prediction residuals against no correction.

A model fitted to calibration points is worth loading only if it predicts points it
was not fitted to better than no correction does. No correction is a constant offset
(a run is referenced to its own first position, so a constant is never a correction):
its leave-one-out residual at point i is ``(y_i - mean) * N / (N - 1)``, so its RMS is
the points' Bessel s times ``sqrt(N / (N - 1))`` (seed 001 eq. 8).

Leave-one-out is optimistic where neighbouring points are correlated (a dense table,
a step run with many close targets: a point's neighbours carry its own slow error).
The *blocked* hold-out leaves out the contiguous blocks of the turn instead,
:data:`BLOCKS` blocks of 360/BLOCKS deg centred on 0, 15, 30, ... deg, one at a time,
refits the model with the same settings on the rest and predicts the block. A table
with at most one point in every block (a 24-face polygon) has its blocked hold-out
equal to its leave-one-out one; a table with more (dense) is judged by the worse of
the two.

The model helps when that figure is below :func:`threshold` times the same figure of
the constant. The margin covers what a search over many models finds in pure noise
(the smallest prediction residual of hundreds of networks is optimistic, most of all
for a network that interpolates a few points): with N points the model must do better
than ``1 - min(MAX_MARGIN, MARGIN_POINTS / N)`` of the constant (0.6 at 24 points: 4 %
of tables of pure noise do better), which refuses 96 to 100 % of tables of pure noise
of 24 to 200 points and accepts a 5" harmonic error under 0.3" noise at every seed
(tests/lib/models/test_gain.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from enctools.data.statistics import figures_or_nan

#: blocks of the blocked hold-out: 24 blocks of 15 deg (the 24-face polygon's spacing)
BLOCKS = 24
#: the margin a model must beat the constant by: min(MAX_MARGIN, MARGIN_POINTS / N)
MARGIN_POINTS = 9.6
MAX_MARGIN = 0.4

#: a model refitted to some points [deg, arcsec] with the settings of the chosen one
Refit = Callable[[np.ndarray, np.ndarray], Callable[[np.ndarray], np.ndarray]]


def rms(values: np.ndarray) -> float:
    """Root mean square of values, the one convention of :mod:`enctools.data.statistics`
    (NaN when empty or any is not finite)."""
    return figures_or_nan(values).rms


def constant_loo_rms(error_arcsec: np.ndarray) -> float:
    """RMS leave-one-out residual [arcsec] of a constant (the mean) through points:
    Bessel s x sqrt(N / (N - 1)); NaN for fewer than 2 points."""
    f = figures_or_nan(error_arcsec)
    return f.std * float(np.sqrt(f.n / (f.n - 1))) if f.n >= 2 else float("nan")


def threshold(n_points: int) -> float:
    """The fraction of the constant's figure a model's must stay below (dimensionless)."""
    return 1.0 - min(MAX_MARGIN, MARGIN_POINTS / max(int(n_points), 1))


def block_index(angle_deg: np.ndarray, blocks: int = BLOCKS) -> np.ndarray:
    """The block 0..blocks-1 of each angle [deg]: (k -+ 1/2) x 360/blocks deg, centred on
    the polygon's positions (measured ones scatter about k x 15 deg)."""
    a = np.mod(np.asarray(angle_deg, dtype=np.float64) * (blocks / 360.0) + 0.5, blocks)
    return np.minimum(a.astype(np.int64), blocks - 1)


def is_dense(angle_deg: np.ndarray, blocks: int = BLOCKS) -> bool:
    """Whether some block of the turn holds more than one point."""
    b = block_index(angle_deg, blocks)
    return bool(np.unique(b).size < b.size)


def blocked_residuals(angle_deg: np.ndarray, error_arcsec: np.ndarray, refit: Refit,
                      blocks: int = BLOCKS) -> np.ndarray:
    """Each point's residual [arcsec] against the model refitted without its block.

    NaN for the points of a block whose refit fails (too few points left to fit)."""
    x = np.asarray(angle_deg, dtype=np.float64)
    y = np.asarray(error_arcsec, dtype=np.float64)
    b = block_index(x, blocks)
    out = np.full(y.shape, np.nan)
    for k in np.unique(b):
        held = b == k
        if np.count_nonzero(~held) < 2:
            continue
        try:
            model = refit(x[~held], y[~held])
        except (ValueError, np.linalg.LinAlgError, ArithmeticError):
            continue
        out[held] = y[held] - np.asarray(model(x[held]), dtype=np.float64)
    return out


def constant_refit(x: np.ndarray, y: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The constant (mean of ``y`` [arcsec]) as a model of angle."""
    mean = float(np.mean(y))
    return lambda a: np.full(np.shape(a), mean)


@dataclass
class Figure:
    """How one model predicts points it was not fitted to [arcsec]: leave-one-out and,
    for a dense table, blocked hold-out RMS; ``worst`` is the larger (NaN if none)."""

    loo_rms: float
    blocked_rms: float | None = None

    @property
    def worst(self) -> float:
        values = [v for v in (self.loo_rms, self.blocked_rms) if v is not None]
        finite = [v for v in values if np.isfinite(v)]
        return max(finite) if len(finite) == len(values) and finite else float("nan")

    def to_meta(self) -> dict[str, Any]:
        out: dict[str, Any] = {"leave_one_out_rms_arcsec": self.loo_rms}
        if self.blocked_rms is not None:
            out["blocked_rms_arcsec"] = self.blocked_rms
        return out


def figure(angle_deg: np.ndarray, error_arcsec: np.ndarray, loo: np.ndarray, refit: Refit,
           dense: bool) -> Figure:
    """A model's :class:`Figure` from its leave-one-out residuals [arcsec] and, for a
    dense table, the blocked hold-out of ``refit``."""
    blocked = rms(blocked_residuals(angle_deg, error_arcsec, refit)) if dense else None
    return Figure(rms(loo), blocked)


@dataclass
class Gain:
    """Whether a model beats no correction (a constant offset) at predicting points.

    model, baseline : the two :class:`Figure` [arcsec]; n : points; by : the figure
    compared (``leave_one_out`` or ``blocked``); ratio : model / baseline on it;
    limit : the :func:`threshold` it must stay below; holdout : (s after, s before) of
    hold-out points [arcsec], or None; alternative : a smoother model's description and
    figure (its ``kernel``, ``n_harmonics``) or None; edges : where the search ended on
    the edge of its grid.
    """

    model: Figure
    baseline: Figure
    n: int
    holdout: tuple[float, float] | None = None
    alternative: dict[str, Any] | None = None
    edges: list[str] = field(default_factory=list)

    @property
    def by(self) -> str:
        return "blocked" if self.model.blocked_rms is not None else "leave_one_out"

    @property
    def ratio(self) -> float:
        base = self.baseline.worst
        return self.model.worst / base if base > 0 else float("nan")

    @property
    def limit(self) -> float:
        return threshold(self.n)

    @property
    def helps(self) -> bool:
        """Below the limit on the points (a ratio that is not a number: no gain shown),
        and on the hold-out points when given."""
        ok = bool(np.isfinite(self.ratio) and self.ratio < self.limit)
        if self.holdout is not None:
            ok = ok and self.holdout[0] < self.holdout[1]
        return ok

    def to_meta(self) -> dict[str, Any]:
        """The ``residuals.gain`` metadata of a model stream (and its summary)."""
        out: dict[str, Any] = {"helps": self.helps, "by": self.by, "ratio": self.ratio,
                               "limit": self.limit, "n_points": self.n,
                               "model": self.model.to_meta(),
                               "baseline": self.baseline.to_meta()}
        if self.holdout is not None:
            out["holdout"] = {"s_bessel_arcsec": self.holdout[0],
                              "before": {"s_bessel_arcsec": self.holdout[1]}}
        if self.alternative is not None:
            out["alternative"] = dict(self.alternative)
        if self.edges:
            out["edges"] = list(self.edges)
        return out

    def why_not(self) -> str:
        """The one-line reason the model does not help ('' when it does)."""
        if self.helps:
            return ""
        return refusal(self.to_meta())


def refusal(meta: dict[str, Any]) -> str:
    """Why a model with this ``residuals.gain`` metadata does not help, in one line."""
    by = meta.get("by", "leave_one_out")
    label = "blocked hold-out" if by == "blocked" else "leave-one-out"
    key = "blocked_rms_arcsec" if by == "blocked" else "leave_one_out_rms_arcsec"
    model, base = meta["model"].get(key), meta["baseline"].get(key)
    ratio, limit = meta.get("ratio"), float(meta["limit"])
    hold = meta.get("holdout")
    if hold is not None and ratio is not None and np.isfinite(ratio) and ratio < limit:
        return (f"the model does not help on the hold-out points: their Bessel s "
                f"{_fmt(hold['s_bessel_arcsec'])} after it against "
                f"{_fmt(hold['before']['s_bessel_arcsec'])} before")
    return (f"the model does not beat no correction: its {label} RMS {_fmt(model)} against "
            f"{_fmt(base)} for a constant offset over {meta['n_points']} points (it must "
            f"be below {limit:.3g} of it)")


def _fmt(value: Any) -> str:
    v = float(value) if value is not None else float("nan")
    return f'{v:.4g}"' if np.isfinite(v) else "none"


def from_residuals(residuals: dict[str, Any]) -> dict[str, Any] | None:
    """The ``gain`` a model stream's ``residuals`` metadata records, or one computed from
    its points' figures and leave-one-out RMS (streams written before the gain was
    recorded); None when neither is there."""
    if not isinstance(residuals, dict):
        return None
    gain = residuals.get("gain")
    if isinstance(gain, dict) and {"helps", "model", "baseline"} <= gain.keys():
        return gain
    points, loo = residuals.get("points") or {}, residuals.get("leave_one_out") or {}
    try:
        n, s = int(points["n"]), float(points["bessel_std_arcsec"])
        model = float(loo["rms_arcsec"])
    except (TypeError, KeyError, ValueError):
        return None
    if n < 2 or not np.isfinite(s):
        return None
    g = Gain(Figure(model), Figure(s * float(np.sqrt(n / (n - 1)))), n)
    return g.to_meta()
