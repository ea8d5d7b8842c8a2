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

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .errors import DataError
from .readings import HeadInfo, head_angle, signal_phase
from .units import ARCSEC, TWO_PI


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
    [arcsec]; ``periods`` swept; ``landing`` (j, j * ratio, kept order) triples.
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
    """(angle [rad], signal phase [rad]) of a head or a head average.

    The average of heads of one encoder is periodic in that encoder's signal period
    as a function of the first head's phase (the heads sit at fixed phase offsets).
    """
    if len({i.periods_per_rev for i in infos}) > 1:
        names = ", ".join(i.name for i in infos)
        msg = f"heads {names} have different signal periods: average heads of one encoder"
        raise DataError(msg)
    angle = np.mean([head_angle(c, i) for c, i in zip(counts, infos)], axis=0)
    return angle, signal_phase(np.asarray(counts[0]), infos[0])


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
    phase = np.asarray(phase, dtype=np.float64)
    if positions is not None:
        _, inv = np.unique(np.asarray(positions), return_inverse=True)
        z = np.bincount(inv, np.cos(phase)) + 1j * np.bincount(inv, np.sin(phase))
        phase = np.angle(z)
    p = np.sort(np.mod(phase, TWO_PI))
    if p.size < 2:
        return 0
    gap = float(np.max(np.diff(np.append(p, p[0] + TWO_PI))))
    return int(np.floor(np.pi / gap - 1e-9)) if gap > 0 else p.size


def _trend_columns(x: np.ndarray, groups: np.ndarray, degree: int) -> np.ndarray:
    cols = []
    for g in np.unique(groups):
        m = groups == g
        xs = x[m]
        lo, hi = xs.min(), xs.max()
        z = np.zeros_like(x)
        z[m] = (xs - (lo + hi) / 2) / ((hi - lo) / 2 if hi > lo else 1.0)
        for d in range(degree + 1):
            col = np.zeros_like(x)
            col[m] = z[m] ** d
            cols.append(col)
    return np.column_stack(cols)


