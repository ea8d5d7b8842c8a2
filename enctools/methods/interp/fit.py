"""The interpolation-error fit of a device against a reference, fed batch by batch.

The deviation ``zeta = psi_E - psi_R`` (seed 000 eq. (19)) is modelled as

    zeta(x) = trend(x) + sum_n [a_n cos(n phi) + b_n sin(n phi)]            (device)
                       - sum_j [c_j cos(j phi_R) + d_j sin(j phi_R)]        (reference)

with phi the device's signal phase (from its counts), x the swept angle, a
polynomial ``trend`` per run (the graduation error and a probe arm-length error are
close to linear over a few arcseconds) or per window of a continuous run, and
optionally the reference's own interpolation error at the reference's signal
phase phi_R. The harmonics n are in units of the device's signal period. A
least-squares fit gives them with standard uncertainties; the interpolation error
is the device part as a function of phase (:mod:`enctools.methods.interp.model`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from enctools.errors import DataError
from enctools.methods.interp.coverage import (
    PhaseCoverage,
    RunCoverage,
    WindowCoverage,
    sector_bits,
)
from enctools.methods.interp.curve import error_figures
from enctools.methods.interp.model import (
    PeriodHarmonics,
    condition_number,
    harmonic_rows,
    landing_harmonics,
    lookup_gram,
    period_ratio,
    scaled_normal_matrix,
    solve_scaled,
)
from enctools.methods.trend_lsq import Grouping, TrendProjectedLSQ, group_batch
from enctools.units import ARCSEC, TWO_PI

#: (device step [count], its steps per period, reference step [count] or None, its steps)
Steps = tuple[np.ndarray, int, np.ndarray | None, int]


@dataclass
class InterpResult:
    """The interpolation error of one device against one reference.

    ``error``: the device's interpolation error as harmonics of its signal period
    (only the kept orders when a reference encoder's period differs); ``fitted``:
    every device harmonic fitted; ``reference``: the reference's own harmonics (in
    its period) when they were fitted; ``period`` [rad] the device's signal period;
    ``ratio`` device period / reference period (None for probes); ``residual_rms``
    [arcsec]; ``periods`` swept (the shortest run, or the whole continuous run);
    ``landing`` (j, j * ratio, kept order) triples; ``windows`` the number of trend
    windows of a continuous run (None: one trend per run).
    """

    error: PeriodHarmonics
    fitted: PeriodHarmonics
    period: float
    samples: int
    periods: float
    residual_rms: float
    reference: PeriodHarmonics | None = None
    ratio: float | None = None
    landing: list[tuple[int, float, int]] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    windows: int | None = None

    def figures(self, points: int = 3600) -> dict[str, float]:
        """Figures of the error curve [arcsec] (:func:`~.curve.error_figures`)."""
        return error_figures(self.error(np.linspace(0.0, TWO_PI, points, endpoint=False)))


@dataclass
class Samples:
    """One batch of samples for :meth:`InterpolationFit.add` (angles and phases in rad;
    ``device_phase`` None when ``steps`` give it)."""

    device_rad: np.ndarray
    device_phase: np.ndarray | None
    reference_rad: np.ndarray
    groups: np.ndarray | None
    reference_phase: np.ndarray | None
    positions: np.ndarray | None
    steps: Steps | None

    def finite(self, reference_total: float | None = None,
               device_finite: bool = False) -> tuple[Samples, int]:
        """The samples whose readings and phases are all finite, and how many were not.

        ``reference_total``: the sum of the reference's angles and phase when already
        taken (one reference for several devices); ``device_finite``: the device's
        angles are known finite (made from integer counts).
        """
        # first without a temporary: a sum is finite only when all its terms are (one
        # that overflows falls through to the test of each sample); a phase from counts
        # is finite (None here: not summed)
        if reference_total is None:
            reference_total = reference_sum(self.reference_rad, self.reference_phase)
        total = reference_total if device_finite \
            else float(np.sum(self.device_rad)) + reference_total
        if self.device_phase is not None:
            total += float(np.sum(self.device_phase))
        if math.isfinite(total):
            return self, 0
        good = np.isfinite(self.device_rad) & np.isfinite(self.reference_rad)
        for a in (self.device_phase, self.reference_phase):
            if a is not None:
                good &= np.isfinite(a)
        if good.all():
            return self, 0
        st = self.steps
        steps = None if st is None else (
            st[0][good], st[1], None if st[2] is None else st[2][good], st[3])
        return Samples(
            self.device_rad[good],
            None if self.device_phase is None else self.device_phase[good],
            self.reference_rad[good],
            None if self.groups is None else np.asarray(self.groups)[good],
            None if self.reference_phase is None else self.reference_phase[good],
            None if self.positions is None else np.asarray(self.positions)[good],
            steps), int(good.size - np.count_nonzero(good))


def reference_sum(reference_rad: np.ndarray, reference_phase: np.ndarray | None) -> float:
    """The sum of a reference's angles [rad] and phases [rad]: finite when all are
    (:meth:`Samples.finite`)."""
    total = float(np.sum(reference_rad))
    return total if reference_phase is None else total + float(np.sum(reference_phase))


class SharedGrouping:
    """The trend windows of the last batch, made by the first of several fits against
    one reference (the devices of a run) and used by the others: the same reference
    array and groups, the same origin, window and trend degree."""

    def __init__(self) -> None:
        self._of: tuple[object, object, tuple[float, float, int]] | None = None
        self._grouping: Grouping | None = None

    def get(self, arrays: tuple[np.ndarray, np.ndarray | None], how: tuple[float, float, int],
            make: Callable[[], Grouping]) -> Grouping:
        """The grouping of ``arrays`` (reference, groups) made ``how``; ``make()`` when new."""
        of = self._of
        if of is None or of[0] is not arrays[0] or of[1] is not arrays[1] or of[2] != how \
                or self._grouping is None:
            self._grouping = make()
            self._of = (arrays[0], arrays[1], how)  # held: their ids stay theirs
        return self._grouping


class InterpolationFit:
    """The fit of :func:`fit_interpolation_error`, fed batch by batch (seed 000 eqs. (19), (20)).

    zeta = (device - reference) [arcsec] is modelled as a trend per group (a run of
    a sweep, or with ``window`` [rad] a window of that span of the reference angle)
    plus the device harmonics of its signal phase and optionally the reference's
    own. Memory does not grow with the number of samples: the trends are projected
    out per group (:class:`TrendProjectedLSQ`), the phase coverage is a bitmap
    (:class:`~.coverage.PhaseCoverage`). See :func:`fit_interpolation_error` for the
    parameters; :meth:`add` takes the same arrays by batch, :meth:`result` fits.
    """

    def __init__(self, periods_per_rev: int, harmonics: int = 4,
                 keep: Sequence[int] | None = None, trend_degree: int = 1,
                 reference_orders: Sequence[int] = (),
                 reference_periods_per_rev: int | None = None,
                 window: float | None = None, shared: SharedGrouping | None = None) -> None:
        if harmonics < 1:
            msg = f"harmonics must be >= 1, not {harmonics}"
            raise DataError(msg)
        self.period = TWO_PI / periods_per_rev
        self.periods_per_rev = periods_per_rev
        self.orders = np.arange(1, harmonics + 1)
        self.keep = [int(n) for n in (self.orders if keep is None else keep)]
        bad = [k for k in self.keep if k not in set(self.orders.tolist())]
        if bad:
            msg = f"kept harmonic {bad[0]} is not fitted (harmonics 1..{harmonics})"
            raise DataError(msg)
        if window is not None and not window >= self.period:
            msg = (f"`window_arcsec` {window / ARCSEC:.4g}\" is shorter than the signal period "
                   f"{self.period / ARCSEC:.4g}\": a window must span at least one period")
            raise DataError(msg)
        self.ref_orders = np.asarray(list(reference_orders), dtype=int)
        self.reference_periods_per_rev = reference_periods_per_rev
        self.window = window
        self.cover = PhaseCoverage()
        self.runs: RunCoverage | WindowCoverage = \
            RunCoverage() if window is None else WindowCoverage(window)
        n_cols = 2 * self.orders.size + 2 * self.ref_orders.size
        self.lsq = TrendProjectedLSQ(n_cols, trend_degree, consecutive=window is not None,
                                     on_close=self.runs.closed)
        self.origin: float | None = None   # the reference angle [rad] windows count from
        self.shared = shared if shared is not None else SharedGrouping()
        self.skipped = 0  # samples with a NaN or infinite reading, probe or phase
        self._per_step: np.ndarray | None = None  # samples per step of the period, not yet summed
        self._gram_steps = False                   # ... and X^T X to be made of them

    def add(self, device_rad: np.ndarray, device_phase: np.ndarray | None,
            reference_rad: np.ndarray, groups: np.ndarray | None = None,
            reference_phase: np.ndarray | None = None, positions: np.ndarray | None = None,
            steps: Steps | None = None) -> None:
        """Add samples (arrays as in :func:`fit_interpolation_error`); non-finite rows are skipped.

        ``steps``: (device step, its steps per period, reference step or None, its steps)
        [count] when the phases come from counts (:func:`enctools.data.readings.signal_step`):
        the harmonic columns are then looked up rather than computed, and
        ``device_phase`` may be None (it is 2 pi step / steps).
        """
        s = self.samples(device_rad, device_phase, reference_rad, groups, reference_phase,
                         positions, steps)
        if s.device_rad.size == 0:
            return
        xy = np.empty((self.lsq.p + 1, s.device_rad.size))  # the last row: for zeta
        bits = np.empty(s.device_rad.size, np.uint8)
        xtx = self.rows(s, xy, bits)
        ref = s.reference_rad
        if self.window is None:
            keys = np.zeros(ref.size, np.int64) if s.groups is None \
                else np.asarray(s.groups).astype(np.int64)
            self.lsq.add(xy, xy[-1], ref, keys, self.period, labels=bits, xtx=xtx)
            return
        self.lsq.add(xy, xy[-1], ref, None, self.window / 2, labels=bits,
                     grouping=self.grouping(ref, s.groups), xtx=xtx)

    def model_key(self) -> tuple[object, ...]:
        """What fits fed as one (:class:`~.bank.FitBank`) share: the period, the harmonics
        fitted (the device's and the reference's), the trend and the window."""
        return (self.periods_per_rev, tuple(self.orders.tolist()),
                tuple(self.ref_orders.tolist()), self.lsq.d1, self.window)

    def samples(self, device_rad: np.ndarray, device_phase: np.ndarray | None,
                reference_rad: np.ndarray, groups: np.ndarray | None = None,
                reference_phase: np.ndarray | None = None, positions: np.ndarray | None = None,
                steps: Steps | None = None, reference_total: float | None = None,
                device_finite: bool = False) -> Samples:
        """The arrays of :meth:`add` checked, without the samples that are not finite
        (counted in ``skipped``; ``reference_total``, ``device_finite`` as
        :meth:`Samples.finite`)."""
        s, skipped = self._checked(device_rad, device_phase, reference_rad, groups,
                                   reference_phase, positions, steps
                                   ).finite(reference_total, device_finite)
        self.skipped += skipped
        return s

    def rows(self, s: Samples, xy: np.ndarray, bits: np.ndarray) -> np.ndarray | None:
        """Fill ``xy`` (p + 1, m) with the columns X of ``s`` and its zeta [arcsec] as the
        last row, ``bits`` (m) with the quarter of the period of each sample's phase
        (1 << quarter); add the phases to the coverage. Returns None, or zeros when the
        columns are all looked up by the device's step: X^T X and the coverage then come
        from the samples counted per step, summed over the batches when the fit is solved.
        """
        dev_step, dev_steps, ref_step, ref_steps = s.steps if s.steps is not None \
            else (None, 0, None, 0)
        n_dev = 2 * self.orders.size
        harmonic_rows(s.device_phase, self.orders, xy[:n_dev], dev_step, dev_steps)
        if self.ref_orders.size and s.reference_phase is not None:
            harmonic_rows(s.reference_phase, self.ref_orders, xy[n_dev:-1], ref_step, ref_steps)
        zeta = np.subtract(s.device_rad, s.reference_rad, out=xy[-1])
        zeta /= ARCSEC
        sector_bits(s.device_phase, dev_step, dev_steps, out=bits)
        if dev_step is not None and s.positions is None and n_dev == self.lsq.p:
            # every column looked up by the step: X^T X and the phases sampled come from
            # the count of samples at each step, summed over the batches (_flush_steps)
            self.add_steps(np.bincount(dev_step, minlength=dev_steps), gram=True)
            return np.zeros((self.lsq.p, self.lsq.p))
        self.cover.add(s.device_phase, s.positions, dev_step, dev_steps)
        return None

    def add_steps(self, per_step: np.ndarray, gram: bool) -> None:
        """Samples counted at each step of the period (``per_step`` [1]), kept (summed over
        the batches) to add to the coverage and, with ``gram`` (every column looked up by
        the step), to make X^T X of when the fit is solved (:meth:`_flush_steps`)."""
        if self._per_step is not None and (self._per_step.size != per_step.size
                                           or self._gram_steps != gram):
            self._flush_steps()
        if self._per_step is None:
            self._per_step, self._gram_steps = per_step, gram
        else:
            self._per_step += per_step

    def _flush_steps(self) -> None:
        """The samples counted per step so far into the coverage and X^T X."""
        if self._per_step is not None:
            self.cover.add_steps(self._per_step)
            if self._gram_steps:
                self.lsq.add_gram(lookup_gram(self._per_step.size, self.orders, self._per_step))
            self._per_step = None

    def grouping(self, ref: np.ndarray, groups: np.ndarray | None) -> Grouping:
        """The trend windows of a batch (reference angles ``ref`` [rad], ``groups``), shared."""
        assert self.window is not None, "windows of a continuous run"
        if self.origin is None:
            self.origin = float(ref[0])
        return self.shared.get((ref, groups), (self.origin, self.window, self.lsq.d1),
                               lambda: self._windows(ref, groups))

    def _windows(self, ref: np.ndarray, groups: np.ndarray | None) -> Grouping:
        """The batch's trend windows (:func:`window_grouping`)."""
        assert self.window is not None and self.origin is not None
        return window_grouping(ref, groups, self.origin, self.window, self.lsq.d1 - 1)

    def _checked(self, device_rad: np.ndarray, device_phase: np.ndarray | None,
                 reference_rad: np.ndarray, groups: np.ndarray | None,
                 reference_phase: np.ndarray | None, positions: np.ndarray | None,
                 steps: Steps | None) -> Samples:
        """The arrays as float64, DataError when they differ in length or a phase is missing.

        The reference's phase is kept only when its harmonics are fitted.
        """
        dev = np.asarray(device_rad, dtype=np.float64)
        ref = np.asarray(reference_rad, dtype=np.float64)
        phase = None if device_phase is None else np.asarray(device_phase, dtype=np.float64)
        if phase is None and steps is None:
            msg = "the device's phase: give it or its steps"
            raise DataError(msg)
        n_phase = phase.size if phase is not None else np.asarray(steps[0]).size  # type: ignore[index]
        if not (ref.size == dev.size and n_phase == dev.size):
            msg = "device, phase and reference differ in length"
            raise DataError(msg)
        if self.ref_orders.size:
            if reference_phase is None:
                msg = "the reference's harmonics are fitted: give its signal phase"
                raise DataError(msg)
            reference_phase = np.asarray(reference_phase, dtype=np.float64)
        else:
            reference_phase = None
        return Samples(dev, phase, ref, groups, reference_phase, positions, steps)

    def result(self) -> InterpResult:
        """The fit of every sample added. DataError as :func:`fit_interpolation_error` says."""
        lsq = self.lsq
        lsq.close_all()
        self._flush_steps()
        if lsq.n == 0:
            msg = "no sample with finite device and reference readings"
            raise DataError(msg)
        periods = self.runs.periods_swept(self.period)
        self._check_determined()
        n_par = lsq.n_trend + lsq.p
        a, norms = scaled_normal_matrix(lsq.xtx, lsq.raw_ss)
        cond = condition_number(a)
        if cond > 1e6:
            what = ("the reference's harmonics cannot be told from the device's over this sweep"
                    if self.ref_orders.size else "the sweep does not determine every harmonic")
            msg = f"{what} (condition number {cond:.3g}); sweep longer or fit fewer harmonics"
            raise DataError(msg)
        coef, cov, s2 = solve_scaled(a, norms, lsq.xty, lsq.yty, lsq.n - n_par)
        n_dev = 2 * self.orders.size
        fitted = PeriodHarmonics.from_pairs(self.orders, coef[:n_dev], cov[:n_dev, :n_dev])
        gain = fitted.amplitude_u / max(np.sqrt(s2), 1e-300)
        if np.any(gain > 1.0):
            n_bad = int(self.orders[np.argmax(gain)])
            msg = (f"harmonic {n_bad} is undetermined by this sweep (its uncertainty exceeds "
                   f"the scatter of one reading): fit fewer harmonics or sweep longer")
            raise DataError(msg)
        reference = None
        if self.ref_orders.size:
            cd = coef[n_dev:]
            # zeta holds minus the reference's error
            reference = PeriodHarmonics(self.ref_orders, -(cd[0::2] - 1j * cd[1::2]),
                                        cov[n_dev:, n_dev:])
        result = InterpResult(error=fitted.select(self.keep), fitted=fitted, period=self.period,
                              samples=int(lsq.n), periods=float(periods),
                              residual_rms=float(np.sqrt(s2)), reference=reference)
        self._warn(result)
        return result

    def _check_determined(self) -> None:
        """DataError when the sampling or the sample count cannot carry the harmonics fitted."""
        # Nyquist within the period: harmonics must be finer than the largest phase gap
        k_max = self.cover.resolvable()
        harmonics = int(self.orders[-1])
        if harmonics > k_max:
            msg = (f"{harmonics} harmonics asked but the sweep samples the signal period "
                   f"only finely enough for {k_max}: fit fewer (`harmonics`) or step finer")
            raise DataError(msg)
        n_par = self.lsq.n_trend + self.lsq.p
        if self.lsq.n <= n_par:
            msg = (f"{self.lsq.n} samples for {n_par} parameters: record more points "
                   f"or fit fewer harmonics")
            raise DataError(msg)

    def _warn(self, result: InterpResult) -> None:
        """Fill the result's warnings, windows, period ratio and landing harmonics."""
        n = self.lsq.n
        if self.skipped:
            result.warnings.append(
                f"{self.skipped} of {self.skipped + n} samples skipped: a NaN or infinite "
                "reading, probe value or phase")
        if isinstance(self.runs, WindowCoverage):
            result.windows = self.lsq.groups
            partial = self.runs.partial_warning(n)
            if partial is not None:
                result.warnings.append(partial)
        ratio_of = self.reference_periods_per_rev
        if ratio_of is None:
            return
        result.ratio = period_ratio(self.periods_per_rev, ratio_of)
        if ratio_of == self.periods_per_rev:
            return
        if self.ref_orders.size:
            # fitted alongside: separable when they differ by a cycle over the sweep
            result.landing = landing_harmonics(result.ratio, self.keep, self.ref_orders.tolist(),
                                               tolerance=1.0 / result.periods)
        else:
            result.landing = landing_harmonics(result.ratio, self.keep)
        for j, at, k in result.landing:
            result.warnings.append(
                f"the reference's harmonic {j} lands at {at:.3g} harmonics of the device "
                f"period, on kept harmonic {k}: the filter cannot remove it "
                f"over {result.periods:.3g} periods swept")


