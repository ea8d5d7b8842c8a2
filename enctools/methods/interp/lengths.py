"""A linear scale's interpolation error as a length: nm of travel within its signal period.

The Heydemann fit (:mod:`.signals`) gives the error of the phase a head reads; on a
rotary encoder of N signal periods a revolution it is an angle, phase error / N
[rad], reported in arcsec. On a linear scale of signal period P (a 20 µm grating: 20,000
nm) one period of phase is P of travel, so the same phase error is a length:

    error [nm] = phase error [rad] / (2 pi) x P [nm]

(the phase error of a quadrature pair: Heydemann, Appl. Opt. 20 (1981) 3382; scale
makers state a linear encoder's interpolation error as such a length, enc-interp-check(1),
LINEAR SCALES).
:func:`to_length` rescales a curve reported in arcsec (its phase error / N) into nm,
with its u, harmonics, figures and metadata; nothing of the angle is left in it.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import pyarrow as pa

from enctools.methods.interp.curve import Curve
from enctools.methods.interp.model import PeriodHarmonics
from enctools.units import ARCSEC, TWO_PI, factor

#: a signal period [m]: 1 nm (an interferometer's quadrature is lambda/2, 316 nm for a
#: HeNe laser; a grating scale 4 µm to 40 µm, a magnetic tape 1 mm to 5 mm) to 1 m
SIGNAL_PERIOD_M = (1e-9, 1.0)
#: nanometres a metre (exact, where factor("m", "nm") is 1/1e-9, 999999999.9999999)
NM_PER_M = 1e9
#: the keys of a curve's metadata in arcsec, and what they become
_ANGLE_KEYS = {"mean_arcsec": "mean_nm"}


def nm_per_arcsec(periods_per_rev: int, signal_period_m: float) -> float:
    """The number that multiplies an interpolation error [arcsec] of a head with
    ``periods_per_rev`` signal periods a revolution to give it in nm of a scale whose
    signal period is ``signal_period_m`` [m]: arcsec -> phase (x N) -> nm (P / 2 pi)."""
    return ARCSEC * periods_per_rev / TWO_PI * signal_period_m * NM_PER_M


def check_period(signal_period_m: float) -> None:
    """ValueError unless ``signal_period_m`` [m] is within :data:`SIGNAL_PERIOD_M`."""
    lo, hi = SIGNAL_PERIOD_M
    if not lo <= signal_period_m <= hi:  # also NaN
        msg = f"a signal period must be 1 nm..1 m, not {signal_period_m!r} m"
        raise ValueError(msg)


def declared_periods(schema: pa.Schema) -> dict[str, float]:
    """The signal period [m] each head's signal columns state in their field metadata
    ``signal_period_nm`` (a readings stream of a linear scale, enc-streams(5)), by head;
    a head whose columns state none, or two, is left out."""
    if not any(b"signal_period_nm" in (f.metadata or {}) for f in schema):
        return {}  # a rotary encoder's readings: no need of the signal columns' module (scipy)
    from enctools.data.limits import FIELD_RANGES
    from enctools.data.schemas import field_meta, parse_field_value
    from enctools.methods.interp.signals import signal_columns

    rng = FIELD_RANGES["signal"]["signal_period_nm"]
    out = {}
    for head, components in signal_columns(schema).items():
        said = {parse_field_value(field_meta(schema.field(c)).get("signal_period_nm", ""), rng)
                for c in components.values()}
        if len(said) == 1 and None not in said:
            out[head] = float(said.pop() or 0.0) / NM_PER_M
    return out


def to_length(curve: Curve, signal_period_m: float) -> Curve:
    """``curve`` (error and u [arcsec] of a head with its periods per revolution) in nm
    of a scale with signal period ``signal_period_m`` [m]: values, u, harmonics (and
    their covariance, [nm^2]) and the metadata's figures, mean and harmonics scaled; its
    period given as ``period_nm``, the angle's ``period_arcsec`` and
    ``periods_per_rev`` left out; ``unit`` nm."""
    check_period(signal_period_m)
    k = nm_per_arcsec(curve.periods_per_rev, signal_period_m)
    h = curve.harmonics
    meta: dict[str, Any] = {}
    for key, value in curve.meta.items():
        if key in ("period_arcsec", "periods_per_rev"):
            continue
        meta[_ANGLE_KEYS.get(key, key)] = _scaled(key, value, k)
    meta["period_nm"] = signal_period_m * NM_PER_M
    meta["unit"] = "nm"
    return replace(curve, error=curve.error * k, u=curve.u * k,
                   harmonics=PeriodHarmonics(h.orders, h.coef * k, h.cov * (k * k)),
                   meta=meta)


def _scaled(key: str, value: Any, k: float) -> Any:
    """A metadata value in nm: the figures (all of the error's unit), the mean, each
    harmonic's amplitude and u; anything else (the fit [V, rad], the reference) as is."""
    if key == "figures":
        return {name: v * k for name, v in value.items()}
    if key in _ANGLE_KEYS:
        return value * k
    if key == "harmonics":
        return [{name: (v * k if name in ("amplitude", "u") else v) for name, v in row.items()}
                for row in value]
    return value


def period_text(signal_period_m: float) -> str:
    """A signal period as a person gives it: 20 µm, 316.5 nm, 2 mm (4 significant digits)."""
    for unit in ("mm", "um", "nm"):
        v = signal_period_m * factor("m", unit)
        if v >= 1.0 or unit == "nm":
            digits = max(0, 3 - math.floor(math.log10(v))) if v > 0 else 0
            text = f"{v:.{digits}f}".rstrip("0").rstrip(".")
            return f"{text} {'µm' if unit == 'um' else unit}"
    raise AssertionError  # the loop ends at nm