def fit_interpolation_error(device_rad: np.ndarray, device_phase: np.ndarray,
                            reference_rad: np.ndarray, periods_per_rev: int,
                            harmonics: int = 4, keep: Sequence[int] | None = None,
                            trend_degree: int = 1, groups: np.ndarray | None = None,
                            reference_phase: np.ndarray | None = None,
                            reference_orders: Sequence[int] = (),
                            reference_periods_per_rev: int | None = None,
                            positions: np.ndarray | None = None) -> InterpResult:
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
        Degree of the polynomial in the swept angle removed per group (run).
    groups : int array or None
        Group (run) of each sample; each has its own trend.
    reference_phase, reference_orders, reference_periods_per_rev :
        The reference encoder's signal phase [rad] and the orders of its own
        interpolation error to fit alongside (empty: none, the seed's plain filter).
    positions : array or None
        Commanded position of each sample (e.g. the sweep's target), so that
        repeated readings at one position count once when judging how finely the
        sweep samples the period (default: every sample is a position).

    Returns
    -------
    InterpResult. Raises DataError when the sweep is shorter than one signal period,
    has too few samples for the model, or the model cannot tell the device's
    harmonics from the reference's (near-collinear columns).
    """
    dev = np.asarray(device_rad, dtype=np.float64)
    ref = np.asarray(reference_rad, dtype=np.float64)
    phase0 = np.asarray(device_phase, dtype=np.float64)
    n = dev.size
    if not (ref.size == n and phase0.size == n):
        msg = "device, phase and reference differ in length"
        raise DataError(msg)
    groups = np.zeros(n, dtype=np.int64) if groups is None else np.asarray(groups)
    good = np.isfinite(dev) & np.isfinite(ref) & np.isfinite(phase0)
    if reference_phase is not None:
        reference_phase = np.asarray(reference_phase, dtype=np.float64)
        good &= np.isfinite(reference_phase)
    if not good.any():
        msg = "no sample with finite device and reference readings"
        raise DataError(msg)
    dev, ref, phase0, groups = dev[good], ref[good], phase0[good], groups[good]
    if reference_phase is not None:
        reference_phase = reference_phase[good]
    if positions is not None:
        positions = np.asarray(positions)[good]
    if harmonics < 1:
        msg = f"harmonics must be >= 1, not {harmonics}"
        raise DataError(msg)
    period = TWO_PI / periods_per_rev

    # Coverage: every group must sweep one signal period (to within a step).
    spans = []
    for g in np.unique(groups):
        x = np.sort(ref[groups == g])
        step = float(np.median(np.diff(np.unique(x)))) if np.unique(x).size > 1 else 0.0
        span = float(x[-1] - x[0])
        spans.append(span)
        if span + step < period * 0.999:
            msg = (f"the sweep covers {span / ARCSEC:.3g}\" but the signal period is "
                   f"{period / ARCSEC:.4g}\": sweep at least one period (--range)")
            raise DataError(msg)

    # Nyquist within the period: harmonics must be finer than the largest phase gap.
    k_max = resolvable_harmonics(phase0, positions)
    if harmonics > k_max:
        msg = (f"{harmonics} harmonics asked but the sweep samples the signal period "
               f"only finely enough for {k_max}: fit fewer (--band) or step finer")
        raise DataError(msg)
    orders = np.arange(1, harmonics + 1)
    keep = list(orders) if keep is None else [int(k) for k in keep]
    bad = [k for k in keep if k not in set(orders.tolist())]
    if bad:
        msg = f"kept harmonic {bad[0]} is not fitted (harmonics 1..{harmonics})"
        raise DataError(msg)
    ref_orders = np.asarray(list(reference_orders) if reference_phase is not None else [],
                            dtype=int)
    zeta = (dev - ref) / ARCSEC
    trend = _trend_columns(ref, groups, trend_degree)
    if ref_orders.size:
        ref_cols = PeriodHarmonics(ref_orders, np.zeros(ref_orders.size, complex),
                                   np.zeros((0, 0))).basis(reference_phase)
    else:
        ref_cols = np.zeros((dev.size, 0))
    n_dev = 2 * orders.size
    n_par = trend.shape[1] + n_dev + ref_cols.shape[1]
    if dev.size <= n_par:
        msg = (f"{dev.size} samples for {n_par} parameters: record more points "
               f"or fit fewer harmonics")
        raise DataError(msg)

    proto = PeriodHarmonics(orders, np.zeros(orders.size, complex), np.zeros((0, 0)))
    design = np.column_stack([trend, proto.basis(phase0), ref_cols])
    norms = np.linalg.norm(design, axis=0)
    norms[norms == 0] = 1.0
    a = design / norms
    sol, _, rank, sv = np.linalg.lstsq(a, zeta, rcond=None)
    cond = sv[0] / sv[-1] if sv[-1] > 0 else np.inf
    if rank < a.shape[1] or cond > 1e6:
        what = ("the reference's harmonics cannot be told from the device's over this sweep"
                if ref_cols.shape[1] else "the sweep does not determine every harmonic")
        msg = f"{what} (condition number {cond:.3g}); sweep longer or fit fewer harmonics"
        raise DataError(msg)
    coef = sol / norms
    resid = zeta - design @ coef
    dof = dev.size - n_par
    s2 = float(resid @ resid) / dof
    cov = np.linalg.inv(a.T @ a) * s2 / np.outer(norms, norms)
    nt = trend.shape[1]
    ab = coef[nt:nt + n_dev]
    fitted = PeriodHarmonics(orders, ab[0::2] - 1j * ab[1::2],
                             cov[nt:nt + n_dev, nt:nt + n_dev])
    gain = fitted.amplitude_u / max(np.sqrt(s2), 1e-300)
    if np.any(gain > 1.0):
        n_bad = int(orders[np.argmax(gain)])
        msg = (f"harmonic {n_bad} is undetermined by this sweep (its uncertainty exceeds "
               f"the scatter of one reading): fit fewer harmonics or sweep longer")
        raise DataError(msg)

    reference = None
    if ref_orders.size:
        cd = coef[nt + n_dev:]
        # zeta holds minus the reference's error
        reference = PeriodHarmonics(ref_orders, -(cd[0::2] - 1j * cd[1::2]),
                                    cov[nt + n_dev:, nt + n_dev:])
    result = InterpResult(error=fitted.select(keep), fitted=fitted, period=period,
                          samples=int(dev.size), periods=float(min(spans) / period),
                          residual_rms=float(np.sqrt(s2)), reference=reference)
    if reference_periods_per_rev is not None:
        result.ratio = period_ratio(periods_per_rev, reference_periods_per_rev)
        if reference_periods_per_rev != periods_per_rev:
            if ref_orders.size:
                # fitted alongside: separable when they differ by a cycle over the sweep
                result.landing = landing_harmonics(result.ratio, keep, ref_orders.tolist(),
                                                   tolerance=1.0 / result.periods)
            else:
                result.landing = landing_harmonics(result.ratio, keep)
            for j, at, k in result.landing:
                result.warnings.append(
                    f"the reference's harmonic {j} lands at {at:.3g} harmonics of the device "
                    f"period, on kept harmonic {k}: the filter cannot remove it "
                    f"over {result.periods:.3g} periods swept")
    return result


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


#: interp-check fits a sweep whole; a longer input (a continuous run) is refused
MAX_SWEEP_SAMPLES = 1_000_000


def read_sweep(source, max_samples: int = MAX_SWEEP_SAMPLES):
    """All of a sweep's readings as one Arrow table, refusing more than ``max_samples`` rows.

    A small-angle sweep has hundreds to thousands of samples and is fitted whole;
    the limit keeps a long continuous run piped in by mistake from filling the
    memory (reading stops at the first batch past it).
    """
    import pyarrow as pa

    from .errors import DataError

    batches = []
    rows = 0
    for b in source.batches():
        rows += b.num_rows
        if rows > max_samples:
            source.close()
            msg = (f"{source.source}: more than {max_samples:,} samples; interp-check fits a "
                   "small-angle sweep whole (enc acquire --mode sweep), not a long run: "
                   "record a sweep, or cut the run to fewer revolutions")
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
    from .schemas import columns_with_role, field_meta

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


def align_in_time(t: np.ndarray, t_ref: np.ndarray, values: Sequence[np.ndarray],
                  source: str) -> tuple[np.ndarray, list[np.ndarray]]:
    """Reference values interpolated to times ``t`` [s]; a mask of the rows covered.

    DataError when the two records do not overlap in time.
    """
    order = np.argsort(t_ref, kind="stable")
    tr = np.asarray(t_ref, float)[order]
    inside = (t >= tr[0]) & (t <= tr[-1])
    if not inside.any():
        msg = (f"{source}: covers t = {tr[0]:.6g}..{tr[-1]:.6g} s, the input "
               f"{np.min(t):.6g}..{np.max(t):.6g} s: no overlap in time")
        raise DataError(msg)
    return inside, [np.interp(t, tr, np.asarray(v, float)[order]) for v in values]


def check_readings(table, heads: Sequence[str] | None = None, average: bool = False,
                   reference: str = "probes", reference_table=None,
                   probes: Sequence[str] | None = None, arm_m: float | None = None,
                   harmonics: int | None = None, keep: Sequence[int] | None = None,
                   reference_harmonics: int = 2, trend_degree: int = 1,
                   points: int = 256, reference_source: str = "reference") -> list[Curve]:
    """Interpolation error of heads of a readings table against a reference.

    ``heads`` (default every head but the reference) are checked one by one, or
    averaged into one device with ``average``. ``reference``: "probes" or a head
    name, taken from ``reference_table`` (matched by time t) when given, else from
    ``table``. ``harmonics`` defaults to 4, or against an encoder of another signal
    period to the highest kept order (the device's higher harmonics are small and
    would share the sweep's few cycles with the reference's own error). See
    :func:`fit_interpolation_error` for the rest.
    """
    from .readings import head_info
    from .schemas import columns_with_role

    all_heads = columns_with_role(table.schema, "head")
    rtab = reference_table if reference_table is not None else table
    rsrc = reference_source if reference_table is not None else "input"
    t = _column(table, "t") if "t" in table.schema.names else None
    rows = np.ones(table.num_rows, dtype=bool)
    ref_phase = None
    ref_info = None
    if reference == "probes":
        ref_rad, ref_meta = probe_reference(rtab, probes, arm_m)
    else:
        ref_info = head_info(rtab.schema, reference, rsrc)
        rc = _column(rtab, reference)
        ref_rad = head_angle(rc, ref_info)
        ref_phase = signal_phase(rc, ref_info)
        ref_meta = {"reference": reference, "encoder": ref_info.encoder,
                    "periods_per_rev": ref_info.periods_per_rev}
    if reference_table is not None:
        if t is None or "t" not in rtab.schema.names:
            msg = f"{rsrc}: both streams need a time column t to be matched"
            raise DataError(msg)
        vals = [ref_rad] + ([np.unwrap(ref_phase)] if ref_phase is not None else [])
        rows, vals = align_in_time(t, _column(rtab, "t"), vals, rsrc)
        ref_rad = vals[0]
        if ref_phase is not None:
            ref_phase = np.mod(vals[1], TWO_PI)
        ref_meta["file"] = reference_source

    names = list(heads) if heads else [h for h in all_heads
                                       if not (reference_table is None and h == reference)]
    if not names:
        msg = "input: no head to check"
        raise DataError(msg)
    groups = _column(table, "run") if "run" in table.schema.names else None
    targets = _column(table, "target") if "target" in table.schema.names else None
    devices = [names] if average else [[n] for n in names]
    curves = []
    grid = np.linspace(0.0, TWO_PI, points, endpoint=False)
    for dev_names in devices:
        infos = [head_info(table.schema, n) for n in dev_names]
        dev_rad, dev_phase = device_reading([_column(table, n) for n in dev_names], infos)
        info = infos[0]
        name = dev_names[0] if len(dev_names) == 1 else "mean(" + ",".join(dev_names) + ")"
        if ref_info is not None and ref_info.name == info.name and reference_table is None:
            msg = f"--ref {reference} is the device itself; choose another head or probes"
            raise DataError(msg)
        other_period = ref_info is not None and ref_info.periods_per_rev != info.periods_per_rev
        k_keep = list(keep) if keep is not None else ([1, 2] if other_period else None)
        n_fit = harmonics if harmonics is not None else (max(k_keep) if other_period else 4)
        warnings = []
        if ref_info is not None and not other_period:
            warnings.append(f"{name}: the reference {ref_info.name} has the same signal period; "
                            f"the result is the difference of both heads' interpolation errors")
        r = fit_interpolation_error(
            dev_rad[rows], dev_phase[rows], ref_rad[rows], info.periods_per_rev,
            harmonics=n_fit, keep=k_keep, trend_degree=trend_degree,
            groups=None if groups is None else groups[rows],
            reference_phase=ref_phase[rows] if other_period else None,
            reference_orders=range(1, reference_harmonics + 1) if other_period else (),
            reference_periods_per_rev=ref_info.periods_per_rev if ref_info else None,
            positions=None if targets is None else targets[rows])
        warnings += [f"{name}: {w}" for w in r.warnings]
        fig = r.figures()
        meta = {"encoder": info.encoder, "heads": dev_names,
                "periods_per_rev": info.periods_per_rev,
                "period_arcsec": r.period / ARCSEC, "periods_swept": r.periods,
                "samples": r.samples, "residual_rms_arcsec": r.residual_rms,
                "kept": [int(n) for n in r.error.orders],
                "harmonics": _harmonics_meta(r.fitted), "figures": fig} | ref_meta
        if r.ratio is not None:
            meta["period_ratio"] = r.ratio
        if r.reference is not None:
            meta["reference_harmonics"] = _harmonics_meta(r.reference)
        curves.append(Curve(name, info.encoder, info.periods_per_rev, grid, r.error(grid),
                            r.error.uncertainty(grid), r.fitted, meta, warnings))
    return curves


def check_signals(table, heads: Sequence[str] | None = None, min_arc_deg: float = 90.0,
                  points: int = 256) -> tuple[list[Curve], dict]:
    """Heydemann fit of every head's raw signals; the interpolation error they predict.

    Signals are the role=signal columns of a head: components cos/sin, or the four
    phases 0/90/180/270. Returns the curves (error [arcsec] at the read phase, mean
    removed) and, per head, the fit (:meth:`EllipseFit.to_dict`) and the Lissajous
    radius variation.
    """
    from . import heydemann as hd
    from .readings import head_info
    from .schemas import columns_with_role, field_meta
    from .units import DEG

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
    from . import heydemann as hd
    from .readings import head_info
    from .schemas import columns_with_role, field_meta

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
