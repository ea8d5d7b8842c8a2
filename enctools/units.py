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
