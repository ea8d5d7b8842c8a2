"""Interpolation error: the deviation of a head within its signal period (seed 000 sec. 4).

A small-angle sweep (seed 000 table 1: 7.2" at 0.2" steps, 25" at 0.5") records a
device head (or a head average) and a reference at once. The deviation
``zeta = psi_E - psi_R`` (seed 000 eq. (19)) is modelled as

    zeta(x) = trend(x) + sum_n [a_n cos(n phi) + b_n sin(n phi)]            (device)
                       - sum_j [c_j cos(j phi_R) + d_j sin(j phi_R)]        (reference)

with phi the device's signal phase (from its counts), x the swept angle, a
polynomial ``trend`` per run (the graduation error and a probe arm-length error are
close to linear over a few arcseconds), and optionally the reference's own
interpolation error at the reference's signal phase phi_R. The harmonics n are in
units of the device's signal period: n = 1 is one cycle per period. A least-squares
fit gives them with standard uncertainties; the interpolation error is the device
part as a function of phase.

References:
- capacitive probes on an arm L: psi_R = side * h / L (seed 000 eq. (20)), the
  probes averaged (two probes on opposite sides cancel the spindle's translation);
- another encoder's head. When its signal period differs, its own interpolation
  error sits at other period-harmonics of the device: the device's curve keeps only
  the chosen harmonics (default 1 and 2), as in seed 000 figs. 12-14. The period
  ratio (device period / reference period) says where the reference's harmonics j
  land (at j * ratio); when one lands on a kept harmonic the filter cannot separate
  them and :func:`landing_harmonics` names it.

The error is a function of the phase the head *reads* (its counts modulo the
interpolation factor), which is what a correction table indexed by the counts needs.
The grating's true phase differs from it by the error itself (periods_per_rev * psi),
so the curve is psi(phi_true) seen through phi_read = phi_true + P psi: the same
values, abscissae moved by up to psi (a shape change of about psi' psi, 0.01" for a
0.2" error over a 25" period). The mean of the error is not observable (it is one
with the reference's zero) and is removed.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from enctools.data.readings import HeadInfo, head_angle, signal_phase, signal_step
from enctools.errors import DataError
from enctools.methods.trend_lsq import TrendProjectedLSQ
from enctools.units import ARCSEC, TWO_PI


@dataclass(frozen=True)
class PeriodHarmonics:
    """A periodic error as harmonics of a signal period.

    ``orders`` (int, cycles per period), ``coef`` complex c_n = a_n - i b_n [arcsec]
    so that the error is sum Re(c_n exp(i n phi)); ``cov`` the covariance of the
    real pairs (a_1, b_1, a_2, b_2, ...) [arcsec^2].
    """

    orders: np.ndarray
    coef: np.ndarray
    cov: np.ndarray

    def __call__(self, phase: np.ndarray) -> np.ndarray:
        """The error [arcsec] at signal phase ``phase`` [rad]."""
        phase = np.asarray(phase, dtype=np.float64)
        out = np.zeros_like(phase)
        for n, c in zip(self.orders, self.coef):
            out += c.real * np.cos(n * phase) - c.imag * np.sin(n * phase)
        return out

    def basis(self, phase: np.ndarray) -> np.ndarray:
        """Design columns cos(n phi), sin(n phi) for every order (rows: samples)."""
        phase = np.asarray(phase, dtype=np.float64)
        cols = []
        for n in self.orders:
            cols += [np.cos(n * phase), np.sin(n * phase)]
        return np.column_stack(cols) if cols else np.zeros((phase.size, 0))

    def uncertainty(self, phase: np.ndarray) -> np.ndarray:
        """Standard uncertainty [arcsec] of the error at ``phase`` [rad]."""
        g = self.basis(phase)
        return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", g, self.cov, g), 0.0))

    @property
    def amplitude(self) -> np.ndarray:
        """|c_n| [arcsec]."""
        return np.abs(self.coef)

    @property
    def phase(self) -> np.ndarray:
        """p_n of |c_n| cos(n phi + p_n) [rad]."""
        return np.angle(self.coef)

    @property
    def amplitude_u(self) -> np.ndarray:
        """Standard uncertainty of |c_n| [arcsec] (linearised)."""
        out = np.empty(self.orders.size)
        for k, c in enumerate(self.coef):
            a, b = c.real, -c.imag
            block = self.cov[2 * k:2 * k + 2, 2 * k:2 * k + 2]
            r = abs(c)
            if r > 0:
                g = np.array([a, b]) / r
                out[k] = np.sqrt(max(g @ block @ g, 0.0))
            else:
                out[k] = np.sqrt(max(np.trace(block) / 2, 0.0))
        return out

    def select(self, keep: Sequence[int]) -> PeriodHarmonics:
        """Only the orders in ``keep`` (those that were fitted)."""
        idx = [k for k, n in enumerate(self.orders) if int(n) in {int(x) for x in keep}]
        cov_idx = np.array([[2 * k, 2 * k + 1] for k in idx], dtype=int).ravel()
        return PeriodHarmonics(self.orders[idx], self.coef[idx],
                               self.cov[np.ix_(cov_idx, cov_idx)])


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
        """Figures of the error curve [arcsec]: p-p, +/- (half the p-p), rms, max, min."""
        return figures(self.error(np.linspace(0.0, TWO_PI, points, endpoint=False)))


def figures(curve: np.ndarray) -> dict[str, float]:
    """p-p, +/- (half the p-p, as enc report), mean, rms, max, min of a curve [arcsec]."""
    c = np.asarray(curve, dtype=np.float64)
    m = float(c.mean())
    pp = float(c.max() - c.min())
    return {"pp": pp, "plus_minus": pp / 2,
            "mean": m, "rms": float(np.sqrt(np.mean((c - m) ** 2))),
            "max": float(c.max()), "min": float(c.min())}


def probe_rotation(values: Sequence[np.ndarray], arms_m: Sequence[float],
                   sides: Sequence[int]) -> np.ndarray:
    """Rotation [rad] from displacement probes: mean of side * h / L (seed 000 eq. (20)).

    ``values`` [m] per probe, ``arms_m`` L [m], ``sides`` +1/-1. Two probes on
    opposite sides cancel the translation of the spindle.
    """
    if not values:
        msg = "no probe to use as the reference"
        raise DataError(msg)
    out = np.zeros(np.asarray(values[0]).shape)
    for h, arm, side in zip(values, arms_m, sides):
        if not (np.isfinite(arm) and arm > 0):
            msg = f"probe arm length L = {arm!r} m: must be > 0 (psi = h / L)"
            raise DataError(msg)
        out += side * np.asarray(h, dtype=np.float64) / arm
    return out / len(values)


def device_reading(counts: Sequence[np.ndarray], infos: Sequence[HeadInfo]
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(angle [rad], interpolation step [count]) of a head or a head average.

    The average of heads of one encoder is periodic in that encoder's signal period
    as a function of the first head's phase (the heads sit at fixed phase offsets);
    the step is that phase in counts (:func:`enctools.readings.signal_step`).
    """
    if len({i.periods_per_rev for i in infos}) > 1:
        names = ", ".join(i.name for i in infos)
        msg = f"heads {names} have different signal periods: average heads of one encoder"
        raise DataError(msg)
    angle = np.mean([head_angle(c, i) for c, i in zip(counts, infos)], axis=0)
    return angle, signal_step(np.asarray(counts[0]), infos[0])


