"""ISO 230-2 (2014) positioning figures of a step run: a rotary axis in arcsec, a linear
axis in um (positions in mm).

Notation of the standard: target positions P_i (i = 1..m), runs j = 1..n, approach
from below (up, direction +1) and from above (down, direction -1); positioning
deviation x_ij = actual - target position [arcsec; um on a linear axis]. A points
stream's deviation is indicated - true, the opposite sign: its x is -deviation
(:attr:`Iso230.x_sign`), so that the reversal value B_i below has the standard's sign.

Per position (sec. 3.3 of the standard):

- mean unidirectional positioning deviation  x_i up = (1/n) sum_j x_ij up (and down)
- estimator of the unidirectional repeatability  s_i up = sqrt(sum (x_ij - x_i)^2 / (n-1))
- unidirectional repeatability  R_i up = 4 s_i up  (coverage +/-2 s: the 2014
  standard's "2s", not the 3s of VDI/DGQ 3441)
- mean bidirectional positioning deviation  x_i = (x_i up + x_i down) / 2
- reversal value  B_i = x_i up - x_i down
- bidirectional repeatability  R_i = max(2 s_i up + 2 s_i down + |B_i|, R_i up, R_i down)

Of the axis:

- reversal value B = max |B_i|; mean reversal value B_mean = (1/m) sum B_i
- repeatability R up = max R_i up, R down = max R_i down, R = max R_i
- systematic positioning error  E up = max x_i up - min x_i up; bidirectional
  E = max(x_i up, x_i down) - min(x_i up, x_i down) (both directions' extremes)
- range of the mean bidirectional positioning deviation  M = max x_i - min x_i
- accuracy  A up = max(x_i up + 2 s_i up) - min(x_i up - 2 s_i up); bidirectional
  A = max(x_i up + 2 s_i up, x_i down + 2 s_i down) - min(x_i up - 2 s_i up, x_i down - 2 s_i down)

One approach is one run's visit of one target in one direction: its readings are
averaged into one x_ij first, so n counts approaches (runs), never readings, and s_i
is the scatter of the runs' means. The standard's test cycle asks for 5 runs in each
direction, for linear and rotary axes alike (rotary axes up to 360 deg: targets over
the turn including 0, 90, 180 and 270 deg, at least 8 of them over a full turn);
fewer runs give the figures with one warning line (:attr:`Iso230.warnings`). A
rotary axis's 0 and 360 deg are one target (``circular``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from enctools.errors import DataError
from enctools.methods.targets import group_within

UP, DOWN = 1, -1


@dataclass
class DirectionFigures:
    """Per-position and axis figures of one approach direction [arcsec]."""

    mean: np.ndarray          # x_i, per position
    s: np.ndarray             # s_i, per position
    runs: np.ndarray          # n_i, approaches (runs) per position
    R_i: np.ndarray           # 4 s_i
    R: float                  # max R_i
    E: float                  # max x_i - min x_i
    A: float                  # max(x_i + 2 s_i) - min(x_i - 2 s_i)


@dataclass
class Iso230:
    """ISO 230-2 figures of a step run (positions in deg, figures in arcsec)."""

    positions: np.ndarray
    up: DirectionFigures | None
    down: DirectionFigures | None
    bidirectional: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    unit: str = "arcsec"          # of the figures (enc report --unit shows another); um
    position_unit: str = "deg"    # of the positions: deg, or mm on a linear axis
    #: x = x_sign * the input's deviation: +1 where it is actual - target (a step run's
    #: encoder - target), -1 where it is indicated - true (a points stream)
    x_sign: int = 1

    @property
    def is_bidirectional(self) -> bool:
        return self.up is not None and self.down is not None

    def axis(self) -> dict[str, float]:
        """The axis figures [arcsec]: R_up, E_up, A_up, R_down, ..., B, B_mean, R, E, M, A."""
        out: dict[str, float] = {}
        for name, d in (("up", self.up), ("down", self.down)):
            if d is not None:
                out.update({f"R_{name}": d.R, f"E_{name}": d.E, f"A_{name}": d.A})
        for key in ("B", "B_mean", "R", "E", "M", "A"):
            if key in self.bidirectional:
                out[key] = float(self.bidirectional[key])
        return out

    def table(self) -> list[dict[str, float]]:
        """One row per target position (key ``position_deg``, or ``position_mm``) with the
        per-position figures [unit] (mean, s, R, B) and the number of runs."""
        rows = []
        for i, p in enumerate(self.positions):
            row: dict[str, float] = {f"position_{self.position_unit}": float(p)}
            for name, d in (("up", self.up), ("down", self.down)):
                if d is not None:
                    row |= {f"mean_{name}": float(d.mean[i]), f"s_{name}": float(d.s[i]),
                            f"R_{name}": float(d.R_i[i]), f"n_{name}": int(d.runs[i])}
            if self.is_bidirectional:
                row |= {"mean": float(self.bidirectional["mean_i"][i]),
                        "B": float(self.bidirectional["B_i"][i]),
                        "R": float(self.bidirectional["R_i"][i])}
            rows.append(row)
        return rows


def _direction(pos_index: np.ndarray, x: np.ndarray, m: int, label: str) -> DirectionFigures:
    """Figures of one direction from one x_ij per approach [arcsec] at target ``pos_index``."""
    counts = np.bincount(pos_index, minlength=m)
    if np.any(counts == 0):
        msg = f"ISO 230-2: {label} approach misses {int(np.sum(counts == 0))} target position(s)"
        raise DataError(msg)
    if np.any(counts < 2):
        msg = f"ISO 230-2: one run per position ({label}); s and R are undefined"
        raise DataError(msg)
    mean = np.bincount(pos_index, weights=x, minlength=m) / counts
    resid = x - mean[pos_index]
    s = np.sqrt(np.bincount(pos_index, weights=resid * resid, minlength=m) / (counts - 1))
    R_i = 4.0 * s
    return DirectionFigures(mean=mean, s=s, runs=counts, R_i=R_i, R=float(R_i.max()),
                            E=float(mean.max() - mean.min()),
                            A=float((mean + 2 * s).max() - (mean - 2 * s).min()))


def approaches(index: np.ndarray, x: np.ndarray, direction: np.ndarray, run: np.ndarray | None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One x_ij per approach: the mean deviation [arcsec] of the readings of one run at
    one target in one direction. ``run`` None: every reading is one approach.
    Returns (target index, direction, x_ij [arcsec], readings per approach)."""
    if run is None:
        return index, direction, x, np.ones(x.size, np.int64)
    keys = np.stack([direction, index, np.asarray(run, np.int64)]).T
    uniq, group = np.unique(keys, axis=0, return_inverse=True)
    group = group.reshape(-1)
    counts = np.bincount(group)
    return uniq[:, 1], uniq[:, 0], np.bincount(group, weights=x) / counts, counts


