"""Angle units and conversions.

Internally angles are radians; errors and deviations are arcseconds; radial
error motion is nanometres; lengths in rig files are millimetres.
"""

from __future__ import annotations

import math

import numpy as np

TWO_PI = 2.0 * math.pi
#: one arcsecond in radians
ARCSEC = math.pi / (180.0 * 3600.0)
#: one degree in radians
DEG = math.pi / 180.0
#: arcseconds in a full turn
ARCSEC_PER_REV = 1_296_000.0


def rad_to_arcsec(x: np.ndarray | float) -> np.ndarray | float:
    """Convert radians to arcseconds."""
    return np.asarray(x) / ARCSEC if isinstance(x, np.ndarray) else x / ARCSEC


def arcsec_to_rad(x: np.ndarray | float) -> np.ndarray | float:
    """Convert arcseconds to radians."""
    return x * ARCSEC


def counts_to_rad(counts: np.ndarray, counts_per_rev: int) -> np.ndarray:
    """Convert counts (int64) to radians, exactly up to float64 rounding."""
    return np.asarray(counts, dtype=np.float64) * (TWO_PI / counts_per_rev)