def period_ratio(device_periods_per_rev: int, reference_periods_per_rev: int) -> float:
    """Device signal period / reference signal period (reference cycles per device period)."""
    return reference_periods_per_rev / device_periods_per_rev


def landing_harmonics(ratio: float, keep: Sequence[int], reference_orders: Sequence[int] = (1, 2),
                      tolerance: float = 0.5) -> list[tuple[int, float, int]]:
    """Reference harmonics j that land within ``tolerance`` of a kept device harmonic.

    The reference's j-th harmonic of its own period is at j * ratio harmonics of the
    device period; when that is near a kept order k, keeping k keeps the reference's
    error too. Returns (j, j * ratio, k) triples.
    """
    out = []
    for j in reference_orders:
        at = j * ratio
        for k in keep:
            if abs(at - k) < tolerance:
                out.append((int(j), float(at), int(k)))
    return out


def resolvable_harmonics(phase: np.ndarray, positions: np.ndarray | None = None) -> int:
    """Highest harmonic of the period the sampled phases [rad] can resolve: pi / largest gap.

    With ``positions``, the readings at one position are averaged (circular mean)
    first, so their noise does not pose as finer sampling.
    """
    cover = PhaseCoverage()
    cover.add(np.asarray(phase, dtype=np.float64), positions)
    return cover.resolvable()


def _largest_gap(p: np.ndarray) -> float:
    p = np.sort(np.mod(p, TWO_PI))
    return float(np.max(np.diff(np.append(p, p[0] + TWO_PI)))) if p.size else TWO_PI