def window_grouping(ref: np.ndarray, groups: np.ndarray | None, origin: float, window: float,
                    degree: int) -> Grouping:
    """The trend windows of a batch of reference angles ``ref`` [rad]: keys (group, window
    of ``window`` [rad] counted from ``origin`` [rad]) and the centre of each window, with
    the trend of ``degree`` (:func:`~enctools.methods.trend_lsq.group_batch`)."""
    w = np.subtract(ref, origin)              # floor((ref - origin) / window), in place
    w /= window
    np.floor(w, out=w)
    centre = w + 0.5                          # origin + (w + 0.5) window, in place
    centre *= window
    centre += origin
    keys = w.astype(np.int64)
    if groups is not None:
        keys += np.asarray(groups).astype(np.int64) << 40
    return group_batch(keys, ref, degree, window / 2, centre)


def fit_interpolation_error(device_rad: np.ndarray, device_phase: np.ndarray,
                            reference_rad: np.ndarray, periods_per_rev: int,
                            harmonics: int = 4, keep: Sequence[int] | None = None,
                            trend_degree: int = 1, groups: np.ndarray | None = None,
                            reference_phase: np.ndarray | None = None,
                            reference_orders: Sequence[int] = (),
                            reference_periods_per_rev: int | None = None,
                            positions: np.ndarray | None = None,
                            window: float | None = None) -> InterpResult:
    """Fit the device's interpolation error against a reference (seed 000 eqs. (19), (20)).

    ``device_rad``, ``reference_rad`` [rad]: both angles at the same samples (any
    offsets); ``device_phase`` [rad] the device's signal phase from its counts
    (:func:`enctools.data.readings.signal_phase`); ``periods_per_rev`` the device's
    signal periods per revolution. ``harmonics``: orders 1..harmonics fitted (cycles
    per period); ``keep`` the orders that make the reported error (default all; the
    seed keeps 1 and 2 against an encoder of another period). ``trend_degree``: the
    polynomial in the reference angle removed per group; ``groups`` the group (run)
    of each sample. ``reference_phase`` [rad], ``reference_orders``,
    ``reference_periods_per_rev``: the reference encoder's own interpolation error
    fitted alongside (empty: none, the seed's plain filter). ``positions``: the
    commanded position of each sample, so that repeated readings count once when
    judging how finely the period is sampled. ``window`` [rad]: a continuous run,
    one trend per window of the reference angle (None: one per group).

    Returns an :class:`InterpResult`. DataError when the sweep is shorter than one
    signal period, has too few samples for the model, or cannot tell the device's
    harmonics from the reference's. The same fit by batch: :class:`InterpolationFit`.
    """
    fit = InterpolationFit(periods_per_rev, harmonics, keep, trend_degree,
                           reference_orders if reference_phase is not None else (),
                           reference_periods_per_rev, window)
    fit.add(device_rad, device_phase, reference_rad, groups, reference_phase, positions)
    return fit.result()
