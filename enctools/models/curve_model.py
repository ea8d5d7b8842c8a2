"""Model streams: error models any command can evaluate at any angle.

A ``model`` stream holds an RBF network (one row per unit: ``centre`` [rad; deg in v1],
``weight`` [arcsec]) or a Fourier series (one row per harmonic: ``n``, ``weight``
= cosine and ``weight_sin`` = sine coefficient [arcsec]); its metadata key
``model`` names the kernel and its parameters. A ``deviations`` stream (a curve on
a uniform grid of ``theta`` [rad]) is a model too: it is evaluated by periodic
linear interpolation.

Sign: a model gives the *deviation* (indicated minus true angle, arcsec) at an
indicated angle [deg]; the correction to add to a reading is its negative.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.arrays import arrow_array
from enctools.data.columns import column, declared_unit
from enctools.data.limits import MAX_MODEL_TERMS
from enctools.data.schemas import column_with_role, make_field
from enctools.errors import DataError, SettingsError
from enctools.models.fourier import COND_LIMIT, FourierModel
from enctools.models.rbf import SPREAD_FACTOR, RBFModel
from enctools.units import TWO_PI, factor

KERNELS = ("rbf", "fourier")


@dataclass
class CurveModel:
    """A deviations curve [arcsec] on a uniform grid of angles [deg], periodic."""

    theta_deg: np.ndarray
    values: np.ndarray
    name: str = ""

    def __call__(self, angle_deg: np.ndarray | float) -> np.ndarray:
        x = np.asarray(angle_deg, dtype=np.float64)
        return np.interp(np.mod(x, 360.0), self.theta_deg, self.values, period=360.0)


Evaluator = Callable[[np.ndarray], np.ndarray]


def model_table(model: RBFModel | FourierModel) -> tuple[pa.Table, dict[str, Any]]:
    """The rows and the ``model`` metadata of a model stream."""
    if isinstance(model, RBFModel):
        schema = pa.schema([make_field("centre", pa.float64(), "rad"),
                            make_field("weight", pa.float64(), "arcsec")])
        table = pa.table([arrow_array(model.centres_deg * factor("deg", "rad")),
                          arrow_array(model.weights)], schema=schema)
        meta = {"kernel": "rbf", "spread_deg": float(model.spread_deg),
                "spread_factor": SPREAD_FACTOR, "distance": "chord on the unit circle",
                "bias_arcsec": float(model.bias), "units": int(model.centres_deg.size),
                "equation": "seed 001 eqs. (5)-(7): y = sum w_i exp(-0.8326^2 d^2 / c^2)"}
    else:
        schema = pa.schema([make_field("n", pa.int32(), ""),
                            make_field("weight", pa.float64(), "arcsec"),
                            make_field("weight_sin", pa.float64(), "arcsec")])
        table = pa.table([arrow_array(model.n.astype(np.int32)), arrow_array(model.a),
                          arrow_array(model.b)], schema=schema)
        meta = {"kernel": "fourier", "harmonics": int(model.n.max()),
                "undetermined": list(model.undetermined),
                "ill_conditioned": list(model.ill_conditioned),
                "condition_limit": COND_LIMIT, "condition_number": model.condition,
                "equation": "y = sum_n weight cos(n x) + weight_sin sin(n x)"}
    meta |= {"argument": "indicated angle x [rad], periodic in 2 pi",
             "output": "deviation [arcsec] = indicated - true; correction = -deviation"}
    return table, meta


def _col(table: pa.Table, name: str, source: str, unit: str = "",
         meta: dict[str, Any] | None = None) -> np.ndarray:
    """Column ``name`` of a model stream, finite, in ``unit`` (converted from the unit of
    its field metadata, else of the schema version ``meta`` declares)."""
    if name not in table.column_names:
        msg = f"{source}: model stream lacks the column {name!r} its kernel needs"
        raise DataError(msg)
    a = (column(table, name, unit, source, declared_unit("model", meta or {}, name)) if unit
         else table.column(name).to_numpy())
    if not np.all(np.isfinite(a)):
        msg = f"{source}: column {name!r} holds NaN or infinite values"
        raise DataError(msg)
    return a


def _meta_number(m: dict, key: str, default: float, source: str) -> float:
    """A finite number of the model metadata (DataError naming the key)."""
    value = m.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        msg = f"{source}: model metadata {key} = {str(value)[:40]!r} is not a finite number"
        raise DataError(msg)
    return float(value)


def from_stream(header: Any, table: pa.Table, source: str = "input",
                curve: str | None = None) -> Evaluator:
    """An evaluator (angles [deg] -> deviation [arcsec]) from a model or deviations stream."""
    if header.kind == "deviations":
        return curve_model(header, table, source, curve)
    if curve is not None:
        msg = (f"`curve` {curve} chooses a curve of a deviations stream; {source} is a "
               f"{header.kind} stream (leave `curve` out)")
        raise SettingsError(msg)
    m = header.meta.get("model", {})
    kernel = m.get("kernel") if isinstance(m, dict) else None
    if table.num_rows == 0:
        msg = f"{source}: the model stream has no rows"
        raise DataError(msg)
    if table.num_rows > MAX_MODEL_TERMS:
        msg = (f"{source}: a model of {table.num_rows} centres or harmonics; at most "
               f"{MAX_MODEL_TERMS} are evaluated (enc-streams(5), LIMITS)")
        raise DataError(msg)
    if kernel == "rbf":
        spread = _meta_number(m, "spread_deg", 0.0, source)
        if not 0 < spread <= 360:
            msg = f"{source}: rbf model without a spread_deg in (0, 360] deg in its metadata"
            raise DataError(msg)
        return RBFModel(_col(table, "centre", source, "deg", header.meta),
                        _col(table, "weight", source, "arcsec", header.meta),
                        _meta_number(m, "bias_arcsec", 0.0, source), spread)
    if kernel == "fourier":
        n = _col(table, "n", source).astype(np.int64)
        if n.min() < 0:
            msg = f"{source}: negative harmonic order in column 'n'"
            raise DataError(msg)
        return FourierModel(n, _col(table, "weight", source, "arcsec", header.meta),
                            _col(table, "weight_sin", source, "arcsec", header.meta))
    msg = f"{source}: unknown model kernel {kernel!r} (kernels: {', '.join(KERNELS)})"
    raise DataError(msg)


def curve_model(header: Any, table: pa.Table, source: str, curve: str | None) -> CurveModel:
    """A deviations curve as a model: periodic linear interpolation of its values [arcsec]
    on its grid (theta [rad], kept in deg); NaN points are bridged with a warning."""
    curve = column_with_role(header.schema, "deviation", curve, source, "`curve`")
    theta = column(table, "theta", "rad", source)
    values = column(table, curve, "arcsec", source)
    ok = np.isfinite(theta) & np.isfinite(values)
    if ok.sum() < 2:
        msg = f"{source}: curve {curve!r} has fewer than 2 finite points"
        raise DataError(msg)
    if not ok.all():
        import logging

        logging.getLogger("enctools").warning(
            "%s: curve %r has %d of %d points NaN (e.g. empty angle bins); the table "
            "interpolates across them", source, curve, int((~ok).sum()), ok.size)
    th = np.mod(theta[ok], TWO_PI) * factor("rad", "deg")
    order = np.argsort(th)
    return CurveModel(th[order], values[ok][order], curve)
