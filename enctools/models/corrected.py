"""A correction table applied to points or readings: the residual error before and after.

This is the after-compensation check of seed 001 (its tables 2 and 3 were measured
with the ROM loaded): the table is applied to what the encoder indicates, exactly as
the hardware holding it would (:mod:`enctools.models.correction`), and the error left
is compared with the error before.

- points (position = indicated angle [deg], deviation = indicated - true [arcsec]): the
  correction c at the position is added to both, ``deviation + c`` and ``position + c``;
  a memory table is looked up at the position's nearest code.
- readings with a reference angle (the simulator's truth or a reference encoder): the
  encoder's code is the mean of its measuring heads' counts rounded down (a sum and a
  division, as an FPGA forms it; each head's count taken within half a turn of the
  first's), mod the counts per turn; the deviation is the code's angle minus the
  reference, wrapped to +-180 deg, less its circular mean (the zero offset, reported).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from enctools.data.statistics import Figures, curve_figures
from enctools.errors import DataError
from enctools.methods.points import Points, distinct
from enctools.models.correction import Correction, MemoryTable
from enctools.units import ARCSEC, DEG, TWO_PI


@dataclass(frozen=True)
class Residuals:
    """The error [arcsec] before and after the correction, and their figures.

    before, after : one value per point or reading [arcsec], as they stand.
    figures_before : the figures of ``before`` (points: of the distinct positions, as
        enc points gives them; readings: of every reading).
    figures_after : the figures of ``after`` (the same values) about their mean: mean
        0, every other figure (min, max, rms, max |e|) of ``after`` less its mean; s and
        p-p are the same either way.
    constant : the constant the correction adds [arcsec]: the mean of ``after`` less
        the mean of ``before`` (a table's mean is a shift of the zero, not an error).
    rms_with_constant : the rms of ``after`` as it stands [arcsec], the constant in it.
    zero_offset : readings: the circular mean of code minus reference [arcsec] removed
        from both (0 for points).
    """

    before: np.ndarray
    after: np.ndarray
    figures_before: Figures
    figures_after: Figures
    zero_offset: float = 0.0
    constant: float = 0.0
    rms_with_constant: float = 0.0


def residuals(before: np.ndarray, after: np.ndarray, figures_of_before: np.ndarray,
              figures_of_after: np.ndarray, zero_offset: float = 0.0) -> Residuals:
    """The residuals, the after figures about their mean (:class:`Residuals`).

    figures_of_before, figures_of_after : the values the figures are of [arcsec] (the
        distinct positions of points, every reading).
    """
    fb, raw = curve_figures(figures_of_before), curve_figures(figures_of_after)
    fa = replace(curve_figures(figures_of_after - raw.mean), mean=0.0)
    return Residuals(before, after, fb, fa, zero_offset, raw.mean - fb.mean, raw.rms)


def correct_points(points: Points, correction: Correction, source: str = "input"
                   ) -> tuple[Points, Residuals]:
    """The points as they read with the table loaded, and the residuals [arcsec].

    Parameters
    ----------
    points : positions = indicated angles [deg], deviations [arcsec].
    correction : the table, applied at each position in its direction.
    """
    c = correction.correction_rad(points.position_deg * DEG, points.direction)
    after = points.deviation + c / ARCSEC
    corrected = Points(points.position_deg + c / DEG, after, points.direction, points.run)
    fb = distinct(points, source=source)[1]
    fa = distinct(Points(points.position_deg, after, points.direction, points.run),
                  source=source)[1]
    return corrected, residuals(points.deviation, after, fb, fa)


def encoder_code(counts: Sequence[np.ndarray], counts_per_rev: int) -> np.ndarray:
    """The encoder's code [count] from its heads' zero-based counts: their mean rounded
    down, mod ``counts_per_rev`` (each head within half a turn of the first head)."""
    first = np.asarray(counts[0], dtype=np.int64)
    total = first * len(counts)
    half = counts_per_rev // 2
    for c in counts[1:]:
        total += np.mod(np.asarray(c, dtype=np.int64) - first + half, counts_per_rev) - half
    return np.mod(np.floor_divide(total, len(counts)), counts_per_rev)


def directions(code: np.ndarray, counts_per_rev: int) -> np.ndarray:
    """+1 where the code rises (across the wrap too), -1 where it falls [per reading]."""
    if code.size < 2:
        return np.ones(code.size, dtype=np.int8)
    half = counts_per_rev // 2
    step = np.mod(np.diff(code) + half, counts_per_rev) - half
    d = np.where(step < 0, -1, 1).astype(np.int8)
    return np.r_[d[:1], d]


def code_correction(correction: Correction, code: np.ndarray, counts_per_rev: int,
                    direction: np.ndarray, source: str = "input") -> np.ndarray:
    """The correction [count] the table adds to each code: a memory table by its address
    (its code must have counts_per_rev = 2**n), any other at the code's angle."""
    if isinstance(correction, MemoryTable):
        if counts_per_rev != 1 << correction.code_bits:
            msg = (f"{source}: the encoder has {counts_per_rev} counts per turn; the table is "
                   f"for a {correction.code_bits}-bit code ({1 << correction.code_bits} counts)")
            raise DataError(msg)
        return correction.correction_counts(code)
    rad = correction.correction_rad(code * (TWO_PI / counts_per_rev), direction)
    return rad * (counts_per_rev / TWO_PI)


def correct_readings(code: np.ndarray, counts_per_rev: int, reference_rad: np.ndarray,
                     correction: Correction, source: str = "input"
                     ) -> tuple[np.ndarray, Residuals]:
    """The residuals of readings against a reference, before and after the table.

    Parameters
    ----------
    code : the encoder's code of each reading [count] (:func:`encoder_code`).
    counts_per_rev : counts per turn of the code.
    reference_rad : the reference angle of each reading [rad].

    Returns
    -------
    The indicated angle of each reading before correction [rad, 0..2 pi) and the
    residuals [arcsec], the zero offset removed from both.
    """
    if code.size == 0:
        msg = f"{source}: the readings stream has no rows"
        raise DataError(msg)
    if not np.all(np.isfinite(reference_rad)):
        msg = f"{source}: the reference angle is NaN or infinite in some readings"
        raise DataError(msg)
    indicated = code * (TWO_PI / counts_per_rev)
    diff = np.angle(np.exp(1j * (indicated - reference_rad)))
    offset = float(np.angle(np.mean(np.exp(1j * diff))))
    before = np.angle(np.exp(1j * (diff - offset))) / ARCSEC
    added = code_correction(correction, code, counts_per_rev, directions(code, counts_per_rev),
                            source)
    after = before + added * (TWO_PI / counts_per_rev) / ARCSEC
    return indicated, residuals(before, after, before, after, offset / ARCSEC)
