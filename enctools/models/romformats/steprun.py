"""The source of a control's table: a step run's means per target and direction, or a model.

A step run (a ``points`` stream: position [rad], deviation = indicated - true
[arcsec], direction +1/-1, run) gives per target and direction the mean over its
approaches (:func:`enctools.methods.targets.target_means`: the targets every command
counts alike): each run's readings at a target in a direction are averaged first, then
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
from enctools.methods.targets import target_means
from enctools.models.romformats.controls import SPACED_DEG, Source


def from_model(deviation: Callable[[np.ndarray], np.ndarray]) -> Source:
    """A model (angles [deg] -> deviation [arcsec]) as a unidirectional source."""
    return Source(lambda a: np.asarray(deviation(np.asarray(a, np.float64)), np.float64))


def from_points(position_deg: np.ndarray, deviation: np.ndarray,
                direction: np.ndarray | None, run: np.ndarray | None,
                count_deg: float = 0.0) -> Source:
    """A step run's per-target means per direction as a source (DataError, one line, when
    a direction misses a target or fewer than 2 targets are visited). The targets are
    those of :func:`enctools.methods.targets.group` (``count_deg``: one count of the
    encoder [deg])."""
    p = np.asarray(position_deg, np.float64)
    x = np.asarray(deviation, np.float64)
    if p.size == 0 or not (np.all(np.isfinite(p)) and np.all(np.isfinite(x))):
        msg = "the points stream is empty or holds NaN or infinite values"
        raise DataError(msg)
    d = np.ones(p.size) if direction is None else np.asarray(direction, np.float64)
    r = np.zeros(p.size) if run is None else np.asarray(run, np.float64)
    if not (np.all(np.isin(d, (1.0, -1.0))) and np.all(np.isfinite(r))):
        msg = "a direction is not +1 or -1, or a run is missing"
        raise DataError(msg)
    try:
        means = target_means(p, x, d, r.astype(np.int64), count_deg, "the step run")
    except DataError:
        msg = "the step run visits fewer than 2 targets"
        raise DataError(msg) from None
    for name, values in (("up (+1)", means.up), ("down (-1)", means.down)):
        if values is not None and np.any(np.isnan(values)):
            msg = (f"the {name} direction misses {int(np.sum(np.isnan(values)))} of the "
                   f"{values.size} targets; a table needs every target in every direction "
                   "it holds")
            raise DataError(msg)
    targets = means.position_deg
    nominal = np.arange(targets.size) * (360.0 / targets.size)
    if np.all(np.abs(targets - nominal) < SPACED_DEG):
        targets = nominal  # measured positions about m commanded steps over the turn
    up = means.up if means.up is not None else means.down
    down = means.down if means.up is not None else None
    assert up is not None
    return Source(_periodic(targets, up), None if down is None else _periodic(targets, down),
                  targets, None if down is None else up - down,
                  means.measured())


def _periodic(targets_deg: np.ndarray, values: np.ndarray
              ) -> Callable[[np.ndarray], np.ndarray]:
    """Linear interpolation of values at targets [deg], periodic over 360 deg."""
    t = np.r_[targets_deg, targets_deg[0] + 360.0]
    v = np.r_[values, values[0]]

    def at(angle_deg: np.ndarray) -> np.ndarray:
        a = t[0] + np.mod(np.asarray(angle_deg, np.float64) - t[0], 360.0)
        return np.interp(a, t, v)

    return at
