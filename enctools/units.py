"""Angle units: the constants that convert between them (multiply by them to get rad).

Internally angles are radians; errors and deviations are arcseconds; radial
error motion is nanometres; lengths in rig files are millimetres.
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
#: the units a column of a user's table may be in (enc-points(1), TABLES): the angle
#: units, and counts of an encoder (with its counts per revolution, :func:`counts_factor`)
COLUMN_UNITS = ("deg", "rad", "arcsec", "arcmin", "urad", "mrad", "counts")
#: the units a person may ask to read angles in (``--unit``), the default first
DISPLAY_UNITS = ("arcsec", "urad", "mrad", "deg", "rad")
_SYMBOLS = {"arcsec": '"', "arcmin": "'", "deg": "°", "urad": "µrad", "mrad": "mrad",
            "rad": "rad"}


def factor(from_unit: str, to_unit: str) -> float:
    """The number that multiplies a value in ``from_unit`` to give it in ``to_unit``.

    1.0 exactly when the units are the same, so that a value kept in its own unit is
    never touched by rounding.
    """
    if from_unit == to_unit:
        return 1.0
    try:
        return ANGLE_UNITS[from_unit] / ANGLE_UNITS[to_unit]
    except KeyError as exc:
        msg = f"not an angle unit: {exc.args[0]!r} (one of {', '.join(ANGLE_UNITS)})"
        raise ValueError(msg) from None


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
