"""The source of a control's table: a step run's means per target and direction, or a model.

A step run (a ``points`` stream: position [rad], deviation = indicated - true
[arcsec], direction +1/-1, run) gives per target and direction the mean over its
approaches: each run's readings at a target in a direction are averaged first, then
the runs (ISO 230-2's mean unidirectional positioning deviation, in the deviation's
sign). Between targets the deviation is interpolated linearly and periodically over
the turn. Targets within SPACED_DEG of m equal steps over the turn are taken at those
steps (the commanded targets; measured positions scatter about them). The reversal
value per target is B_i = mean up - mean down [arcsec].
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from enctools.errors import DataError
from enctools.models.romformats.controls import SPACED_DEG, Source

#: measured positions closer than this [deg] are one target
TARGET_TOLERANCE_DEG = 1e-3


def from_model(deviation: Callable[[np.ndarray], np.ndarray]) -> Source:
    """A model (angles [deg] -> deviation [arcsec]) as a unidirectional source."""
    return Source(lambda a: np.asarray(deviation(np.asarray(a, np.float64)), np.float64))


def from_points(position_deg: np.ndarray, deviation: np.ndarray,
                direction: np.ndarray | None, run: np.ndarray | None) -> Source:
    """A step run's per-target means per direction as a source (DataError, one line, when
    a direction misses a target or fewer than 2 targets are visited)."""
    p = np.mod(np.asarray(position_deg, np.float64), 360.0)
    x = np.asarray(deviation, np.float64)
    if p.size == 0 or not (np.all(np.isfinite(p)) and np.all(np.isfinite(x))):
        msg = "the points stream is empty or holds NaN or infinite values"
        raise DataError(msg)
    d = np.ones(p.size) if direction is None else np.asarray(direction, np.float64)
    r = np.zeros(p.size) if run is None else np.asarray(run, np.float64)
    if not (np.all(np.isin(d, (1.0, -1.0))) and np.all(np.isfinite(r))):
        msg = "a direction is not +1 or -1, or a run is missing"
        raise DataError(msg)
    r = r.astype(np.int64)
    targets, index = _targets(p)
    if targets.size < 2:
        msg = "the step run visits fewer than 2 targets"
        raise DataError(msg)
    nominal = np.arange(targets.size) * (360.0 / targets.size)
    if np.all(np.abs(targets - nominal) < SPACED_DEG):
        targets = nominal  # measured positions about m commanded steps over the turn
    means = {}
    for sign in (1, -1):
        sel = d == sign
        if sel.any():
            means[sign] = _direction_means(index[sel], x[sel], r[sel], targets.size, sign)
    up = means[1] if 1 in means else means[-1]
    down = means[-1] if len(means) == 2 else None
    return Source(_periodic(targets, up), None if down is None else _periodic(targets, down),
                  targets, None if down is None else up - down)


def _targets(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Targets [deg] (sorted, closer than TARGET_TOLERANCE_DEG are one, 360 = 0) and the
    target of each position."""
    order = np.argsort(p, kind="stable")
    new = np.concatenate([[True], np.diff(p[order]) > TARGET_TOLERANCE_DEG])
    group = np.cumsum(new) - 1
    if group[-1] > 0 and p[order][0] + 360.0 - p[order][-1] <= TARGET_TOLERANCE_DEG:
        group[group == group[-1]] = 0  # 359.9995 and 0 are one target
    index = np.empty(p.size, np.int64)
    index[order] = group
    first = np.zeros(group[-1] + 1 if group.size else 0)
    first[group[::-1]] = p[order][::-1]  # each target at its smallest position
    return first, index


def _direction_means(index: np.ndarray, x: np.ndarray, run: np.ndarray, m: int,
                     sign: int) -> np.ndarray:
    """Per target the mean over runs of each run's mean deviation [arcsec]."""
    keys = np.stack([index, run]).T
    uniq, group = np.unique(keys, axis=0, return_inverse=True)
    group = group.reshape(-1)
    per_run = np.bincount(group, weights=x) / np.bincount(group)
    runs = np.bincount(uniq[:, 0], minlength=m)
    if np.any(runs == 0):
        name = "up (+1)" if sign > 0 else "down (-1)"
        msg = (f"the {name} direction misses {int(np.sum(runs == 0))} of the {m} targets; "
               "a table needs every target in every direction it holds")
        raise DataError(msg)
    return np.bincount(uniq[:, 0], weights=per_run, minlength=m) / runs


def _periodic(targets_deg: np.ndarray, values: np.ndarray
              ) -> Callable[[np.ndarray], np.ndarray]:
    """Linear interpolation of values at targets [deg], periodic over 360 deg."""
    t = np.r_[targets_deg, targets_deg[0] + 360.0]
    v = np.r_[values, values[0]]

    def at(angle_deg: np.ndarray) -> np.ndarray:
        a = t[0] + np.mod(np.asarray(angle_deg, np.float64) - t[0], 360.0)
        return np.interp(a, t, v)

    return at
