"""One checked device's interpolation error: its curve, its figures, its harmonics as metadata."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from enctools.data.statistics import curve_figures
from enctools.methods.interp.model import PeriodHarmonics


@dataclass
class Curve:
    """One checked device: its error on a phase grid and what made it.

    ``error`` [arcsec] and ``u`` [arcsec] on ``phase`` [rad] (zero mean);
    ``meta`` JSON-able facts (period, reference, figures, harmonics, warnings).
    """

    name: str
    encoder: str
    periods_per_rev: int
    phase: np.ndarray
    error: np.ndarray
    u: np.ndarray
    harmonics: PeriodHarmonics
    meta: dict[str, Any]
    warnings: list[str] = field(default_factory=list)


def error_figures(curve: np.ndarray) -> dict[str, float]:
    """Figures of an error curve [arcsec] as the output's metadata holds them.

    Those of :func:`enctools.data.statistics.curve_figures`, with its conventions (rms
    of the values themselves): the curve holds harmonics of the signal period only,
    sampled evenly over one period, so its mean is zero to rounding and its rms is
    also its standard deviation about the mean.
    """
    f = curve_figures(np.asarray(curve, dtype=np.float64))
    return {"pp": f.pp, "plus_minus": f.plus_minus, "mean": f.mean, "rms": f.rms,
            "max": f.maximum, "min": f.minimum}


def harmonics_meta(h: PeriodHarmonics) -> list[dict[str, float]]:
    """Order, amplitude [arcsec], phase [rad] and amplitude uncertainty [arcsec] per harmonic."""
    return [{"n": int(n), "amplitude": float(a), "phase": float(p), "u": float(u)}
            for n, a, p, u in zip(h.orders, h.amplitude, h.phase, h.amplitude_u, strict=True)]
