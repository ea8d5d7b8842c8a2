"""Several devices' fits against one reference, fed as one (seed 000 eqs. (19), (20)).

The heads of a run are each fitted against the same reference over the same samples:
their trend windows are the reference's, and so is every window's trend basis. A
:class:`FitBank` holds the fits of devices alike (the same harmonics, trend and
windows) and feeds each batch of all of them at once: one array of their columns, one
pass of the group sums over it, one trend basis per window
(:class:`~enctools.methods.trend_lsq.StackedTrendLSQ`). Each fit keeps its own sums
and gives the result it gets alone, to rounding. A batch in which a device has a
reading that is not finite (its samples then differ from the others') ends the
stacking: from it on, each fit is fed alone.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np

from enctools.data.readings import HeadInfo
from enctools.methods.interp import fused
from enctools.methods.interp.fit import InterpolationFit, Samples, Steps, reference_sum
from enctools.methods.trend_lsq import Grouping, MemberRows, StackedTrendLSQ, group_batch

#: a batch's trend windows made ahead: their grouping, their origin [rad] and per fit zeta
#: [arcsec] at each window's first sample (None: made here)
MadeAhead = tuple[Grouping, float, Sequence[np.ndarray | None]]


class FitBank:
    """The fits ``fits`` (alike: see :meth:`of`) fed batch by batch as one."""

    def __init__(self, fits: Sequence[InterpolationFit]) -> None:
        self.fits = list(fits)
        self.stack = StackedTrendLSQ([f.lsq for f in fits]) if len(fits) > 1 else None

    @staticmethod
    def of(fits: Sequence[InterpolationFit]) -> list[FitBank]:
        """The fits in banks of those alike, in the order of their first member."""
        banks: dict[tuple[object, ...], list[InterpolationFit]] = {}
        for f in fits:
            banks.setdefault(f.model_key(), []).append(f)
        return [FitBank(b) for b in banks.values()]

    def add(self, device_rad: Sequence[np.ndarray], reference_rad: np.ndarray,
            steps: Sequence[Steps], groups: np.ndarray | None = None,
            reference_phase: np.ndarray | None = None,
            positions: np.ndarray | None = None,
            device_finite: Sequence[bool] | None = None) -> None:
        """One batch of every fit: ``device_rad`` [rad] and ``steps`` per fit (in order),
        the rest shared (as :meth:`InterpolationFit.add`; the phases from the steps).
        ``device_finite``: per fit, its angles are known finite (from integer counts)."""
        known = device_finite if device_finite is not None else [False] * len(self.fits)
        if self.stack is not None:
            total = reference_sum(reference_rad, reference_phase)   # summed once for all
            samples = [f.samples(d, None, reference_rad, groups, reference_phase, positions, st,
                                 total, ok)
                       for f, d, st, ok in zip(self.fits, device_rad, steps, known, strict=True)]
            if all(s.device_rad.size == reference_rad.size for s in samples):
                self._add_stacked(samples)
                return
            self.stack.release()          # samples differ from here on: each fit alone
            self.stack = None
            for f, s in zip(self.fits, samples, strict=True):
                f.add(s.device_rad, s.device_phase, s.reference_rad, s.groups,
                      s.reference_phase, s.positions, s.steps)
            return
        for f, d, st in zip(self.fits, device_rad, steps, strict=True):
            f.add(d, None, reference_rad, groups, reference_phase, positions, st)

    def _add_stacked(self, samples: list[Samples]) -> None:
        """Every fit's samples (all finite, the same rows) into the stack."""
        assert self.stack is not None
        first, ref = self.fits[0], samples[0].reference_rad
        m = ref.size
        if m == 0:
            return
        grouping, scale = self._grouping(ref, samples[0].groups)
        xy = np.empty((first.lsq.p + 1, m))   # one buffer: each fit's rows summed in turn
        bits = np.empty(m, np.uint8)

        def rows() -> Iterator[MemberRows]:
            for f, s in zip(self.fits, samples, strict=True):
                xtx = f.rows(s, xy, bits)
                yield xy, bits, xtx

        self.stack.add(ref, scale, grouping, rows())

    def _grouping(self, ref: np.ndarray, groups: np.ndarray | None,
                  windows: MadeAhead | None = None) -> tuple[Grouping, float]:
        """The batch's groups (the runs, or the windows of the reference angle ``ref``
        [rad]) and the trend's scale [rad], shared by every fit of the bank. ``windows``:
        the windows made ahead (grouping, origin [rad]), taken when the fits count theirs
        from that origin (or from none yet)."""
        first = self.fits[0]
        if first.window is None:
            keys = np.zeros(ref.size, np.int64) if groups is None \
                else np.asarray(groups).astype(np.int64)
            return group_batch(keys, ref, first.lsq.d1 - 1, first.period), first.period
        if windows is not None and first.origin in (None, windows[1]):
            first.origin = windows[1]
            grouping = windows[0]
        else:
            grouping = first.grouping(ref, groups)
        for f in self.fits[1:]:
            f.origin = first.origin       # the same windows if the bank parts later
        return grouping, first.window / 2

    def add_counts(self, counts: Sequence[np.ndarray], infos: Sequence[HeadInfo],
                   reference_rad: np.ndarray, reference_step: np.ndarray | None,
                   reference_steps: int, groups: np.ndarray | None = None,
                   finite: bool | None = None, windows: MadeAhead | None = None) -> bool:
        """One batch of every fit from its head's ``counts`` [count] (``infos``, in order),
        summed by the compiled kernel (:mod:`.fused`); the reference's angle [rad] and,
        for the fits that take its harmonics, its step [count] of ``reference_steps``.
        False, and nothing added, when the kernel cannot take it (absent, counts not
        integer, a reference not finite, groups not in order): then :meth:`add`.
        Made ahead (:mod:`.batches`): ``finite``, whether every reference angle is;
        ``windows``, the trend windows (grouping, origin [rad]) and each fit's zeta
        [arcsec] at their first samples (or None)."""
        if reference_rad.size == 0:
            return True
        if not fused.usable(self.fits, counts, infos, reference_rad, reference_step,
                            reference_steps, finite):
            return False
        grouping, scale = self._grouping(reference_rad, groups, windows)
        if grouping.order is not None:
            return False
        first_y = windows[2] if windows is not None and grouping is windows[0] \
            else [None] * len(self.fits)
        rows = [fused.CountsRows(f, c, i, reference_rad, reference_step, reference_steps, y)
                for f, c, i, y in zip(self.fits, counts, infos, first_y, strict=True)]
        if self.stack is not None:
            self.stack.add(reference_rad, scale, grouping, rows)
        else:
            for f, r in zip(self.fits, rows, strict=True):
                f.lsq.add_fused(reference_rad, scale, grouping, r)
        return True

    def close(self) -> None:
        """Close the groups still open (at the end of the input), before the results."""
        if self.stack is not None:
            self.stack.close_all()
