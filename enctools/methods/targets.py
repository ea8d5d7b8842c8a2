"""Calibration targets: the visits of a step run or a table grouped into targets.

A step run visits each target several times (runs, directions, the 0 deg target again
at 360 deg); each visit reads a slightly different indicated angle (the stage's
repeatability, its reversal, the noise of the heads). Every command that counts
positions (enc points, fit-rbf, report, correct, make-rom) groups them here, alike:

- Positions are taken modulo 360 deg and sorted around the circle. Neighbours closer
  than the tolerance T are visits of one target (single linkage):

      T = max(min(S / SEPARATION, MAX_SPREAD_DEG), COUNTS x one count of the encoder)

  where S is the run's step (the smallest step between neighbouring targets). S is
  found from the positions: the coarsest grouping each of whose targets spreads (its
  first to its last visit) within both S / SEPARATION and MAX_SPREAD_DEG.
- A target's position is the circular mean of its visits [deg, 0..360); a target whose
  visits straddle 0 deg (359.99998 and 0.00002) is the first target, at 0 deg.
- Its deviation per direction is the mean over runs of each run's mean there (ISO
  230-2's mean unidirectional deviation, :func:`target_means`); the mean over the
  directions present is the deviation a model indexed by the indicated angle fits.
- The measured range (:func:`measured_range`): the arc from the target after the
  largest gap between neighbouring targets to the one before it. The targets cover the
  turn when that gap is at most FULL_TURN_GAP times the run's typical step (the median
  of the other gaps).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from enctools.errors import DataError
from enctools.units import DEG, factor

#: neighbouring targets are at least this many tolerances apart
SEPARATION = 4.0
#: the visits of one target spread at most this far apart [deg] (180 arcsec)
MAX_SPREAD_DEG = 0.05
#: positions within this many counts of the encoder are one target whatever the step
COUNTS = 2.0
#: the targets cover the turn when no gap between neighbours exceeds this many steps
FULL_TURN_GAP = 2.0


@dataclass(frozen=True)
class Targets:
    """Targets of a set of positions.

    position_deg : each target's position, increasing within 0..360 [deg].
    index : the target of each position given (0..m-1).
    visits : the positions given (visits) per target.
    tolerance_deg : neighbours closer than this were taken as one target [deg].
    step_deg : the smallest step between neighbouring targets [deg] (360 for one).
    """

    position_deg: np.ndarray
    index: np.ndarray
    visits: np.ndarray
    tolerance_deg: float
    step_deg: float

    def __len__(self) -> int:
        return int(self.position_deg.size)

    def meta(self) -> dict[str, Any]:
        """What a stream's metadata says of the targets (``targets``)."""
        return {"targets": len(self), "visits": int(self.index.size),
                "tolerance_deg": self.tolerance_deg, "step_deg": self.step_deg}


def _circular_gaps(p: np.ndarray) -> np.ndarray:
    """Gaps [deg] between sorted angles ``p`` [deg, 0..360) and, last, the wrap gap."""
    return np.diff(np.r_[p, p[:1] + 360.0])


def _spreads(p: np.ndarray, within: float) -> np.ndarray:
    """The spread [deg] (first to last visit) of each group of sorted angles ``p`` [deg,
    0..360) whose neighbours are at most ``within`` apart, around the circle."""
    breaks = np.flatnonzero(np.diff(p) > within)
    first = np.r_[0, breaks + 1]
    last = np.r_[breaks, p.size - 1]
    spread = p[last] - p[first]
    if first.size > 1 and p[0] + 360.0 - p[-1] <= within:  # the last group joins the first
        spread[0] = p[last[0]] + 360.0 - p[first[-1]]
        spread = spread[:-1]
    return spread


def tolerance(position_deg: np.ndarray, count_deg: float = 0.0) -> float:
    """The tolerance T [deg] within which positions [deg] are visits of one target
    (module docstring): the coarsest split of the gaps between neighbours into gaps
    inside targets and steps between them (each >= S, the smallest) such that every
    target spreads within min(S / SEPARATION, MAX_SPREAD_DEG); at least COUNTS counts
    of ``count_deg`` [deg]."""
    p = np.sort(np.mod(np.asarray(position_deg, np.float64), 360.0))
    if p.size == 0:
        return COUNTS * count_deg
    g = np.sort(_circular_gaps(p))
    bound = np.minimum(g / SEPARATION, MAX_SPREAD_DEG)  # T if g[k] is the smallest step
    # k: gaps g[:k] inside targets, g[k:] between them; the coarsest that holds
    for k in np.flatnonzero(g[:-1] <= bound[1:])[::-1] + 1:
        if g[k] > g[k - 1] and np.all(_spreads(p, g[k - 1]) <= bound[k]):
            return max(float(bound[k]), COUNTS * count_deg)
    return max(float(bound[0]), COUNTS * count_deg)


