"""Type B declarations of a rig file (``[uncertainty.NAME]``, enc-rig(5)).

A lab declares, per input quantity of its measurement, what its certificates or its
knowledge say: a value in a unit, its distribution (or the coverage factor k of an
expanded value), the degrees of freedom where known and the source (certificate no.).
This module checks one declaration and turns it into a standard uncertainty in the
quantity's base unit; the sensitivity coefficients come from the measurement models
of :mod:`enctools.methods.budget`.

The same check reads the declarations of a rig file and those a stream's metadata
carries (``meta["rig"]["uncertainty"]``): both are data from elsewhere.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from enctools.errors import DataError
from enctools.units import ANGLE_UNITS, ARCSEC

#: the size of each unit in its dimension's base unit (arcsec, m, K, 1)
UNITS: dict[str, dict[str, float]] = {
    "angle": {u: v / ARCSEC for u, v in ANGLE_UNITS.items()},
    "length": {"m": 1.0, "mm": 1e-3, "um": 1e-6, "nm": 1e-9},
    "temperature": {"K": 1.0},
    "relative": {"1": 1.0, "%": 1e-2, "ppm": 1e-6},
}
#: the base unit of each dimension, as a Contribution names it
BASE_UNIT = {"angle": "arcsec", "length": "m", "temperature": "K", "relative": "1"}

#: each quantity a rig may declare -> its dimension and what it is (enc-rig(5))
QUANTITIES: dict[str, tuple[str, str]] = {
    "polygon": ("angle", "polygon face angle deviation (each face)"),
    "autocollimator": ("relative", "autocollimator scale (calibration) error"),
    "probe_arm": ("length", "probe arm length L"),
    "probe": ("relative", "probe calibration (scale) error"),
    "temperature": ("temperature", "deviation of the arm's temperature from 20 degC"),
    "head_mounting": ("angle", "mounting angle of a scanning head"),
    "reference_encoder": ("angle", "calibrated deviation of the reference encoder of a "
                                   "comparison or a step run (its certificate's uncertainty)"),
    "reference_encoder_uncorrected": ("angle", "accuracy of the reference encoder used without "
                                               "its calibrated curve: the bound of its error "
                                               "(a half-width, as a maker states a grade)"),
    "alignment": ("angle", "alignment of a step run's reference instrument (or polygon) to "
                           "the axis: the angle error its residual eccentricity or tilt makes "
                           "at a target"),
    "autocollimator_resolution": ("angle", "resolution of the autocollimator's reading"),
    "autocollimator_noise": ("angle", "autocollimator noise and air turbulence beyond the "
                                      "scatter of a stop's readings"),
    "face_flatness": ("angle", "angle error from the flatness of a polygon face"),
    "pyramidal": ("angle", "angle error from a polygon face's pyramidal error (tilt)"),
    "temperature_drift": ("angle", "drift of the polygon method's zero with temperature "
                                   "over a run"),
}

#: divisors of the GUM for a value of each distribution (GUM 4.3.7-4.3.9)
DIVISORS: dict[str, float] = {
    "normal": 1.0,           # a standard deviation (or an expanded U with divisor k)
    "rectangular": math.sqrt(3.0),
    "triangular": math.sqrt(6.0),
    "u-shaped": math.sqrt(2.0),
}

#: the keys of one declaration and their types (rig.py checks a rig file's tables by it)
KEYS: dict[str, tuple[type, ...]] = {
    "value": (int, float), "unit": (str,), "distribution": (str,), "k": (int, float),
    "dof": (int, float), "source": (str,), "expansion_per_k": (int, float), "encoder": (str,)}
#: the quantities a declaration may tie to one of the rig's encoders (``encoder = "I"``)
ENCODER_QUANTITIES = ("reference_encoder", "reference_encoder_uncorrected")


@dataclass(frozen=True)
class Declaration:
    """One declared input quantity: ``value`` in ``unit``, its distribution, the
    coverage factor ``k`` of an expanded value (1: a standard deviation or a half-width),
    degrees of freedom (``math.inf``: taken as exact) and the source.

    ``expansion_per_k`` [1/K]: the arm's expansion coefficient (temperature only).
    ``kind``: the evaluation, "B" (a rig's declarations) or "A" (a certificate's u that
    a Type A evaluation gave, as enc closure's face errors).
    ``encoder``: the rig's encoder a reference encoder's row is of ("": not said, any).
    """

    quantity: str
    value: float
    unit: str
    distribution: str
    k: float = 1.0
    dof: float = math.inf
    source: str = ""
    expansion_per_k: float = 0.0
    kind: str = "B"
    encoder: str = ""

    @property
    def dimension(self) -> str:
        return QUANTITIES[self.quantity][0]

    @property
    def divisor(self) -> float:
        """What turns ``value`` into a standard uncertainty: k, or the distribution's."""
        return self.k if self.distribution == "normal" else DIVISORS[self.distribution]

    @property
    def base_value(self) -> float:
        """``value`` in the dimension's base unit (arcsec, m, K, 1)."""
        return self.value * UNITS[self.dimension][self.unit]

    @property
    def standard(self) -> float:
        """The standard uncertainty in the base unit (arcsec, m, K, 1)."""
        return self.base_value / self.divisor


def _number(table: dict[str, Any], key: str, where: str, default: float) -> float:
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int | float):
        msg = f"{where}.{key} must be a number, not {value!r}"
        raise DataError(msg)
    return float(value)


