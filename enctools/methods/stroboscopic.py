"""Sampling in step with a head's signal period: the run's samples meet the head's
interpolation error at nearly the same phase, which then aliases into low harmonics.

:func:`stroboscopic_heads` judges a stretch of samples by its step (enc interp-check's
windows); :func:`aliased_interpolation` a whole revolution by the angles it reached, and
:func:`warn_stroboscopic` warns on the first revolution of a self-calibration or a
comparison (:func:`enctools.methods.revolutions.revolutions`).

Units: angles in rad.
"""

from __future__ import annotations

import logging

import numpy as np

from enctools.data.readings import HeadInfo
from enctools.data.statistics import median
from enctools.methods.harmonics import revolution_coefficients
from enctools.units import TWO_PI

#: a sample step within this many signal periods of a whole number is "stroboscopic"
STROBOSCOPIC = 0.05


def stroboscopic_heads(step: float, heads: tuple[HeadInfo, ...]) -> list[tuple[str, float]]:
    """Heads whose signal phase barely moves from one sample to the next.

    ``step``: angle between samples [rad]. When it is within :data:`STROBOSCOPIC` of
    a whole number of signal periods, every sample meets the head's interpolation
    error at nearly the same phase, so a short stretch of samples (enc interp-check's
    window) does not go through the period. Returns (head, periods per sample).
    Whole revolutions are judged by :func:`aliased_interpolation` instead.
    """
    out = []
    for h in heads:
        periods = step * h.periods_per_rev / TWO_PI
        if abs(periods - round(periods)) < STROBOSCOPIC and periods > 0.5:
            out.append((h.name, periods))
    return out


#: a unit interpolation error that puts more than this fraction of its amplitude into one
#: harmonic the result resolves is aliased (sampled synchronously) ...
ALIASED = 0.05
#: ... or more than this many times the 1/sqrt(samples) of an evenly spread phase
ALIASED_OVER_SPREAD = 6.0


def aliased_interpolation(u: np.ndarray, start: float, periods_per_rev: int,
                          band: int) -> tuple[float, int, int]:
    """Where one revolution's sampling aliases a head's interpolation error.

    The interpolation error of a head with ``periods_per_rev`` signal periods per
    revolution repeats at its 1st and 2nd harmonics of the signal period. Sampled at
    the angles ``u`` [rad] the run actually reached over the revolution from ``start``
    [rad] (its measured speed, speed error and jitter included), a unit phasor
    ``exp(i m periods_per_rev u)`` has Fourier coefficients over the revolution; an
    evenly advancing phase leaves about
    1/sqrt(samples) in each, a phase that barely moves from sample to sample (a whole
    number of signal periods per sample) puts up to all of it into low harmonics,
    which no averaging of revolutions removes. Returns (largest coefficient's
    magnitude of harmonics 1..``band`` over m = 1, 2; that harmonic; m).
    """
    rows = []
    for m in (1, 2):
        phase = np.mod(u * (m * periods_per_rev), TWO_PI)
        rows += [np.cos(phase), np.sin(phase)]
    c = revolution_coefficients(u, np.array(rows), start, band)[:, 1:]
    best = (0.0, 0, 0)
    for k, m in enumerate((1, 2)):
        cos, sin = c[2 * k], c[2 * k + 1]
        # the phasor's coefficients at +n and -n (f = Re(sum c_n exp(i n u)))
        leak = np.maximum(np.abs(cos + 1j * sin), np.abs(np.conj(cos) + 1j * np.conj(sin))) / 2
        n = int(np.argmax(leak))
        if leak[n] > best[0]:
            best = (float(leak[n]), n + 1, m)
    return best


def warn_stroboscopic(u: np.ndarray, start: float, heads: tuple[HeadInfo, ...],
                      band: int) -> None:
    """Warn when a revolution's sampling (``u`` [rad] from ``start``, the first revolution's)
    aliases the interpolation error of one of ``heads`` into the harmonics 1..``band`` the
    result resolves (:func:`aliased_interpolation`)."""
    limit = max(ALIASED, ALIASED_OVER_SPREAD / np.sqrt(max(u.size, 1)))
    by_period: dict[int, list[str]] = {}
    for h in heads:
        names = by_period.setdefault(h.periods_per_rev, [])
        if h.name not in names:
            names.append(h.name)
    bad = []
    for ppr, names in by_period.items():
        leak, n, m = aliased_interpolation(u, start, ppr, band)
        if leak > limit:
            periods = abs(median(np.diff(u))) * ppr / TWO_PI
            bad.append(f"{', '.join(names)} ({periods:.4f} signal periods per sample: "
                       f"harmonic {m} of the period lands at n = {n} with {leak:.2f} "
                       f"of its amplitude)")
    if bad:
        logging.getLogger("enctools").warning(
            "sampling is nearly synchronous with the signal period of %s: their "
            "interpolation error aliases into low harmonics; record with another "
            "sample interval (`interval_s`)", "; ".join(bad))