def _runs_warning(up: DirectionFigures | None, down: DirectionFigures | None,
                  per_approach: np.ndarray) -> list[str]:
    """One line when a direction has fewer than the 5 runs the standard asks for."""
    n = {name: int(d.runs.min()) for name, d in (("up", up), ("down", down)) if d is not None}
    if min(n.values()) >= 5:
        return []
    each = ", ".join(f"{k} {v}" for k, v in n.items())
    readings = (f"; the {int(per_approach.max())} readings of one approach count once"
                if per_approach.max() > 1 else "")
    return [f"ISO 230-2 asks for 5 runs in each direction; runs counted per target: {each}"
            f"{readings}"]


def target_positions(position_deg: np.ndarray, tol_deg: float = 0.01, circular: bool = False
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Group measured positions [deg] into targets: positions closer than ``tol_deg``
    (after sorting) are one target. ``circular``: the targets every command counts
    (:func:`enctools.methods.targets.group_within`): modulo 360 deg, 359.999 and 0.001
    are the 0 deg target. Returns (target [deg], index of each reading's target,
    readings per target); a target is its group's mean (circular mean when circular)."""
    p = np.asarray(position_deg, dtype=np.float64)
    if circular:
        t = group_within(p, tol_deg)
        return t.position_deg, t.index, t.visits
    order = np.argsort(p, kind="stable")
    group_sorted = np.cumsum(np.concatenate([[True], np.diff(p[order]) > tol_deg])) - 1
    index = np.empty(p.size, np.int64)
    index[order] = group_sorted
    counts = np.bincount(index)
    return np.bincount(index, weights=p) / counts, index, counts


def _targets_warning(positions: np.ndarray) -> list[str]:
    """One line when a rotary axis has fewer targets than the standard asks for its
    range: 3 up to 90 deg, 5 up to 180 deg, 8 beyond (a full turn) [deg]."""
    p = np.sort(np.mod(positions, 360.0))
    gaps = np.diff(np.r_[p, p[0] + 360.0])
    span = 360.0 - float(gaps.max()) if p.size > 1 else 0.0
    need = 3 if span <= 90.0 else 5 if span <= 180.0 else 8
    if p.size >= need:
        return []
    return [f"ISO 230-2 asks for {need} targets or more over a rotary axis's "
            f"{span:.4g} deg; {p.size} here"]


def _linear_targets_warning(positions: np.ndarray) -> list[str]:
    """One line when a linear axis has fewer targets than the standard asks for: 5 a
    metre of travel and 5 at least [mm]."""
    span_m = float(positions.max() - positions.min()) / 1000.0 if positions.size else 0.0
    need = max(5, int(np.ceil(5.0 * span_m - 1e-9)))
    if positions.size >= need:
        return []
    return [f"ISO 230-2 asks for {need} targets or more over a linear axis's "
            f"{span_m * 1000.0:.4g} mm (5 a metre, at least 5); {positions.size} here"]


def _inputs(position: np.ndarray, deviation: np.ndarray, direction: np.ndarray | None,
            run: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positions, deviations and directions (None: all up) as arrays, checked: one
    length, finite, directions +-1 (DataError, one line)."""
    p = np.asarray(position, dtype=np.float64)
    x = np.asarray(deviation, dtype=np.float64)
    d = np.ones(p.shape, np.int64) if direction is None else np.asarray(direction, np.int64)
    if not (p.size == x.size == d.size) or p.size == 0:
        msg = "ISO 230-2: positions, deviations and directions differ in length or are empty"
        raise DataError(msg)
    if not np.all(np.isfinite(x)):
        msg = "ISO 230-2: a deviation is NaN or infinite"
        raise DataError(msg)
    bad = ~np.isin(d, (UP, DOWN))
    if np.any(bad):
        msg = f"ISO 230-2: direction must be +1 or -1, found {int(d[bad][0])}"
        raise DataError(msg)
    if not np.all(np.isfinite(p)):
        msg = "ISO 230-2: a position is NaN or infinite"
        raise DataError(msg)
    if run is not None and np.asarray(run).size != p.size:
        msg = "ISO 230-2: runs and positions differ in length"
        raise DataError(msg)
    return p, x, d


def iso230_2(position_deg: np.ndarray, deviation: np.ndarray, direction: np.ndarray | None,
             tol_deg: float = 0.01, circular: bool = False, run: np.ndarray | None = None,
             linear: bool = False) -> Iso230:
    """ISO 230-2 figures from every reading of a step run, one x_ij per approach.

    Parameters
    ----------
    position_deg : target position of each reading [deg; mm when ``linear``]
    deviation : positioning deviation x_ij = actual - target of each reading [arcsec;
        um when ``linear``] (a points stream's is -deviation, :attr:`Iso230.x_sign`)
    direction : +1 (approach from below) / -1 (from above) per reading; None: all up.
    tol_deg : measured positions closer than this [deg] are one target position.
    circular : group positions modulo 360 deg (rotary axis: 0 and 360 deg are one target).
    linear : a linear axis: positions [mm] (``tol_deg`` in mm), figures [um], never
        circular; the targets it asks for are counted per metre.
    run : the run of each reading; the readings of one run at one target in one
        direction are averaged into one x_ij. None: every reading is one approach.
    """
    p, x, d = _inputs(position_deg, deviation, direction, run)
    if linear and circular:
        msg = "ISO 230-2: a linear axis has no turn (circular)"
        raise DataError(msg)
    positions, index, _ = target_positions(p, tol_deg, circular)
    m = positions.size
    a_index, a_dir, a_x, per_approach = approaches(index, x, d, run)
    up = _direction(a_index[a_dir == UP], a_x[a_dir == UP], m, "up") if np.any(d == UP) else None
    down = (_direction(a_index[a_dir == DOWN], a_x[a_dir == DOWN], m, "down")
            if np.any(d == DOWN) else None)
    warnings = _runs_warning(up, down, per_approach)
    if circular:
        warnings += _targets_warning(positions)
    if linear:
        warnings += _linear_targets_warning(positions)
    result = (Iso230(positions, up, down, warnings=warnings, unit="um", position_unit="mm")
              if linear else Iso230(positions, up, down, warnings=warnings))
    if up is not None and down is not None:
        mean_i = (up.mean + down.mean) / 2.0
        B_i = up.mean - down.mean
        R_i = np.maximum.reduce([2 * up.s + 2 * down.s + np.abs(B_i), up.R_i, down.R_i])
        hi = np.maximum(up.mean, down.mean)
        lo = np.minimum(up.mean, down.mean)
        result.bidirectional = {
            "mean_i": mean_i, "B_i": B_i, "R_i": R_i,
            "B": float(np.max(np.abs(B_i))), "B_mean": float(np.mean(B_i)),
            "R": float(R_i.max()), "E": float(hi.max() - lo.min()),
            "M": float(mean_i.max() - mean_i.min()),
            "A": float(np.maximum(up.mean + 2 * up.s, down.mean + 2 * down.s).max()
                       - np.minimum(up.mean - 2 * up.s, down.mean - 2 * down.s).min()),
        }
    return result