def declaration(quantity: str, table: Any, where: str) -> Declaration:
    """Check one ``[uncertainty.QUANTITY]`` table and return its declaration.

    DataError (one line naming ``where``, the key and the value) on an unknown
    quantity or key, a value that is negative or not finite, an unknown distribution,
    a unit not of the quantity's dimension, k without a normal distribution, k or dof
    not > 0, a temperature without a finite expansion coefficient.
    """
    if quantity not in QUANTITIES:
        msg = f"{where}: unknown quantity {quantity!r} (one of {', '.join(QUANTITIES)})"
        raise DataError(msg)
    if not isinstance(table, dict):
        msg = f"{where} must be a table, not {table!r}"
        raise DataError(msg)
    unknown = [k for k in table if k not in KEYS]
    if unknown:
        msg = f"{where}: unknown key {unknown[0]!r} (keys: {', '.join(KEYS)})"
        raise DataError(msg)
    dimension = QUANTITIES[quantity][0]
    if "value" not in table or "unit" not in table:
        msg = f"{where} needs the keys 'value' and 'unit'"
        raise DataError(msg)
    value = _number(table, "value", where, math.nan)
    if not (math.isfinite(value) and value >= 0.0):
        msg = f"{where}.value must be finite and >= 0, not {value!r}"
        raise DataError(msg)
    unit = table["unit"]
    if not isinstance(unit, str) or unit not in UNITS[dimension]:
        msg = (f"{where}.unit {unit!r} is not a unit of {dimension} "
               f"(one of {', '.join(UNITS[dimension])})")
        raise DataError(msg)
    distribution = table.get("distribution", "normal")
    if not isinstance(distribution, str) or distribution not in DIVISORS:
        msg = (f"{where}.distribution must be one of {', '.join(DIVISORS)}, "
               f"not {distribution!r}")
        raise DataError(msg)
    if "k" in table and distribution != "normal":
        msg = f"{where}.k is for an expanded value of a normal distribution, not {distribution}"
        raise DataError(msg)
    k, dof = _number(table, "k", where, 1.0), _number(table, "dof", where, math.inf)
    for key, v in (("k", k), ("dof", dof)):
        if key in table and not (v > 0.0 and math.isfinite(v)):
            msg = f"{where}.{key} must be finite and > 0 (no dof: taken as exact), not {v!r}"
            raise DataError(msg)
    expansion = _number(table, "expansion_per_k", where, math.nan if dimension ==
                        "temperature" else 0.0)
    if dimension == "temperature" and not (math.isfinite(expansion) and abs(expansion) < 1e-3):
        msg = f"{where}.expansion_per_k must be a finite coefficient [1/K] below 1e-3"
        raise DataError(msg)
    if dimension != "temperature" and "expansion_per_k" in table:
        msg = f"{where}.expansion_per_k is for [uncertainty.temperature] only"
        raise DataError(msg)
    source = table.get("source", "")
    if not isinstance(source, str):
        msg = f"{where}.source must be a string, not {source!r}"
        raise DataError(msg)
    return Declaration(quantity, value, unit, distribution, k, dof, source, expansion,
                       encoder=_encoder(table, quantity, where))


def _encoder(table: dict[str, Any], quantity: str, where: str) -> str:
    """The encoder a reference encoder's declaration is of ("" when it names none)."""
    encoder = table.get("encoder", "")
    if encoder and quantity not in ENCODER_QUANTITIES:
        msg = f"{where}.encoder is for {' and '.join(ENCODER_QUANTITIES)} only"
        raise DataError(msg)
    if not isinstance(encoder, str) or ("encoder" in table and not encoder.strip()):
        msg = f"{where}.encoder must name one of the rig's encoders, not {encoder!r}"
        raise DataError(msg)
    return encoder


def declarations(tables: Any, where: str) -> dict[str, Declaration]:
    """Every declaration of an ``[uncertainty]`` table (a rig file's or a stream's)."""
    if tables is None:
        return {}
    if not isinstance(tables, dict):
        msg = f"{where} must be a table, not {tables!r}"
        raise DataError(msg)
    return {q: declaration(q, t, f"{where}.{q}") for q, t in tables.items()}
