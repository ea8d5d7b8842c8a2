"""A head's batch summed into its fit in one pass by the compiled kernel (:mod:`enctools.kernel`).

The numpy passes of a batch (the head's angle and step from its counts, the deviation
zeta, the looked-up harmonic columns, the quarter of the period, the trend moments per
window, X^T y and, with the reference's harmonics, X^T X) are one loop over the samples
in C when the kernel is installed: the same sums, to rounding (the order of the
additions differs). Used for heads read from integer counts, groups met in order (a
continuous run's windows, a sweep's runs one after another), no positions; anything else
takes the numpy passes (:meth:`~.fit.InterpolationFit.rows`).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import numpy as np

from enctools import kernel
from enctools.data.readings import HeadInfo
from enctools.methods.interp.coverage import _sector_bits_table
from enctools.methods.interp.fit import InterpolationFit
from enctools.methods.interp.model import phase_table
from enctools.methods.trend_lsq import FusedRows, Grouping, TrendProjectedLSQ, add_cross
from enctools.units import ARCSEC, TWO_PI

#: the kernel's limits: columns + 1 and trend terms
MAX_P1, MAX_D1 = 64, 8


@functools.lru_cache(maxsize=8)
def _by_step(steps: int, orders: tuple[int, ...]) -> np.ndarray:
    """:func:`~.model.phase_table` as (steps, columns), each step's columns together."""
    return np.ascontiguousarray(phase_table(steps, orders).T)


def _ptr(a: np.ndarray | None) -> int | None:
    return None if a is None else int(a.ctypes.data)


class CountsRows(FusedRows):
    """One head's batch for its fit: its ``counts`` [count], the reference angle
    ``reference_rad`` [rad] and, when the fit takes the reference's harmonics, its step
    ``reference_step`` [count] of ``reference_steps`` per period; ``first_y``: zeta
    [arcsec] at the first sample of each group of the grouping it is summed with, when
    made ahead (:mod:`.batches`)."""

    def __init__(self, fit: InterpolationFit, counts: np.ndarray, info: HeadInfo,
                 reference_rad: np.ndarray, reference_step: np.ndarray | None,
                 reference_steps: int, first_y: np.ndarray | None = None) -> None:
        self.fit = fit
        self.counts = np.ascontiguousarray(counts, dtype=np.int64)
        self.scale = TWO_PI / info.counts_per_rev      # as head_angle
        self.steps = info.interpolation
        self.shift = info.zero_count % self.steps      # as signal_step
        self.ref = np.ascontiguousarray(reference_rad, dtype=np.float64)
        fits_ref = fit.ref_orders.size > 0
        self.ref_step = np.ascontiguousarray(reference_step, dtype=np.int64) \
            if fits_ref and reference_step is not None else None
        self.ref_steps = reference_steps
        self._first_y = first_y

    def first_y(self, first: np.ndarray) -> np.ndarray:
        """zeta [arcsec] at the samples ``first``, as :meth:`InterpolationFit.rows` makes it
        (made ahead, at the first samples of the grouping given, when given)."""
        if self._first_y is not None:
            return self._first_y
        zeta = np.subtract(np.multiply(self.counts[first], self.scale, dtype=np.float64),
                           self.ref[first])
        zeta /= ARCSEC
        return zeta

    def sums(self, g: Grouping, tz: list[np.ndarray], y0: np.ndarray, txy: np.ndarray,
             seen: np.ndarray, member: TrendProjectedLSQ) -> None:
        lib = kernel.library()
        assert lib is not None, "the compiled kernel"
        fit, m, k = self.fit, self.counts.size, g.keys.size
        n_dev, n_ref = 2 * fit.orders.size, 2 * fit.ref_orders.size
        p1, d1 = member.p + 1, len(tz) + 1
        dev_table = _by_step(self.steps, tuple(fit.orders.tolist()))
        ref_table = _by_step(self.ref_steps, tuple(fit.ref_orders.tolist())) if n_ref else None
        full = n_dev != member.p                       # X^T X not from the steps alone
        # written in place when the buffers are the kernel's layout (trend_lsq.add_batch's)
        out = txy if txy.flags.c_contiguous else np.empty((d1, p1, k))
        bits = seen if seen.flags.c_contiguous else np.empty(k, np.uint8)
        cross = np.zeros((p1, p1) if full else p1)
        per_step = np.zeros(self.steps, np.int64)
        z = np.ascontiguousarray(np.array(tz, dtype=np.float64)) if len(tz) > 1 \
            else (np.ascontiguousarray(tz[0], dtype=np.float64) if tz else None)
        starts = np.ascontiguousarray(g.starts, dtype=np.int64)
        y0c = np.ascontiguousarray(y0, dtype=np.float64)
        rc = lib.enc_interp_member(
            m, _ptr(self.counts), self.scale, self.shift, self.steps, _ptr(self.ref), ARCSEC,
            _ptr(dev_table), n_dev, _ptr(self.ref_step), _ptr(ref_table), n_ref, self.ref_steps,
            k, _ptr(starts), _ptr(y0c), _ptr(z), d1 - 1,
            _ptr(_sector_bits_table(self.steps)), _ptr(out), _ptr(bits), _ptr(cross),
            int(full), _ptr(per_step))
        if rc != 0:    # usable() keeps the sizes within its limits: not met
            msg = f"the compiled kernel refused a batch ({rc}): run with ENCTOOLS_KERNEL=numpy"
            raise RuntimeError(msg)
        if out is not txy:
            txy[...] = out
        if bits is not seen:
            seen[...] = bits
        p = member.p
        if full:
            add_cross(member, cross[:p, :p], cross[:p, p], float(cross[p, p]), m)
        else:
            add_cross(member, np.zeros((p, p)), cross[:p], float(cross[p]), m)
        fit.add_steps(per_step, gram=not full)


def usable(fits: Sequence[InterpolationFit], counts: Sequence[np.ndarray],
           infos: Sequence[HeadInfo], reference_rad: np.ndarray,
           reference_step: np.ndarray | None, reference_steps: int,
           finite: bool | None = None) -> bool:
    """Whether the kernel can take this batch of these fits: installed, integer counts of
    heads with steps per period, a finite reference (its step when its harmonics are
    fitted), sizes within its limits. ``finite``: whether the reference is, when known."""
    if kernel.library() is None or any(i.interpolation <= 0 for i in infos):
        return False
    if any(c.dtype.kind not in "iu" or c.dtype.itemsize > 8 or c.dtype == np.uint64
           for c in counts):
        return False
    for f in fits:
        if f.lsq.p + 1 > MAX_P1 or f.lsq.d1 > MAX_D1:
            return False
        if f.ref_orders.size and (reference_step is None or reference_steps <= 0):
            return False
    return finite if finite is not None else bool(np.isfinite(np.sum(reference_rad)))
