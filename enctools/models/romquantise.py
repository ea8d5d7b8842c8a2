"""A block of a correction table quantised: the model's deviation [arcsec] at addresses
start..stop-1 made words [LSB] and the block's summary (:func:`quantise`), for
:func:`~enctools.models.rom.scan_rom`.

From the model's exact evaluation, or, where the model evaluates its grid cheaply within a
stated bound (a Fourier series' ``near``, :class:`~enctools.models.fourier.GridSeries`),
from that evaluation wherever the bound proves every word the same.

A segment at a time (:func:`quantise_segments`): the cubic of a segment of S points is
P(t) = a0 + a1 t + a2 t^2 + a3 t^3 [LSB] at its points t = i - h (h = (S - 1) / 2),
within d [LSB] of the exact corrections (the model's bound and the rounding). Over the
segment P stays within r = |a1| h + |a2| h^2 + |a3| h^3 of a0, so a segment whose a0
lies farther than r + d from every half LSB has one word at every point, the word of a0:
the word of every exact correction there. Its sums of squares come from the coefficients
in closed form (the sums of t^2, t^4 and t^6 over its points), once for the segment. A
table's corrections change slowly (the table-1 model's 1680 times in 2^26 addresses), so
all but a few segments of a block are such: the block costs the cubics' terms and a few
passes over its segments instead of a dozen over its points. The other segments are
evaluated point by point, as :func:`quantise_near` evaluates a whole block: those near a
half LSB, and those whose upper bound (|a0 - word| + r, |a0| + r) reaches the largest
lower bound of a segment of one word (its ends' values, points of the grid), which hold
the block's largest quantisation error and largest correction. The words are therefore
those of the exact corrections, the largest figures known within the same slack as
:func:`quantise_near`'s, and the sums to the bound.
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
    segment at a time where it can be (:func:`quantise_segments`)."""
    if grid is not None:
        got = quantise_segments(grid, spec, dtype, start, stop)
        if got is not UNSUITED:
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


#: what :func:`quantise_segments` returns for a block it does not take (not whole segments, or
#: more than :data:`DENSE` of them to evaluate point by point): the caller's whole-block
#: evaluation then runs
UNSUITED = (float("nan"),), None
#: the share of a block's segments evaluated point by point past which the whole block is
DENSE = 0.25
#: the unit roundoff of float64
_U = 2.0 ** -53


def quantise_segments(grid: SegmentGrid, spec: RomSpec, dtype: np.dtype, start: int, stop: int
             ) -> tuple[tuple[float, ...], np.ndarray | None] | None:
    """Addresses start..stop-1 quantised from ``grid``'s cubics a segment at a time
    (:func:`quantise_near`'s summary and words), None where a word is in doubt, the bound
    too coarse, a value not finite or beyond the word width (the block is then evaluated
    exactly), or :data:`UNSUITED`."""
    size = grid.powers.shape[1]
    n = stop - start
    if n % size:
        return UNSUITED
    arcsec = grid.terms(start, stop)[:n // size]
    scale = -1.0 / spec.lsb_arcsec
    a = np.multiply(arcsec.T, scale, order="C")  # (4, segments) [LSB]
    h = (size - 1) / 2.0
    reach = np.abs(a[1]) * h + np.abs(a[2]) * (h * h) + np.abs(a[3]) * (h * h * h)
    centre = a[0]
    top = float(np.max(np.abs(centre) + reach))
    if not np.isfinite(top):
        return None
    slack = grid.bound / spec.lsb_arcsec + 4.0 * _U * (top + 1.0)
    if slack > NEAR_LSB:
        return None
    margin = slack + 16.0 * _U * (top + 1.0)  # and the rounding of these figures
    q = np.rint(centre)
    off = np.abs(centre - q)
    flag = _evaluated(a, q, off, reach, h, margin)
    idx = np.flatnonzero(flag)
    if idx.size > DENSE * flag.size:
        return UNSUITED
    values = np.multiply(arcsec[idx] @ grid.powers, scale)  # (evaluated, S) [LSB]
    words_e = np.rint(values)
    err_e = values - words_e
    err = float(np.max(np.abs(err_e)))
    if err >= 0.5 - slack:  # a word in doubt
        return None
    keep = ~flag
    qmin = min(float(np.min(q, where=keep, initial=np.inf)), float(words_e.min()))
    qmax = max(float(np.max(q, where=keep, initial=-np.inf)), float(words_e.max()))
    lo, hi = spec.word_range
    if qmin < lo or qmax > hi:  # the exact evaluation names the range
        return None
    sums = _sums(a, q, keep, grid.powers)
    part = (qmin, qmax, err, sums[0] + float(np.vdot(values, values)),
            sums[1] + float(np.vdot(err_e, err_e)), float(np.max(np.abs(values))), slack)
    words = np.repeat(np.clip(q, lo, hi).astype(dtype), size)
    words.reshape(-1, size)[idx] = words_e
    return part, words


def _evaluated(a: np.ndarray, q: np.ndarray, off: np.ndarray, reach: np.ndarray, h: float,
               margin: float) -> np.ndarray:
    """Which segments (``a``: their cubics' terms by degree) are evaluated point by point:
    those within ``margin`` of a half LSB, and those whose bound of |error| or |correction|
    comes within twice ``margin`` of the largest value at an end of a segment of one word
    (or, for |correction|, of any)."""
    even = a[0] + a[2] * (h * h)
    odd = a[1] * h + a[3] * (h * h * h)
    flag = off + reach + margin >= 0.5
    ends_c = np.maximum(np.abs(even + odd), np.abs(even - odd))
    ends_e = np.maximum(np.abs(even + odd - q), np.abs(even - odd - q))
    one = ~flag
    if one.any():
        flag |= off + reach + 2.0 * margin >= float(ends_e[one].max())
    flag |= np.abs(a[0]) + reach + 2.0 * margin >= float(ends_c.max())
    return flag


def _sums(a: np.ndarray, q: np.ndarray, keep: np.ndarray, powers: np.ndarray
          ) -> tuple[float, float]:
    """The sums of squared corrections and of squared quantisation errors [LSB^2] over the
    segments ``keep`` (``a``: the cubics' terms by degree, ``q``: the segments' words,
    ``powers``: 1, t, t^2, t^3 at a segment's points): a cubic's squares summed over its
    points are a^T G a, G = powers powers^T, so the sum over segments is that of G times
    the (4 x 4) sum of each segment's a a^T, one product."""
    gram = powers @ powers.T
    corr = float(np.sum(gram * ((a * keep) @ a.T)))
    b = a.copy()
    b[0] -= q
    return corr, float(np.sum(gram * ((b * keep) @ b.T)))
