"""A block of a correction table quantised: the model's deviation [arcsec] at addresses
start..stop-1 made words [LSB] and the block's summary (:func:`quantise`), for
:func:`~enctools.models.rom.scan_rom`.

From the model's exact evaluation, or, where the model evaluates its grid cheaply within a
stated bound (a Fourier series' ``near``, :class:`~enctools.models.fourier.GridSeries`),
from that evaluation wherever the bound proves every word the same.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from enctools.errors import DataError


class RomSpec(Protocol):
    """What a block's quantisation reads of the table (:class:`enctools.models.rom.RomSpec`)."""

    @property
    def lsb_arcsec(self) -> float: ...

    @property
    def word_range(self) -> tuple[int, int]: ...

class SegmentGrid(Protocol):
    """A model's cubic a segment of a uniform grid (:class:`~enctools.models.fourier.
    GridSeries`): each segment's terms [arcsec], their powers of t, the bound [arcsec]."""

    powers: np.ndarray
    bound: float

    def terms(self, start: int, stop: int) -> np.ndarray: ...


#: the largest distance [LSB] of an approximate evaluation from the exact one that a block
#: is quantised from (:func:`quantise_near`); a coarser one: the block evaluated exactly
NEAR_LSB = 1e-6


def quantise(at: Callable[[int, int], np.ndarray], spec: RomSpec, dtype: np.dtype,
             start: int, stop: int) -> tuple[tuple[float, ...], np.ndarray | None]:
    """Addresses start..stop-1 quantised: their summary and words (``dtype``).

    The summary is (min, max, largest |quantisation error|, sum of squared corrections,
    sum of squared quantisation errors, largest |correction|, slack) [LSB, LSB^2]. A block
    beyond the word width has no words, but its range is returned, to name the width
    needed. A model that evaluates a grid within a stated bound (``at.near``) gives the
    words from that where no correction is within the bound of a half LSB (the same
    words); its largest errors are then known within ``slack`` [LSB] (0: exactly), and the
    sums to the bound.
    """
    near = getattr(at, "near", None)
    grid: SegmentGrid | None = at if hasattr(at, "terms") else None  # type: ignore[assignment]
    got = None if near is None else quantise_near(near, spec, dtype, start, stop, grid)
    return got if got is not None else quantise_exact(at, spec, dtype, start, stop)


def quantise_exact(at: Callable[[int, int], np.ndarray], spec: RomSpec, dtype: np.dtype,
                   start: int, stop: int) -> tuple[tuple[float, ...], np.ndarray | None]:
    """:func:`quantise` from the model evaluated exactly (slack 0)."""
    return summarised(np.multiply(at(start, stop), -1.0 / spec.lsb_arcsec,
                                  dtype=np.float64), spec, dtype)


def quantise_near(near: Callable[[int, int], tuple[np.ndarray, float]], spec: RomSpec,
                  dtype: np.dtype, start: int, stop: int,
                  grid: SegmentGrid | None = None
                  ) -> tuple[tuple[float, ...], np.ndarray | None] | None:
    """:func:`quantise` from the model's approximate values, or None where they may not
    give every word (a correction within their bound of a half LSB, a bound over
    :data:`NEAR_LSB`, or values not finite: the block is then evaluated exactly).

    With |approximate - exact| <= d and |approximate - word| < 1/2 - d, the exact
    correction rounds to the same word; ``d`` adds to the model's bound [arcsec] in LSB
    the rounding of the products by 1/LSB. A model whose approximation is a cubic a
    segment (``grid``: a :class:`~enctools.models.fourier.GridSeries`) is quantised a
    segment at a time where it can be (:mod:`.romsegments`)."""
    if grid is not None:
        from enctools.models import romsegments

        got = romsegments.quantise(grid, spec, dtype, start, stop)
        if got is not romsegments.UNSUITED:
            return got
    values, bound = near(start, stop)
    corr = np.multiply(values, -1.0 / spec.lsb_arcsec, dtype=np.float64)
    cmin, cmax = float(corr.min()), float(corr.max())
    if not (np.isfinite(cmin) and np.isfinite(cmax)):
        return None
    slack = bound / spec.lsb_arcsec + 4.0 * 2.0 ** -53 * (max(-cmin, cmax) + 1.0)
    if slack > NEAR_LSB:
        return None
    part, words = summarised(corr, spec, dtype, slack, (cmin, cmax))
    # beyond the width (the range named must be the exact one) or a word in doubt
    return None if words is None or part[2] >= 0.5 - slack else (part, words)


def summarised(corr: np.ndarray, spec: RomSpec, dtype: np.dtype, slack: float = 0.0,
               extremes: tuple[float, float] | None = None
                ) -> tuple[tuple[float, ...], np.ndarray | None]:
    """The summary and words of a block's corrections [LSB] (changed in place), whose
    smallest and largest are ``extremes`` when known."""
    # NaN or inf if any value is
    cmin, cmax = extremes or (float(corr.min()), float(corr.max()))
    # rint is monotonic: the words' range is the range of the corrections rounded
    qmin, qmax = float(np.rint(cmin)), float(np.rint(cmax))
    if not (np.isfinite(qmin) and np.isfinite(qmax)):
        msg = "the model gives NaN or infinite values; check the model stream"
        raise DataError(msg)
    lo, hi = spec.word_range
    if qmin < lo or qmax > hi:
        return (qmin, qmax, 0.0, 0.0, 0.0, 0.0, 0.0), None
    sum_corr, largest = float(corr @ corr), max(-cmin, cmax) + 0.0
    q = np.rint(corr)
    corr -= q
    err = max(-float(corr.min()), float(corr.max()))
    return (qmin, qmax, err, sum_corr, float(corr @ corr), largest, slack), q.astype(dtype)