def group(position_deg: np.ndarray, count_deg: float = 0.0) -> Targets:
    """Group positions [deg] into targets within the derived :func:`tolerance`.

    ``count_deg``: one count of the encoder [deg] (0: unknown), the least tolerance's unit.
    """
    return group_within(position_deg, tolerance(position_deg, count_deg))


def group_within(position_deg: np.ndarray, tolerance_deg: float) -> Targets:
    """Group positions [deg] into targets: neighbours around the circle closer than
    ``tolerance_deg`` are one target (a chain across 0 deg is one target, at 0 deg)."""
    p = np.mod(np.asarray(position_deg, np.float64), 360.0)
    if p.size == 0 or not np.all(np.isfinite(p)):
        msg = "no positions, or a position is NaN or infinite"
        raise DataError(msg)
    order = np.argsort(p, kind="stable")
    ps = p[order]
    group_sorted = np.r_[0, np.cumsum(np.diff(ps) > tolerance_deg)]
    across = group_sorted[-1] > 0 and ps[0] + 360.0 - ps[-1] <= tolerance_deg
    if across:  # the chain crosses 0 deg: its last part joins the first target
        group_sorted[group_sorted == group_sorted[-1]] = 0
    index = np.empty(p.size, np.int64)
    index[order] = group_sorted
    visits = np.bincount(index)
    z = np.bincount(index, np.cos(p * DEG)) + 1j * np.bincount(index, np.sin(p * DEG))
    position = np.mod(np.angle(z) / DEG, 360.0)
    if across or position[0] > 180.0:
        position[0] = 0.0  # straddles 0: the first target
    step = float(np.min(_circular_gaps(position))) if position.size > 1 else 360.0
    return Targets(position, index, visits, float(tolerance_deg), step)


@dataclass(frozen=True)
class TargetMeans:
    """The deviation [arcsec] per target: per direction and over the directions.

    targets : the grouping.
    up, down : per target the mean over runs of each run's mean deviation approaching
        in the positive (+1) and negative (-1) direction; NaN where the direction
        misses a target; None where no point has that direction.
    mean : per target the mean of ``up`` and ``down`` over the directions present.
    spread : the largest peak-to-peak of one target's visits' deviations [arcsec].
    """

    targets: Targets
    up: np.ndarray | None
    down: np.ndarray | None
    mean: np.ndarray
    spread: float

    @property
    def position_deg(self) -> np.ndarray:
        return self.targets.position_deg

    def measured(self) -> MeasuredRange:
        """The range the targets measure (:func:`measured_range`), their tolerance beyond."""
        return measured_range(self.position_deg, self.targets.tolerance_deg)


def direction_means(index: np.ndarray, deviation: np.ndarray, run: np.ndarray, m: int
                    ) -> np.ndarray:
    """Per target (0..m-1) the mean over runs of each run's mean deviation [arcsec]:
    the readings of one run at one target are one approach; NaN where none."""
    keys = np.stack([index, np.asarray(run, np.int64)]).T
    uniq, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    per_run = np.bincount(inverse, deviation) / np.bincount(inverse)
    runs = np.bincount(uniq[:, 0], minlength=m).astype(np.float64)
    total = np.bincount(uniq[:, 0], per_run, minlength=m)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(runs > 0, total / runs, np.nan)


def target_means(position_deg: np.ndarray, deviation: np.ndarray,
                 direction: np.ndarray | None = None, run: np.ndarray | None = None,
                 count_deg: float = 0.0, source: str = "input") -> TargetMeans:
    """Positions [deg] grouped into targets (:func:`group`) and the deviation [arcsec]
    per target and direction; DataError (one line) for fewer than 2 targets."""
    x = np.asarray(deviation, np.float64)
    targets = group(position_deg, count_deg)
    m = len(targets)
    if m < 2:
        within = targets.tolerance_deg * factor("deg", "arcsec")
        msg = (f"{source}: fewer than 2 targets ({x.size} positions within {within:.4g} "
               "arcsec); a model needs points around the circle")
        raise DataError(msg)
    d = np.ones(x.size) if direction is None else np.asarray(direction)
    if not np.all(np.isin(d, (1, -1))):
        msg = f"{source}: a direction is not +1 or -1"
        raise DataError(msg)
    r = np.zeros(x.size, np.int64) if run is None else np.asarray(run, np.int64)
    per = {}
    for sign in (1, -1):
        sel = d == sign
        if sel.any():
            per[sign] = direction_means(targets.index[sel], x[sel], r[sel], m)
    both = np.array(list(per.values()))
    mean = np.nanmean(both, axis=0) if both.shape[0] > 1 else both[0]
    lo = np.full(m, np.inf)
    hi = np.full(m, -np.inf)
    np.minimum.at(lo, targets.index, x)
    np.maximum.at(hi, targets.index, x)
    return TargetMeans(targets, per.get(1), per.get(-1), mean, float(np.max(hi - lo)))