class PhaseCoverage:
    """How finely samples cover the signal period, gathered batch by batch.

    Without positions the phases [rad] are marked in :data:`BINS` bins of the
    period (a bitmap of constant size); phases from counts are multiples of
    2 pi / interpolation (4096), so with 16 bins per count step the largest gap is
    exact. With positions (a sweep's target column) the readings at one position
    are averaged first (circular mean of their phases), as their noise must not
    pose as finer sampling: the sums are kept per position, bounded by the number
    of positions.
    """

    #: bins of the bitmap per signal period
    BINS = 1 << 16

    def __init__(self) -> None:
        self._mask = np.zeros(self.BINS, dtype=bool)
        self._pos: dict[float, complex] = {}
        self.samples = 0

    def add(self, phase: np.ndarray, positions: np.ndarray | None = None,
            step: np.ndarray | None = None, steps: int = 0) -> None:
        """Add phases [rad] (with ``step``: phase = 2 pi step / steps, from counts)."""
        phase = np.asarray(phase, dtype=np.float64)
        self.samples += phase.size
        if positions is None:
            if step is not None and self.BINS % steps == 0:
                self._mask[step * (self.BINS // steps)] = True
                return
            k = np.rint(np.mod(phase, TWO_PI) * (self.BINS / TWO_PI)).astype(np.int64)
            self._mask[np.mod(k, self.BINS)] = True
            return
        keys, inv = np.unique(np.asarray(positions), return_inverse=True)
        z = np.bincount(inv, np.cos(phase), keys.size) + 1j * np.bincount(inv, np.sin(phase), keys.size)
        for key, v in zip(keys.tolist(), z.tolist()):
            self._pos[key] = self._pos.get(key, 0j) + v

    def gap(self) -> float:
        """Largest gap [rad] between the sampled phases (2 pi when fewer than 2)."""
        if self._pos:
            if len(self._pos) < 2:
                return TWO_PI
            return _largest_gap(np.angle(np.array(list(self._pos.values()))))
        k = np.flatnonzero(self._mask)
        if k.size < 2:
            return TWO_PI
        return _largest_gap(k * (TWO_PI / self.BINS))

    def resolvable(self) -> int:
        """Highest harmonic of the period resolvable: floor(pi / largest gap)."""
        n = len(self._pos) if self._pos else int(self._mask.sum())
        if n < 2:
            return 0
        gap = self.gap()
        return int(np.floor(np.pi / gap - 1e-9)) if gap > 0 else n


#: default window of a continuous run [arcsec]: a line per 0.5 deg leaves of the
#: graduation error of sjtu-dual (harmonics up to 180 per turn) 0.004" rms
DEFAULT_WINDOW_ARCSEC = 1800.0
#: quarters of the signal period a window's phases must all visit to count as covering it
SECTORS = 4


def _harmonic_rows(phase: np.ndarray, orders: np.ndarray, out: np.ndarray,
                   step: np.ndarray | None = None, steps: int = 0) -> None:
    """cos(n phase), sin(n phase) for each order n into rows 2k, 2k + 1 of ``out``.

    With ``step`` (phase = 2 pi step / steps, from the counts) they are looked up in a
    table of the ``steps`` phases; otherwise consecutive orders by complex products
    from exp(i phase) (one cos/sin pair).
    """
    if step is not None:
        table = _phase_table(steps, tuple(int(n) for n in orders))
        for k in range(len(orders)):
            np.take(table[2 * k], step, out=out[2 * k])
            np.take(table[2 * k + 1], step, out=out[2 * k + 1])
        return
    e1 = np.exp(1j * phase)
    e = np.ones_like(e1)
    n = 0
    for k, order in enumerate(orders):
        e = e * (e1 if order == n + 1 else np.exp(1j * (order - n) * phase))
        n = int(order)
        out[2 * k], out[2 * k + 1] = e.real, e.imag


@functools.lru_cache(maxsize=8)
def _phase_table(steps: int, orders: tuple[int, ...]) -> np.ndarray:
    """Rows cos(n phi), sin(n phi) for each order n at phi = 2 pi j / steps, j < steps."""
    phi = np.arange(steps) * (TWO_PI / steps)
    out = np.empty((2 * len(orders), steps))
    for k, n in enumerate(orders):
        out[2 * k], out[2 * k + 1] = np.cos(n * phi), np.sin(n * phi)
    out.flags.writeable = False
    return out


class InterpolationFit:
    """The fit of :func:`fit_interpolation_error`, fed batch by batch (seed 000 eqs. (19), (20)).

    zeta = (device - reference) [arcsec] is modelled as a trend per group (a run of
    a sweep, or with ``window`` [rad] a window of that span of the reference angle)
    plus the device harmonics of its signal phase and optionally the reference's
    own. Memory does not grow with the number of samples: the trends are projected
    out per group (:class:`TrendProjectedLSQ`), the phase coverage is a bitmap
    (:class:`PhaseCoverage`). See :func:`fit_interpolation_error` for the
    parameters; :meth:`add` takes the same arrays by batch, :meth:`result` fits.
    """

    def __init__(self, periods_per_rev: int, harmonics: int = 4,
                 keep: Sequence[int] | None = None, trend_degree: int = 1,
                 reference_orders: Sequence[int] = (),
                 reference_periods_per_rev: int | None = None,
                 window: float | None = None) -> None:
        if harmonics < 1:
            msg = f"harmonics must be >= 1, not {harmonics}"
            raise DataError(msg)
        self.period = TWO_PI / periods_per_rev
        self.periods_per_rev = periods_per_rev
        self.orders = np.arange(1, harmonics + 1)
        self.keep = list(self.orders) if keep is None else [int(k) for k in keep]
        bad = [k for k in self.keep if k not in set(self.orders.tolist())]
        if bad:
            msg = f"kept harmonic {bad[0]} is not fitted (harmonics 1..{harmonics})"
            raise DataError(msg)
        if window is not None and not window >= self.period:
            msg = (f"--window {window / ARCSEC:.4g}\" is shorter than the signal period "
                   f"{self.period / ARCSEC:.4g}\": a window must span at least one period")
            raise DataError(msg)
        self.ref_orders = np.asarray(list(reference_orders), dtype=int)
        self.reference_periods_per_rev = reference_periods_per_rev
        self.window = window
        self.cover = PhaseCoverage()
        n_cols = 2 * self.orders.size + 2 * self.ref_orders.size
        self.lsq = TrendProjectedLSQ(n_cols, trend_degree, consecutive=window is not None,
                                     on_close=self._closed, n_extra=1 + SECTORS)
        self._origin: float | None = None
        self._lo, self._hi = np.inf, -np.inf
        self.skipped = 0  # samples with a NaN or infinite reading, probe or phase
        # per closed group: the worst coverage (runs) or phase coverage (windows)
        self._short: tuple[float, float] | None = None   # (span + step, span) of the worst run
        self._min_span = np.inf
        self._covering = [0, 0]     # windows, samples that carry the phase through a period
        self._samples_closed = 0

    def _closed(self, extra: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
        count = extra[:, 0]
        span = hi - lo
        self._samples_closed += int(count.sum())
        if self.window is None:
            step = np.where(count > 1, span / np.maximum(count - 1, 1), 0.0)
            worst = int(np.argmin(span + step))
            if self._short is None or span[worst] + step[worst] < self._short[0]:
                self._short = (float(span[worst] + step[worst]), float(span[worst]))
            self._min_span = min(self._min_span, float(span.min()))
        else:
            full = np.all(extra[:, 1:] > 0, axis=1)
            self._covering[0] += int(full.sum())
            self._covering[1] += int(count[full].sum())

    def add(self, device_rad: np.ndarray, device_phase: np.ndarray, reference_rad: np.ndarray,
            groups: np.ndarray | None = None, reference_phase: np.ndarray | None = None,
            positions: np.ndarray | None = None,
            steps: tuple[np.ndarray, int, np.ndarray | None, int] | None = None) -> None:
        """Add samples (arrays as in :func:`fit_interpolation_error`); non-finite rows are skipped.

        ``steps``: (device step, its steps per period, reference step or None, its steps)
        when the phases come from counts (:func:`enctools.readings.signal_step`): the
        harmonic columns are then looked up rather than computed.
        """
        dev = np.asarray(device_rad, dtype=np.float64)
        ref = np.asarray(reference_rad, dtype=np.float64)
        phase = np.asarray(device_phase, dtype=np.float64)
        n = dev.size
        if not (ref.size == n and phase.size == n):
            msg = "device, phase and reference differ in length"
            raise DataError(msg)
        good = np.isfinite(dev) & np.isfinite(ref) & np.isfinite(phase)
        if self.ref_orders.size:
            if reference_phase is None:
                msg = "the reference's harmonics are fitted: give its signal phase"
                raise DataError(msg)
            reference_phase = np.asarray(reference_phase, dtype=np.float64)
            good &= np.isfinite(reference_phase)
        if not good.all():
            self.skipped += int(n - np.count_nonzero(good))
            steps = None if steps is None else (
                steps[0][good], steps[1], None if steps[2] is None else steps[2][good], steps[3])
            dev, ref, phase = dev[good], ref[good], phase[good]
            groups = None if groups is None else np.asarray(groups)[good]
            positions = None if positions is None else np.asarray(positions)[good]
            reference_phase = None if reference_phase is None else reference_phase[good]
        if dev.size == 0:
            return
        dev_step, dev_steps, ref_step, ref_steps = steps if steps is not None else (None, 0, None, 0)
        self.cover.add(phase, positions, dev_step, dev_steps)
        self._lo, self._hi = min(self._lo, float(ref.min())), max(self._hi, float(ref.max()))
        m = dev.size
        x_rows = np.empty((self.lsq.p, m))
        _harmonic_rows(phase, self.orders, x_rows[:2 * self.orders.size], dev_step, dev_steps)
        if self.ref_orders.size:
            _harmonic_rows(reference_phase, self.ref_orders, x_rows[2 * self.orders.size:],
                           ref_step, ref_steps)
        zeta = (dev - ref) / ARCSEC
        keys = np.zeros(m, np.int64) if groups is None else np.asarray(groups).astype(np.int64)
        if dev_step is not None:
            sector = dev_step * SECTORS // dev_steps
        else:
            sector = np.minimum((np.mod(phase, TWO_PI) * (SECTORS / TWO_PI)).astype(np.int64),
                                SECTORS - 1)
        extra = np.empty((1 + SECTORS, m))
        extra[0] = 1.0
        for k in range(SECTORS):
            np.equal(sector, k, out=extra[1 + k], casting="unsafe")
        if self.window is None:
            self.lsq.add(x_rows, zeta, ref, keys, self.period, extra=extra)
            return
        if self._origin is None:
            self._origin = float(ref[0])
        w = np.floor((ref - self._origin) / self.window)
        centre = self._origin + (w + 0.5) * self.window
        keys = (keys << 40) + w.astype(np.int64)
        self.lsq.add(x_rows, zeta, ref, keys, self.window / 2, centre=centre, extra=extra)

    def result(self) -> InterpResult:
        """The fit of every sample added. DataError as :func:`fit_interpolation_error` says."""
        lsq = self.lsq
        lsq.close_all()
        period = self.period
        if lsq.n == 0:
            msg = "no sample with finite device and reference readings"
            raise DataError(msg)
        if self.window is None:
            # coverage: every run must sweep one signal period (to within a step)
            if self._short is not None and self._short[0] < period * 0.999:
                msg = (f"the sweep covers {self._short[1] / ARCSEC:.3g}\" but the signal period is "
                       f"{period / ARCSEC:.4g}\": sweep at least one period (--range)")
                raise DataError(msg)
            periods = self._min_span / period
        else:
            periods = (self._hi - self._lo) / period
            if self._covering[0] == 0:
                msg = (f"no window of {self.window / ARCSEC:.4g}\" carries the device's phase "
                       f"through a whole signal period ({lsq.groups} windows): widen --window "
                       f"or sample at another interval")
                raise DataError(msg)
        # Nyquist within the period: harmonics must be finer than the largest phase gap
        k_max = self.cover.resolvable()
        harmonics = int(self.orders[-1])
        if harmonics > k_max:
            msg = (f"{harmonics} harmonics asked but the sweep samples the signal period "
                   f"only finely enough for {k_max}: fit fewer (--band) or step finer")
            raise DataError(msg)
        p = lsq.p
        n_par = lsq.n_trend + p
        if lsq.n <= n_par:
            msg = (f"{lsq.n} samples for {n_par} parameters: record more points "
                   f"or fit fewer harmonics")
            raise DataError(msg)
        # columns scaled by their norms before the trends were projected out, so that
        # a harmonic the trends absorb shows as a small eigenvalue
        norms = np.sqrt(lsq.raw_ss)
        norms[norms == 0] = 1.0
        a = lsq.xtx / np.outer(norms, norms)
        a = (a + a.T) / 2
        w = np.linalg.eigvalsh(a)
        cond = float(np.sqrt(w[-1] / w[0])) if w[0] > 0 else np.inf
        if cond > 1e6:
            what = ("the reference's harmonics cannot be told from the device's over this sweep"
                    if self.ref_orders.size else "the sweep does not determine every harmonic")
            msg = f"{what} (condition number {cond:.3g}); sweep longer or fit fewer harmonics"
            raise DataError(msg)
        a_inv = np.linalg.inv(a)
        coef = (a_inv @ (lsq.xty / norms)) / norms
        rss = max(lsq.yty - float(coef @ lsq.xty), 0.0)
        dof = lsq.n - n_par
        s2 = rss / dof
        cov = a_inv * s2 / np.outer(norms, norms)
        n_dev = 2 * self.orders.size
        ab = coef[:n_dev]
        fitted = PeriodHarmonics(self.orders, ab[0::2] - 1j * ab[1::2], cov[:n_dev, :n_dev])
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
        result = InterpResult(error=fitted.select(self.keep), fitted=fitted, period=period,
                              samples=int(lsq.n), periods=float(periods),
                              residual_rms=float(np.sqrt(s2)), reference=reference)
        if self.skipped:
            result.warnings.append(
                f"{self.skipped} of {self.skipped + lsq.n} samples skipped: a NaN or infinite "
                "reading, probe value or phase")
        if self.window is not None:
            result.windows = lsq.groups
            partial = lsq.n - self._covering[1]
            if partial > lsq.n / 2:
                result.warnings.append(
                    f"{partial / lsq.n:.0%} of the samples lie in windows whose phases do not "
                    f"go through a whole signal period; they add little: widen --window")
        ratio_of = self.reference_periods_per_rev
        if ratio_of is not None:
            result.ratio = period_ratio(self.periods_per_rev, ratio_of)
            if ratio_of != self.periods_per_rev:
                if self.ref_orders.size:
                    # fitted alongside: separable when they differ by a cycle over the sweep
                    result.landing = landing_harmonics(result.ratio, self.keep,
                                                       self.ref_orders.tolist(),
                                                       tolerance=1.0 / result.periods)
                else:
                    result.landing = landing_harmonics(result.ratio, self.keep)
                for j, at, k in result.landing:
                    result.warnings.append(
                        f"the reference's harmonic {j} lands at {at:.3g} harmonics of the device "
                        f"period, on kept harmonic {k}: the filter cannot remove it "
                        f"over {result.periods:.3g} periods swept")
        return result


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

    Parameters
    ----------
    device_rad, reference_rad : arrays [rad]
        The device's and the reference's angles at the same samples (any offsets).
    device_phase : array [rad]
        The device's signal phase from its counts (:func:`enctools.readings.signal_phase`).
    periods_per_rev : int
        Signal periods per revolution of the device (the period is 2 pi / it).
    harmonics : int
        Device harmonics 1..harmonics are fitted (cycles per signal period).
    keep : orders or None
        Orders that make the reported error (default all fitted); with a reference
        encoder of another signal period the seed keeps 1 and 2.
    trend_degree : int
        Degree of the polynomial in the reference angle removed per group.
    groups : int array or None
        Group (run) of each sample; each has its own trend.
    reference_phase, reference_orders, reference_periods_per_rev :
        The reference encoder's signal phase [rad] and the orders of its own
        interpolation error to fit alongside (empty: none, the seed's plain filter).
    positions : array or None
        Commanded position of each sample (e.g. the sweep's target), so that
        repeated readings at one position count once when judging how finely the
        sweep samples the period (default: every sample is a position).
    window : float or None
        A continuous run [rad]: each window of this span of the reference angle
        (within each group) has its own trend, so that the trend need only follow
        the graduation error over the window; None: one trend per group.

    Returns
    -------
    InterpResult. Raises DataError when the sweep is shorter than one signal period,
    has too few samples for the model, or the model cannot tell the device's
    harmonics from the reference's (near-collinear columns). The same fit by batch:
    :class:`InterpolationFit`.
    """
    fit = InterpolationFit(periods_per_rev, harmonics, keep, trend_degree,
                           reference_orders if reference_phase is not None else (),
                           reference_periods_per_rev, window)
    fit.add(device_rad, device_phase, reference_rad, groups, reference_phase, positions)
    return fit.result()


# ------------------------------------------------------------- readings-level checks


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
    meta: dict
    warnings: list[str] = field(default_factory=list)


#: --signals, --corrected and --ref-file read their input whole; longer inputs are refused
MAX_SWEEP_SAMPLES = 1_000_000


def read_sweep(source, max_samples: int = MAX_SWEEP_SAMPLES, why: str = "--signals"):
    """All of a stream's readings as one Arrow table, refusing more than ``max_samples`` rows.

    The modes that need the whole table (``why``: the Heydemann fit of --signals,
    a reference file matched by time) read at most this many rows; a longer input
    is refused at the first batch past it, before it fills the memory. The
    reference mode proper streams (:func:`check_readings`).
    """
    import pyarrow as pa

    batches = []
    rows = 0
    for b in source.batches():
        rows += b.num_rows
        if rows > max_samples:
            source.close()
            msg = (f"{source.source}: more than {max_samples:,} samples; {why} reads its input "
                   "whole: record fewer revolutions or a sweep (enc acquire --mode sweep), "
                   "or check against a reference in the same stream (--ref HEAD or probes)")
            raise DataError(msg)
        batches.append(b)
    return pa.Table.from_batches(batches, schema=source.schema)


def _column(table, name: str) -> np.ndarray:
    """A column as numpy: int64 stays integer (counts), the rest float64 (nulls -> NaN)."""
    import pyarrow as pa

    col = table.column(name)
    if pa.types.is_integer(col.type) and col.null_count == 0:
        return col.to_numpy()
    return col.cast(pa.float64()).to_numpy(zero_copy_only=False)


def _harmonics_meta(h: PeriodHarmonics) -> list[dict[str, float]]:
    return [{"n": int(n), "amplitude": float(a), "phase": float(p), "u": float(u)}
            for n, a, p, u in zip(h.orders, h.amplitude, h.phase, h.amplitude_u)]


def probe_reference(table, probes: Sequence[str] | None, arm_m: float | None,
                    ) -> tuple[np.ndarray, dict]:
    """The probes' rotation [rad] (seed 000 eq. (20)) and a description of it."""
    from enctools.data.schemas import columns_with_role, field_meta

    names = list(probes) if probes else columns_with_role(table.schema, "probe")
    if not names:
        msg = "input: no probe column (role=probe); give --ref HEAD or --ref-file"
        raise DataError(msg)
    values, arms, sides = [], [], []
    for p in names:
        if p not in table.schema.names or field_meta(table.schema.field(p)).get("role") != "probe":
            msg = f"input: no probe {p!r} (probes: {', '.join(columns_with_role(table.schema, 'probe')) or 'none'})"
            raise DataError(msg)
        fm = field_meta(table.schema.field(p))
        arm = float(arm_m) if arm_m is not None else float(fm.get("arm_m", "nan"))
        if not (np.isfinite(arm) and arm > 0):
            msg = f"probe {p}: arm length L = {arm:g} m; it must be > 0 (give --arm)"
            raise DataError(msg)
        values.append(_column(table, p))
        arms.append(arm)
        sides.append(int(float(fm.get("side", "1"))))
    return probe_rotation(values, arms, sides), {"reference": "probes", "probes": names,
                                                 "arm_m": arms, "sides": sides}


#: rows handed to the fit at once (bounds the temporaries of a large batch)
CHUNK_ROWS = 1 << 16


def _chunks(source):
    """Record batches of ``source`` (a Table or a stream with .batches()), cut to CHUNK_ROWS."""
    batches = source.to_batches() if hasattr(source, "to_batches") else source.batches()
    for b in batches:
        for start in range(0, b.num_rows, CHUNK_ROWS):
            yield b.slice(start, CHUNK_ROWS)


class _TimeMatched:
    """A reference recorded apart, interpolated to the input's times t [s] batch by batch."""

    def __init__(self, t_ref: np.ndarray, values: Sequence[np.ndarray], source: str) -> None:
        order = np.argsort(t_ref, kind="stable")
        self.t = np.asarray(t_ref, float)[order]
        self.values = [np.asarray(v, float)[order] for v in values]
        self.source = source
        self.rows = 0
        self.t_lo, self.t_hi = np.inf, -np.inf

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        if t.size:
            self.t_lo, self.t_hi = min(self.t_lo, float(np.min(t))), max(self.t_hi, float(np.max(t)))
        inside = (t >= self.t[0]) & (t <= self.t[-1])
        self.rows += int(inside.sum())
        return inside, [np.interp(t, self.t, v) for v in self.values]

    def check(self) -> None:
        if self.rows == 0:
            msg = (f"{self.source}: covers t = {self.t[0]:.6g}..{self.t[-1]:.6g} s, the input "
                   f"{self.t_lo:.6g}..{self.t_hi:.6g} s: no overlap in time")
            raise DataError(msg)


def check_readings(source, heads: Sequence[str] | None = None, average: bool = False,
                   reference: str = "probes", reference_table=None,
                   probes: Sequence[str] | None = None, arm_m: float | None = None,
                   harmonics: int | None = None, keep: Sequence[int] | None = None,
                   reference_harmonics: int = 2, trend_degree: int = 1,
                   points: int = 256, reference_source: str = "reference",
                   continuous: bool = False, window_arcsec: float | None = None) -> list[Curve]:
    """Interpolation error of heads of a readings stream against a reference.

    ``source``: a readings table, or a stream (``.schema``, ``.batches()``) read batch
    by batch in constant memory. ``heads`` (default every head but the reference)
    are checked one by one, or averaged into one device with ``average``.
    ``reference``: "probes" or a head name, taken from ``reference_table`` (whole,
    matched by time t) when given, else from the input. ``harmonics`` defaults to 4,
    or against an encoder of another signal period to the highest kept order (the
    device's higher harmonics are small and would share the sweep's few cycles with
    the reference's own error). A ``continuous`` run (or any input with
    ``window_arcsec``) has a trend per window of ``window_arcsec`` [arcsec] (default
    :data:`DEFAULT_WINDOW_ARCSEC`) of the reference angle; a sweep one per run.
    See :class:`InterpolationFit` for the rest.
    """
    from enctools.data.readings import head_info
    from enctools.data.schemas import columns_with_role

    schema = source.schema
    all_heads = columns_with_role(schema, "head")
    rtab = reference_table
    rsrc = reference_source if rtab is not None else "input"
    ref_info = None
    if reference == "probes":
        _, ref_meta = probe_reference(rtab if rtab is not None else schema.empty_table(),
                                      probes, arm_m)
    else:
        ref_info = head_info((rtab if rtab is not None else source).schema, reference, rsrc)
        ref_meta = {"reference": reference, "reference_encoder": ref_info.encoder,
                    "reference_periods_per_rev": ref_info.periods_per_rev}
    matched = None
    if rtab is not None:
        if "t" not in schema.names or "t" not in rtab.schema.names:
            msg = f"{rsrc}: both streams need a time column t to be matched"
            raise DataError(msg)
        if ref_info is None:
            vals = [probe_reference(rtab, probes, arm_m)[0]]
        else:
            rc = _column(rtab, reference)
            vals = [head_angle(rc, ref_info), np.unwrap(signal_phase(rc, ref_info))]
        matched = _TimeMatched(_column(rtab, "t"), vals, rsrc)
        ref_meta["file"] = reference_source

    names = list(heads) if heads else [h for h in all_heads
                                       if not (rtab is None and h == reference)]
    if not names:
        msg = "input: no head to check"
        raise DataError(msg)
    windowed = continuous or window_arcsec is not None
    window_arcsec = (window_arcsec if window_arcsec is not None else DEFAULT_WINDOW_ARCSEC) \
        if windowed else None
    chunks = _chunks(source)
    first = next(chunks, None)
    strobe = _stroboscopic(first, schema, names, reference, ref_info, probes, arm_m) \
        if windowed and first is not None and rtab is None else {}
    devices = [names] if average else [[n] for n in names]
    plans = []
    skipped = []
    for dev_names in devices:
        infos = [head_info(schema, n) for n in dev_names]
        info = infos[0]
        name = dev_names[0] if len(dev_names) == 1 else "mean(" + ",".join(dev_names) + ")"
        if ref_info is not None and ref_info.name == info.name and rtab is None:
            msg = f"--ref {reference} is the device itself; choose another head or probes"
            raise DataError(msg)
        synchronous = [n for n in dev_names if n in strobe]
        if synchronous:
            h = synchronous[0]
            what = (f"{h}: sampling is nearly synchronous with its signal period "
                    f"({strobe[h]:.3f} periods per sample): its phase barely moves within a "
                    f"window, so its interpolation error goes into the trend")
            if heads:
                msg = f"{what}; record with another sample interval (enc acquire --interval)"
                raise DataError(msg)
            skipped.append(f"{what}: not checked (record with another --interval)")
            continue
        if len({i.periods_per_rev for i in infos}) > 1:
            msg = f"heads {', '.join(dev_names)} have different signal periods: average heads of one encoder"
            raise DataError(msg)
        other_period = ref_info is not None and ref_info.periods_per_rev != info.periods_per_rev
        k_keep = list(keep) if keep is not None else ([1, 2] if other_period else None)
        n_fit = harmonics if harmonics is not None else (max(k_keep) if other_period else 4)
        warnings = []
        ref_fitted = other_period and reference not in strobe
        if other_period and not ref_fitted:
            warnings.append(f"{name}: sampling is nearly synchronous with the signal period of "
                            f"the reference {reference} ({strobe[reference]:.3f} periods per "
                            f"sample): its interpolation error goes into the trend and its "
                            f"harmonics are not fitted")
        if ref_info is not None and not other_period:
            warnings.append(f"{name}: the reference {ref_info.name} has the same signal period; "
                            f"the result is the difference of both heads' interpolation errors")
        fit = InterpolationFit(
            info.periods_per_rev, n_fit, k_keep, trend_degree,
            range(1, reference_harmonics + 1) if ref_fitted else (),
            ref_info.periods_per_rev if ref_info else None,
            window_arcsec * ARCSEC if windowed else None)
        plans.append((dev_names, infos, name, ref_fitted, warnings, fit))
    if not plans:
        msg = skipped[0].replace(": not checked", "") if skipped else "input: no head to check"
        raise DataError(msg)

    has_run = "run" in schema.names
    has_target = "target" in schema.names
    for batch in itertools.chain([first] if first is not None else [], chunks):
        if batch.num_rows == 0:
            continue
        rows = None
        ref_phase = ref_step = None
        if matched is not None:
            rows, vals = matched(_column(batch, "t"))
            ref_rad = vals[0]
            if ref_info is not None:
                ref_phase = np.mod(vals[1], TWO_PI)
        elif ref_info is None:
            ref_rad = probe_reference(batch, probes, arm_m)[0]
        else:
            rc = _column(batch, reference)
            ref_step = signal_step(rc, ref_info)
            ref_rad, ref_phase = head_angle(rc, ref_info), ref_step * (TWO_PI / ref_info.interpolation)
        groups = _column(batch, "run") if has_run else None
        targets = _column(batch, "target") if has_target else None
        for dev_names, infos, _, ref_fitted, _, fit in plans:
            counts = [_column(batch, n) for n in dev_names]
            dev_rad, dev_step = device_reading(counts, infos)
            dev_phase = dev_step * (TWO_PI / infos[0].interpolation)
            r_step = ref_step
            if rows is not None:
                sel = np.flatnonzero(rows)
                dev_rad, dev_phase, dev_step = dev_rad[sel], dev_phase[sel], dev_step[sel]
                r_rad = ref_rad[sel]
                r_phase = ref_phase[sel] if ref_phase is not None else None
                r_step = ref_step[sel] if ref_step is not None else None
                g = groups[sel] if groups is not None else None
                pos = targets[sel] if targets is not None else None
            else:
                r_rad, r_phase, g, pos = ref_rad, ref_phase, groups, targets
            steps = (dev_step, infos[0].interpolation, r_step,
                     ref_info.interpolation if r_step is not None else 0)
            fit.add(dev_rad, dev_phase, r_rad, g, r_phase if ref_fitted else None, pos, steps)
    if matched is not None:
        matched.check()

    curves = []
    grid = np.linspace(0.0, TWO_PI, points, endpoint=False)
    for dev_names, infos, name, _, warnings, fit in plans:
        info = infos[0]
        try:
            r = fit.result()
        except DataError as exc:
            raise DataError(f"{name}: {exc}") from None
        warnings += [f"{name}: {w}" for w in r.warnings]
        fig = r.figures()
        meta = {"encoder": info.encoder, "heads": dev_names,
                "periods_per_rev": info.periods_per_rev,
                "period_arcsec": r.period / ARCSEC, "periods_swept": r.periods,
                "samples": r.samples, "residual_rms_arcsec": r.residual_rms,
                "kept": [int(n) for n in r.error.orders],
                "harmonics": _harmonics_meta(r.fitted), "figures": fig} | ref_meta
        if r.windows is not None:
            meta |= {"windows": r.windows, "window_arcsec": window_arcsec}
        if r.ratio is not None:
            meta["period_ratio"] = r.ratio
        if r.reference is not None:
            meta["reference_harmonics"] = _harmonics_meta(r.reference)
        curves.append(Curve(name, info.encoder, info.periods_per_rev, grid, r.error(grid),
                            r.error.uncertainty(grid), r.fitted, meta, warnings))
    if curves:
        curves[0].warnings[:0] = skipped
    return curves


def _stroboscopic(batch, schema, names, reference, ref_info, probes, arm_m) -> dict[str, float]:
    """Heads (devices and reference) sampled nearly synchronously with their signal period.

    The angle between samples is the median step of the reference over the first
    batch; :func:`enctools.harmonics.stroboscopic_heads` judges. Returns
    {head: signal periods per sample}.
    """
    from enctools.data.readings import head_info
    from enctools.methods.revolutions import stroboscopic_heads

    if batch.num_rows < 3:
        return {}
    if ref_info is None:
        ref_rad = probe_reference(batch, probes, arm_m)[0]
    else:
        ref_rad = head_angle(_column(batch, reference), ref_info)
    d = np.abs(np.diff(ref_rad))
    d = d[np.isfinite(d)]
    if not d.size:
        return {}
    seen = [head_info(schema, n) for n in names if n in schema.names]
    if ref_info is not None:
        seen.append(ref_info)
    return dict(stroboscopic_heads(float(np.median(d)), tuple(seen)))


def check_signals(table, heads: Sequence[str] | None = None, min_arc_deg: float = 90.0,
                  points: int = 256) -> tuple[list[Curve], dict]:
    """Heydemann fit of every head's raw signals; the interpolation error they predict.

    Signals are the role=signal columns of a head: components cos/sin, or the four
    phases 0/90/180/270. Returns the curves (error [arcsec] at the read phase, mean
    removed) and, per head, the fit (:meth:`EllipseFit.to_dict`) and the Lissajous
    radius variation.
    """
    from enctools.data.readings import head_info
    from enctools.data.schemas import columns_with_role, field_meta
    from enctools.methods import heydemann as hd
    from enctools.units import DEG

    by_head: dict[str, dict[str, str]] = {}
    for c in columns_with_role(table.schema, "signal"):
        fm = field_meta(table.schema.field(c))
        by_head.setdefault(fm.get("head", ""), {})[fm.get("component", "")] = c
    if not by_head:
        msg = "input: no raw signal columns (role=signal); record them with enc acquire --signals"
        raise DataError(msg)
    names = list(heads) if heads else list(by_head)
    curves, fits = [], {}
    grid = np.linspace(0.0, TWO_PI, points, endpoint=False)
    for name in names:
        comp = by_head.get(name)
        if comp is None:
            msg = f"input: no signals of head {name!r} (signals of: {', '.join(by_head)})"
            raise DataError(msg)
        if {"cos", "sin"} <= comp.keys():
            i, q = _column(table, comp["cos"]), _column(table, comp["sin"])
        elif {"0", "90", "180", "270"} <= comp.keys():
            i, q = hd.from_four_phase(*(_column(table, comp[k]) for k in ("0", "90", "180", "270")))
        else:
            msg = (f"input: head {name} has signal components {', '.join(sorted(comp))}; "
                   f"need cos and sin, or 0, 90, 180 and 270")
            raise DataError(msg)
        try:
            fit = hd.fit_ellipse(i, q, min_arc=min_arc_deg * DEG)
        except DataError as exc:
            raise DataError(f"head {name}: {exc}") from None
        info = head_info(table.schema, name) if name in table.schema.names else None
        ppr = info.periods_per_rev if info else 0
        err_rad = hd.read_phase_error(fit, grid)
        meta = {"signals": fit.to_dict(), "lissajous": hd.radius_variation(i, q),
                "reference": "signals"}
        fits[name] = meta
        if ppr:
            scale = 1.0 / ppr / ARCSEC
            unit_err = err_rad * scale
            mean = float(unit_err.mean())
            err = unit_err - mean
            u = hd.interpolation_error_u(fit, grid, ppr)
            meta |= {"encoder": info.encoder, "periods_per_rev": ppr,
                     "period_arcsec": TWO_PI / ppr / ARCSEC, "mean_arcsec": mean,
                     "figures": figures(err)}
            c = np.fft.rfft(err)[1:9] * 2 / grid.size
            meta["harmonics"] = [{"n": k + 1, "amplitude": float(abs(v)),
                                  "phase": float(np.angle(v))} for k, v in enumerate(c)]
            curves.append(Curve(name, info.encoder, ppr, grid, err, u,
                                PeriodHarmonics(np.arange(1, 9), c, np.zeros((16, 16))),
                                meta, [f"{name}: {w}" for w in fit.warnings]))
    return curves, fits


def corrected_counts(table, fits: dict[str, dict], names: Sequence[str]) -> dict[str, np.ndarray]:
    """Counts of each head with the interpolation redone from the corrected phase.

    The period index comes from the head's counts; the fraction from the
    Heydemann-corrected phase (the sample's phase nearest the counted one is
    taken, so a correction across a period boundary moves to the next period).
    """
    from enctools.data.readings import head_info
    from enctools.data.schemas import columns_with_role, field_meta
    from enctools.methods import heydemann as hd

    comps: dict[str, dict[str, str]] = {}
    for c in columns_with_role(table.schema, "signal"):
        fm = field_meta(table.schema.field(c))
        comps.setdefault(fm.get("head", ""), {})[fm.get("component", "")] = c
    out = {}
    for name in names:
        info = head_info(table.schema, name)
        f = fits[name]["signals"]
        comp = comps[name]
        if "cos" in comp:
            i, q = _column(table, comp["cos"]), _column(table, comp["sin"])
        else:
            i, q = hd.from_four_phase(*(_column(table, comp[k]) for k in ("0", "90", "180", "270")))
        phi = hd.corrected_phase(i, q, f["offset_cos_v"], f["offset_sin_v"], f["amplitude_v"],
                                 f["ratio"], f["phase_rad"])
        counts = _column(table, name).astype(np.int64)
        n = info.interpolation
        absolute = counts + info.zero_count
        frac = np.mod(phi, TWO_PI) * (n / TWO_PI)
        base = np.floor_divide(absolute, n) * n
        new = base + np.rint(frac).astype(np.int64)
        # choose the period so the corrected count is nearest the counted one
        new += n * np.rint((absolute - new) / n).astype(np.int64)
        out[name] = new - info.zero_count
    return out
