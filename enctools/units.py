"""Angle and length units: the constants that convert between them (multiply by them to
get rad, or m).

Internally angles are radians; errors and deviations are arcseconds; radial
error motion is nanometres; lengths in rig files are millimetres. A linear axis's
positions are millimetres and its deviations micrometres (``um``, printed µm).
"""

from __future__ import annotations

import math

TWO_PI = 2.0 * math.pi
#: one arcsecond in radians
ARCSEC = math.pi / (180.0 * 3600.0)
#: one degree in radians
DEG = math.pi / 180.0
#: one microradian in radians
URAD = 1e-6

#: the size of each angle unit in radians; every conversion goes through this table
ANGLE_UNITS = {"rad": 1.0, "mrad": 1e-3, "urad": URAD, "deg": DEG,
               "arcmin": DEG / 60.0, "arcsec": ARCSEC}
#: the size of each length unit in metres (a linear axis, enc-points(1), LINEAR AXES)
LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "nm": 1e-9}
#: the units a column of a user's table may be in (enc-points(1), TABLES): the angle
#: units, counts of an encoder (with its counts per revolution, :func:`counts_factor`),
#: and the lengths of a linear axis
COLUMN_UNITS = ("deg", "rad", "arcsec", "arcmin", "urad", "mrad", "counts", "mm", "um", "nm")
#: the units a person may ask to read angles in (``--unit``), the default first
DISPLAY_UNITS = ("arcsec", "urad", "mrad", "deg", "rad")
_SYMBOLS = {"arcsec": '"', "arcmin": "'", "deg": "°", "urad": "µrad", "mrad": "mrad",
            "rad": "rad", "um": "µm", "nm": "nm", "mm": "mm", "m": "m"}


def factor(from_unit: str, to_unit: str) -> float:
    """The number that multiplies a value in ``from_unit`` to give it in ``to_unit`` (two
    angle units, or two lengths; ValueError for an angle and a length).

    1.0 exactly when the units are the same, so that a value kept in its own unit is
    never touched by rounding.
    """
    if from_unit == to_unit:
        return 1.0
    if is_length(from_unit) and is_length(to_unit):
        return LENGTH_UNITS[from_unit] / LENGTH_UNITS[to_unit]
    try:
        return ANGLE_UNITS[from_unit] / ANGLE_UNITS[to_unit]
    except KeyError as exc:
        msg = f"not an angle unit: {exc.args[0]!r} (one of {', '.join(ANGLE_UNITS)})"
        raise ValueError(msg) from None


def is_length(unit: str | None) -> bool:
    """Whether ``unit`` is a length (m, mm, um, nm): a linear axis's."""
    return unit in LENGTH_UNITS


def symbol(unit: str) -> str:
    """How a value in ``unit`` is marked in text: ``"`` for arcsec, ``µrad``, ``°``."""
    return _SYMBOLS.get(unit, unit)


def counts_factor(counts_per_rev: float, to_unit: str) -> float:
    """The number that multiplies a value in counts (``counts_per_rev`` a revolution)
    to give it in the angle unit ``to_unit``."""
    if not counts_per_rev > 0:
        msg = f"counts per revolution must be > 0, not {counts_per_rev}"
        raise ValueError(msg)
    return TWO_PI / counts_per_rev / ANGLE_UNITS[to_unit]


def length_m(text: str) -> float:
    """A length as a person writes it, a number and a length unit (``20um``, ``20 µm``,
    ``0.02mm``, ``316.5nm``, ``1e-3 m``), in metres; ValueError naming what it is not."""
    t = text.strip().replace("µ", "u").replace("μ", "u")
    number = t.rstrip("abcdefghijklmnopqrstuvwxyz").rstrip()
    unit = t[len(number):].strip()
    if unit not in LENGTH_UNITS:
        msg = (f"{text!r} is not a length: a number and a unit, one of "
               f"{', '.join(LENGTH_UNITS)} (20um)")
        raise ValueError(msg)
    try:
        value = float(number)
    except ValueError:
        msg = f"{text!r} is not a length: {number!r} is not a number"
        raise ValueError(msg) from None
    return value / _PER_METRE[unit]  # 20 / 1e6 is 2e-05; 20 * 1e-6 is not


#: the size of a metre in each length unit (exact: a length divided by it is rounded once)
_PER_METRE = {"m": 1.0, "mm": 1e3, "um": 1e6, "nm": 1e9}