@dataclass(frozen=True)
class MeasuredRange:
    """The arc of the turn a set of targets measures [deg].

    start_deg : the first target after the largest gap (0..360).
    span_deg : the arc from it to the last target before the gap, increasing (mod 360).
    step_deg : the run's typical step: the median gap between neighbouring targets
        other than the largest.
    gap_deg : the largest gap between neighbouring targets (across 360 deg too).
    full_turn : whether the targets cover the turn (gap <= FULL_TURN_GAP x step).
    margin_deg : how far beyond the end targets the range reaches: the targets'
        tolerance, within which their visits lie [deg].
    """

    start_deg: float
    span_deg: float
    step_deg: float
    gap_deg: float
    full_turn: bool
    margin_deg: float = 0.0

    @property
    def end_deg(self) -> float:
        """The last target [deg, start_deg..start_deg + 360)."""
        return self.start_deg + self.span_deg

    def contains(self, angle_deg: np.ndarray) -> np.ndarray:
        """Whether each angle [deg] lies within the range (always, over a full turn)."""
        a = np.asarray(angle_deg, np.float64)
        if self.full_turn:
            return np.ones(a.shape, bool)
        start = self.start_deg - self.margin_deg
        return np.mod(a - start, 360.0) <= self.span_deg + 2.0 * self.margin_deg

    def text(self) -> str:
        """The range as a person reads it, e.g. ``15..56 deg (41 deg)``."""
        if self.full_turn:
            return "the full turn"
        end = self.end_deg - 360.0 if self.end_deg >= 360.0 else self.end_deg
        return f"{self.start_deg:.6g}..{end:.6g} deg ({self.span_deg:.4g} deg of the turn)"

    def meta(self) -> dict[str, Any]:
        """The ``domain`` metadata of a model stream [deg]."""
        return {"start_deg": self.start_deg, "end_deg": self.end_deg,
                "span_deg": self.span_deg, "step_deg": self.step_deg, "gap_deg": self.gap_deg,
                "full_turn": self.full_turn, "margin_deg": self.margin_deg}

    @classmethod
    def from_meta(cls, meta: Any, source: str = "input") -> MeasuredRange:
        """A range from a model stream's ``domain`` metadata (DataError when malformed)."""
        try:
            r = cls(float(meta["start_deg"]), float(meta["span_deg"]),
                    float(meta["step_deg"]), float(meta["gap_deg"]), bool(meta["full_turn"]),
                    float(meta.get("margin_deg", 0.0)))
        except (KeyError, TypeError, ValueError):
            r = None
        if r is None or not (0.0 <= r.start_deg < 360.0 and 0.0 <= r.span_deg <= 360.0
                             and 0.0 <= r.margin_deg <= MAX_SPREAD_DEG * 10):
            msg = f"{source}: the model's domain metadata is malformed: {meta!r}"
            raise DataError(msg)
        return r


def measured_range(position_deg: np.ndarray, margin_deg: float = 0.0) -> MeasuredRange:
    """The range targets at ``position_deg`` [deg, 0..360) measure (module docstring),
    reaching ``margin_deg`` (their tolerance) beyond the end targets."""
    p = np.sort(np.mod(np.asarray(position_deg, np.float64), 360.0))
    if p.size < 2:
        return MeasuredRange(float(p[0]) if p.size else 0.0, 0.0, 0.0, 360.0, False,
                             margin_deg)
    gaps = _circular_gaps(p)
    k = int(np.argmax(gaps))
    step = float(np.median(np.delete(gaps, k)))
    start = float(p[(k + 1) % p.size])
    gap = float(gaps[k])
    return MeasuredRange(start, 360.0 - gap, step, gap, gap <= FULL_TURN_GAP * step,
                         margin_deg)
