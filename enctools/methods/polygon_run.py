"""What a polygon step run's points record of the run for their uncertainty budget
(``polygon_run`` metadata): the scatter of its readings and heads, the autocollimator's
span, one count, and what its Type A spans (runs, directions, the readings' interval).
Made by :func:`enctools.methods.points.points_from_steps`; read by ``report/budget``."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.units import ARCSEC


def run_meta(heads: np.ndarray, ac: np.ndarray, keys: tuple[np.ndarray, ...],
             visits: tuple[np.ndarray, np.ndarray], lsb: float) -> dict[str, Any]:
    """What a polygon run tells its uncertainty budget (``polygon_run`` metadata, [arcsec]):
    the pooled standard deviation of one reading's deviation (head mean minus
    autocollimator) and of one head's reading about their position's mean, its degrees
    of freedom, the fewest readings of a position, the largest |a_j - a_0| of a run's
    autocollimator means, one count ``lsb`` [arcsec] and the number of heads averaged.
    (A run of one approach adds each point's a_j - a_0 [arcsec] and face j from the first,
    ``ac_arcsec`` and ``face``, in the points' order.)"""
    key = np.stack(keys).T
    ok = np.isfinite(ac)
    visit = np.r_[0, np.cumsum(np.any(key[1:] != key[:-1], axis=1))][ok]
    n = np.bincount(visit)
    used = n > 0
    dof = int(np.sum(n[used] - 1))

    def pooled(x: np.ndarray) -> float:
        mean = np.bincount(visit, x, n.size)[visit] / n[visit]
        return float(np.sum((x - mean) ** 2)) / dof

    h = heads[:, ok] / ARCSEC
    d = h.mean(axis=0) - ac[ok]
    s = math.sqrt(pooled(d - d[0])) if dof > 0 else None
    head_s = math.sqrt(np.mean([pooled(x - x[0]) for x in h])) if dof > 0 else None
    vac, vr = visits
    span = max(float(np.max(np.abs(vac[vr == r] - vac[vr == r][0]))) for r in np.unique(vr))
    return {"s_arcsec": s, "dof": dof, "readings": int(n[used].min()),
            "span_arcsec": span, "lsb_arcsec": lsb,
            "heads": int(heads.shape[0]), "head_s_arcsec": head_s}


def span_meta(table: pa.Table, keys: tuple[np.ndarray, ...], vr: np.ndarray,
              vd: np.ndarray) -> dict[str, Any]:
    """What a run's Type A spans (``polygon_run`` metadata): ``runs`` and ``directions``
    [count] and ``interval_s``, the median time between consecutive readings of one stop
    [s] (absent without a ``t`` column or repeated readings)."""
    out: dict[str, Any] = {"runs": int(np.unique(vr).size),
                           "directions": int(np.unique(vd).size)}
    if "t" not in table.column_names:
        return out
    t = table.column("t").to_numpy(zero_copy_only=False).astype(np.float64)
    key = np.stack(keys).T
    same = np.all(key[1:] == key[:-1], axis=1) & np.isfinite(t[1:]) & np.isfinite(t[:-1])
    if np.any(same):
        out["interval_s"] = float(np.median(np.diff(t)[same]))
    return out
