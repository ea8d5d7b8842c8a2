"""The harmonic core: time-sampled head readings to per-revolution spectra and back.

A continuous run samples every head at times t; the spindle angle theta(t) is not
known, so an *angle coordinate* u stands in for it: the reading of a reference head
or the mean of several heads (seed 000 eqs. (3), (6)). Every other channel is taken
as a function of u and each revolution of u (``[u0 + 2 pi r, u0 + 2 pi (r + 1))``)
is kept apart, so that methods can average revolutions and measure the spread
between them.

Per revolution the Fourier coefficients of a channel f(u) are the integral

    c_n = 1/pi * integral f(u) exp(-i n u) du        (c_0 = 1/(2 pi) * integral f du)

over the revolution, evaluated with the trapezoid rule on the (nearly uniform,
jittered) samples, the revolution's ends interpolated. This is the resampling onto a
uniform angle grid and the DFT in one step: unlike binning or decimating onto a
coarse grid, it does not alias the interpolation error (tens of thousands of cycles
per revolution) into the low harmonics. With the convention of
:mod:`enctools.truth`, ``f(u) = Re(sum_n c_n exp(i n u))`` and
``a cos(n u) + b sin(n u)`` has ``c_n = a - i b``.

Units: angles in rad; a channel's coefficients carry the channel's unit.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from enctools.data.readings import HeadInfo
from enctools.errors import DataError
from enctools.units import TWO_PI


def trapezoid_weights(x: np.ndarray) -> np.ndarray:
    """Trapezoid-rule weights [rad] of samples at ``x`` [rad] (monotonic either way)."""
    w = np.empty_like(x, dtype=np.float64)
    np.subtract(x[2:], x[:-2], out=w[1:-1])
    w[1:-1] *= 0.5
    w[0] = (x[1] - x[0]) * 0.5
    w[-1] = (x[-1] - x[-2]) * 0.5
    if x[-1] < x[0]:
        np.negative(w, out=w)
    return w


def revolution_coefficients(u: np.ndarray, values: np.ndarray, start: float,
                            band: int) -> np.ndarray:
    """Fourier coefficients c_0..c_band of channels over one revolution of ``u``.

    Parameters
    ----------
    u : (S,) angle coordinate [rad], monotonic, covering ``[start, start + 2 pi]``
        with its first and last samples exactly on the ends.
    values : (C, S) channel values (any unit) at ``u``.
    start : where the revolution starts [rad].
    band : highest harmonic K.

    Returns
    -------
    (C, K + 1) complex coefficients with ``f(u) = Re(sum c_n exp(i n u))``.

    The trapezoid sum ``sum_j w_j f(u_j) exp(-i n x_j)`` is evaluated bin by bin of
    angle (:func:`_binned_sums`): exact to rounding, a few passes over the samples
    and FFTs instead of the (K + 1) x S exponentials of the direct sum.
    """
    x = np.asarray(u, dtype=np.float64) - start
    v = np.atleast_2d(np.asarray(values, dtype=np.float64))
    w = trapezoid_weights(x)
    c = _binned_sums(x, v, w, band)
    if c is None:
        c = _direct_sums(x, v, w, band)
    c /= np.pi
    c[:, 0] /= 2.0
    # the integral ran over x = u - start: move the origin back to u = 0
    n = np.arange(band + 1)
    return c * np.exp(-1j * n * start)


def _direct_sums(x: np.ndarray, v: np.ndarray, w: np.ndarray, band: int) -> np.ndarray:
    """``sum_j w_j v_cj exp(-i n x_j)`` for n = 0..K from the full (K + 1) x S matrix."""
    base = np.exp(-1j * x)
    e = np.empty((band + 1, x.size), dtype=np.complex128)
    e[0] = w
    for n in range(1, band + 1):
        np.multiply(e[n - 1], base, out=e[n])
    return (e @ v.T).T


#: truncation of the local expansion: its first neglected term is below the unit roundoff
_TAYLOR_EPS = 2.0 ** -53
#: angle bins per harmonic kept (bin half-width h = pi / B: K h <= pi / 16) ...
BINS_PER_HARMONIC = 16
#: ... and at most about this many samples per bin (finer sampling: more, narrower bins)
SAMPLES_PER_BIN = 16


def _taylor_terms(z: float) -> int:
    """Terms P of the series of exp(-i z s), |s| <= 1, whose first neglected one is < 2^-53."""
    terms, last = 1, 1.0
    while last > _TAYLOR_EPS or terms <= z:
        last *= z / terms
        terms += 1
    return terms


@functools.lru_cache(maxsize=8)
def _expansion(band: int, h: float, terms: int) -> np.ndarray:
    """``(-i n h)^p / p!`` for p < P (rows) and n = 0..K (columns), times exp(-i n h)."""
    n = np.arange(band + 1, dtype=np.float64)
    fact = np.array([math.factorial(k) for k in range(terms)], dtype=np.float64)
    t = (-1j * h * n) ** np.arange(terms)[:, None] / fact[:, None]
    t *= np.exp(-1j * h * n)  # exp(-i n x_b) = exp(-2 pi i n b / B) exp(-i n h)
    t.flags.writeable = False
    return t


def _indices(n: int) -> np.ndarray:
    """0, 1, ..., n - 1 (read-only; one array kept for the longest n asked)."""
    global _INDICES
    if _INDICES.size < n:
        _INDICES = np.arange(max(n, 2 * _INDICES.size))
        _INDICES.flags.writeable = False
    return _INDICES[:n]


_INDICES = np.arange(0)


def _binned_sums(x: np.ndarray, v: np.ndarray, w: np.ndarray,
                 band: int) -> np.ndarray | None:
    """``sum_j w_j v_cj exp(-i n x_j)``, n = 0..K, by local expansion in bins of angle.

    ``x`` [rad] runs over one revolution, [0, 2 pi] or [-2 pi, 0], monotonic. The
    revolution is cut into B equal bins (half-width h = pi / B, centres
    x_b = (2 b + 1) h); in bin b
    ``exp(-i n x_j) = exp(-i n x_b) sum_p (-i n h)^p / p! s_j^p`` with
    ``s_j = (x_j - x_b) / h`` in [-1, 1], summed to P terms so that the first
    neglected one, ``(K h)^P / P!``, is below the unit roundoff: only rounding is
    left. What the samples contribute are the moments
    ``M_pcb = sum_(j in b) w_j v_cj s_j^p``; ``sum_b M_pcb exp(-i n x_b)`` is then a
    real FFT of length B, the centres being equally spaced. Per revolution: P passes
    over the samples and P FFTs, against (K + 1) complex exponentials per sample for
    the direct sum. Returns None where this does not pay (few samples) or the
    sampling is too uneven for the padded bin layout (a long stop).
    """
    s1 = x.size
    if band == 0:
        return (v @ w)[:, None].astype(np.complex128)
    nb = 1 << max(3, math.ceil(math.log2(band * BINS_PER_HARMONIC)),
                  math.ceil(math.log2(s1 / SAMPLES_PER_BIN)))
    if s1 < 256 or nb > 16 * s1:
        return None
    if x[-1] < x[0]:  # turning backwards: the same sums over x + 2 pi, increasing
        x, v, w = x[::-1] + TWO_PI, v[:, ::-1], w[::-1]
    h = math.pi / nb
    terms = _taylor_terms(band * h)
    # the bin of every sample (x >= 0 up to rounding: truncation is the floor) ...
    pos = x * (0.5 / h)
    b = pos.astype(np.intp)  # a first sample rounded below 0 truncates to bin 0
    if b[-1] >= nb:  # the last sample on 2 pi (or rounded past it) is in the last bin
        b[int(np.searchsorted(b, nb)):] = nb - 1
    # ... and s = (x - x_b) / h = 2 (pos - b) - 1
    s = pos
    s -= b
    s *= 2.0
    s -= 1.0
    counts = np.bincount(b, minlength=nb)
    width = int(counts.max())
    if nb * width > 4 * s1 + 4096:
        return None
    # padded layout (L, B): sample j of bin b goes to row j - first(b)
    first = np.cumsum(counts)
    first -= counts
    slot = first[b]
    np.subtract(_indices(s1), slot, out=slot)
    slot *= nb
    slot += b
    size = width * nb
    c = v.shape[0]
    g = np.zeros((c, size))
    g[:, slot] = v * w
    spow = np.empty((terms, size))
    spow[0] = 1.0
    spow[1] = 0.0
    spow[1, slot] = s
    for k in range(2, terms):
        np.multiply(spow[k - 1], spow[1], out=spow[k])
    moments = np.einsum("clb,plb->pcb", g.reshape(c, width, nb),
                        spow.reshape(terms, width, nb))  # (P, C, B)
    f = np.fft.rfft(moments, axis=-1)[..., : band + 1]  # sum_b M exp(-2 pi i n b / B)
    return np.einsum("pcn,pn->cn", f, _expansion(band, h, terms))


@dataclass
class Revolution:
    """One revolution of channels against the angle coordinate.

    ``u``: coordinate samples [rad], the ends on ``start`` and ``start +/- 2 pi``;
    ``values``: (C, S) channels.
    """

    index: int
    start: float
    u: np.ndarray
    values: np.ndarray


class RevolutionSplitter:
    """Cut a stream of (u, values) blocks into whole revolutions of u.

    Feed blocks in order (u strictly monotonic, checked by the caller); each
    complete revolution is yielded with its end interpolated linearly onto the
    boundary, which also starts the next one. The first revolution starts at the
    first sample. What is left at the end (less than a revolution) is not yielded;
    ``pending`` says how much of a revolution it was. Blocks are held as views and
    copied once, into the revolution they complete.
    """

    def __init__(self) -> None:
        self.start: float | None = None
        self.direction = 0.0
        self.index = 0
        self._u: list[np.ndarray] = []
        self._v: list[np.ndarray] = []

    @property
    def pending(self) -> float:
        """Fraction of a revolution buffered but not complete."""
        if not self._u or self.start is None:
            return 0.0
        return float(abs(self._u[-1][-1] - self.start) / TWO_PI)

    def feed(self, u: np.ndarray, values: np.ndarray) -> Iterator[Revolution]:
        """Add a block (u: (S,) [rad]; values: (C, S)); yield the revolutions it completes."""
        if u.size == 0:
            return
        if self.start is None:
            self.start = float(u[0])
        if self.direction == 0.0:
            if u[-1] == self.start:
                self._u.append(u)
                self._v.append(values)
                return
            self.direction = 1.0 if u[-1] > self.start else -1.0
        d = self.direction
        key = u if d > 0 else -u  # ascending, for searchsorted
        lo = 0
        while True:
            end = self.start + d * TWO_PI
            k = lo + int(np.searchsorted(key[lo:], d * end, side="left"))
            if k >= u.size:
                self._u.append(u[lo:])
                self._v.append(values[:, lo:])
                return
            if u[k] == end:
                eu, ev = u[k: k + 1], values[:, k: k + 1]
                nxt_u, nxt_v, nlo = [], [], k
            else:
                pu, pv = ((u[k - 1], values[:, k - 1]) if k > lo
                          else (self._u[-1][-1], self._v[-1][:, -1]))
                f = (end - pu) / (u[k] - pu)
                eu = np.array([end])
                ev = (pv * (1.0 - f) + values[:, k] * f)[:, None]
                nxt_u, nxt_v, nlo = [eu], [ev], k
            ru = np.concatenate(self._u + [u[lo:k], eu])
            rv = np.concatenate(self._v + [values[:, lo:k], ev], axis=1)
            yield Revolution(self.index, self.start, ru, rv)
            self.index += 1
            self.start = end
            self._u, self._v, lo = nxt_u, nxt_v, nlo

    def close(self, max_gap: float) -> Revolution | None:
        """The last revolution if it lacks at most ``max_gap`` [rad] at its end.

        A run of N revolutions sampled from t = 0 stops one sample short of the Nth
        turn; the gap is closed with the revolution's first sample (the channels are
        periodic). Returns None when more is missing.
        """
        if self.start is None or sum(p.size for p in self._u) < 3:
            return None
        end = self.start + self.direction * TWO_PI
        if abs(end - self._u[-1][-1]) > max_gap:
            return None
        ru = np.concatenate(self._u + [np.array([end])])
        rv = np.concatenate(self._v + [self._v[0][:, :1]], axis=1)
        rev = Revolution(self.index, self.start, ru, rv)
        self.index += 1
        self._u, self._v = [], []
        return rev


class RunningMean:
    """Mean and spread of arrays of a fixed shape, one per revolution (Welford).

    Memory does not grow with the number of revolutions. ``sem_re``/``sem_im`` are
    the standard uncertainties of the mean of the real/imaginary parts.
    """

    def __init__(self) -> None:
        self.count = 0
        self.mean: np.ndarray | None = None
        self._m2_re: np.ndarray | None = None
        self._m2_im: np.ndarray | None = None

    def add(self, x: np.ndarray) -> None:
        x = np.asarray(x)
        self.count += 1
        if self.mean is None:
            self.mean = x.astype(np.complex128 if np.iscomplexobj(x) else np.float64).copy()
            self._m2_re = np.zeros(x.shape)
            self._m2_im = np.zeros(x.shape)
            return
        d = x - self.mean
        self.mean = self.mean + d / self.count
        d2 = x - self.mean
        self._m2_re += d.real * d2.real
        self._m2_im += np.imag(d) * np.imag(d2)

    def variance(self) -> tuple[np.ndarray, np.ndarray]:
        """Sample variances (re, im) between revolutions; NaN with fewer than 2."""
        if self.count < 2 or self._m2_re is None:
            shape = () if self.mean is None else self.mean.shape
            return np.full(shape, np.nan), np.full(shape, np.nan)
        return self._m2_re / (self.count - 1), self._m2_im / (self.count - 1)

    def sem(self) -> np.ndarray:
        """Standard uncertainty of the mean per component, pooled over re and im.

        For complex values: sqrt((var re + var im) / 2 / count), the standard
        uncertainty of the real part, of the imaginary part and (for a harmonic well
        above the noise) of the amplitude. For real values: sqrt(var / count).
        """
        vr, vi = self.variance()
        if self.mean is not None and np.iscomplexobj(self.mean):
            return np.sqrt((vr + vi) / 2.0 / self.count)
        return np.sqrt(vr / self.count)


def band_limit(coefficients: np.ndarray, band: int) -> np.ndarray:
    """Coefficients (any unit) with the harmonics above ``band`` set to zero (last axis = n)."""
    c = np.array(coefficients, dtype=np.complex128, copy=True)
    c[..., band + 1:] = 0
    return c


def synthesize(coefficients: np.ndarray, points: int) -> np.ndarray:
    """Curves ``Re(sum_n c_n exp(i n theta))`` on the grid theta_j = 2 pi j / points [rad].

    ``coefficients``: (..., K + 1) in the curve's unit (arcsec, rad, nm); returns
    (..., points) in that unit. Needs points > 2 K.
    """
    c = np.asarray(coefficients, dtype=np.complex128)
    k = c.shape[-1] - 1
    if points <= 2 * k:
        msg = f"a grid of {points} points cannot carry {k} harmonics (needs > {2 * k})"
        raise ValueError(msg)
    spec = np.zeros(c.shape[:-1] + (points // 2 + 1,), dtype=np.complex128)
    spec[..., : k + 1] = c * (points / 2.0)
    spec[..., 0] = c[..., 0].real * points
    return np.fft.irfft(spec, points, axis=-1)


def analyse(curve: np.ndarray, band: int) -> np.ndarray:
    """Coefficients c_0..c_band (the curve's unit) of a curve on a uniform grid over 2 pi [rad]."""
    y = np.asarray(curve, dtype=np.float64)
    m = y.shape[-1]
    if band >= m / 2:
        msg = f"a grid of {m} points carries harmonics below {m / 2:g}, not {band}"
        raise ValueError(msg)
    spec = np.fft.rfft(y, axis=-1)[..., : band + 1] * (2.0 / m)
    spec[..., 0] /= 2.0
    return spec


def grid(points: int) -> np.ndarray:
    """The uniform angle grid theta_j = 2 pi j / points [rad]."""
    return np.arange(points) * (TWO_PI / points)


def amplitude_phase(coefficients: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Amplitude and phase p [rad] of each harmonic: ``amplitude * cos(n x + p)``."""
    c = np.asarray(coefficients)
    return np.abs(c), np.angle(c)


def bin_average(u: np.ndarray, values: np.ndarray, points: int) -> np.ndarray:
    """Mean of the samples in each of ``points`` equal bins of angle ``u`` mod 2 pi.

    Unfiltered curves (no band limit) are shown this way; bin j covers
    ``[2 pi j / points, 2 pi (j + 1) / points)``; a bin without samples is NaN.
    ``u`` [rad], ``values`` (C, S); returns (C, points).
    """
    idx = np.minimum((np.mod(u, TWO_PI) * (points / TWO_PI)).astype(np.int64), points - 1)
    v = np.atleast_2d(values)
    out = np.full((v.shape[0], points), np.nan)
    counts = np.bincount(idx, minlength=points)
    has = counts > 0
    for i in range(v.shape[0]):
        s = np.bincount(idx, weights=v[i], minlength=points)
        out[i, has] = s[has] / counts[has]
    return out


def _column(batch: object, name: str, source: str) -> np.ndarray:
    """A column of an Arrow batch as numpy, refusing nulls and NaN."""
    col = batch.column(name)  # type: ignore[attr-defined]
    if col.null_count:
        msg = f"{source}: column {name!r} has {col.null_count} missing values"
        raise DataError(msg)
    arr = col.to_numpy(zero_copy_only=False)
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        msg = f"{source}: column {name!r} has NaN or infinite values"
        raise DataError(msg)
    return arr


@dataclass(frozen=True)
class ChannelSpec:
    """What :func:`revolution_spectra` reads: channels against a coordinate.

    ``channels``: heads whose error relative to the coordinate is analysed;
    ``coordinate``: heads whose mean reading is the angle coordinate;
    ``mean``: analyse only the mean of the channels (one spectrum: the mean of
    theirs, the transform being linear, for a fraction of the work).
    """

    channels: tuple[HeadInfo, ...]
    coordinate: tuple[HeadInfo, ...]
    mean: bool = False


def mean_reading(batch: object, heads: tuple[HeadInfo, ...], source: str = "input",
                 minus: np.ndarray | None = None) -> np.ndarray:
    """The mean of the heads' readings [rad] (``readings.head_reading``) over a batch.

    Counts are summed into one float64 array (exact below 2^53 counts) and scaled
    once per counts-per-revolution; ``minus`` [rad] is subtracted in place. A few
    passes over the batch, however many heads.
    """
    out: np.ndarray | None = None
    m = len(heads)
    offset = 0.0
    for cpr in dict.fromkeys(h.counts_per_rev for h in heads):
        group = [h for h in heads if h.counts_per_rev == cpr]
        acc = _column(batch, group[0].name, source).astype(np.float64)
        for h in group[1:]:
            acc += _column(batch, h.name, source)
        acc *= TWO_PI / (cpr * m)
        offset += sum(h.zero_count * (TWO_PI / cpr) - h.alpha for h in group) / m
        if out is None:
            out = acc
        else:
            out += acc
    assert out is not None
    out += offset
    if minus is not None:
        out -= minus
    return out


def _times(batch: object, source: str) -> tuple[np.ndarray, bool]:
    """Column t [s] as numpy, refusing nulls, NaN and infinities; and whether it rises.

    Rising samples with finite ends are all finite: the full check runs only when
    this quick one fails.
    """
    col = batch.column("t")  # type: ignore[attr-defined]
    if col.null_count:
        msg = f"{source}: column 't' has {col.null_count} missing values"
        raise DataError(msg)
    t = col.to_numpy(zero_copy_only=False)
    if bool(np.all(t[1:] > t[:-1])) and np.isfinite(t[0]) and np.isfinite(t[-1]):
        return t, True
    return _column(batch, "t", source), False


@dataclass
class BatchChannels:
    """One readings batch as :func:`revolution_spectra` reads it (see :func:`batch_channels`).

    ``t`` [s]; ``u``: the angle coordinate [rad]; ``values``: (C, S) channels minus u
    [rad]; ``t_rising``: t increases strictly within the batch; ``u_sense``: +1 or -1
    when u rises or falls strictly within the batch, else 0.
    """

    t: np.ndarray
    u: np.ndarray
    values: np.ndarray
    t_rising: bool
    u_sense: int


def batch_channels(batch: object, spec: ChannelSpec, source: str = "input") -> BatchChannels | None:
    """The per-batch half of :func:`revolution_spectra` (None for an empty batch).

    It needs nothing of the batches before it, so a reader thread can run it
    (``InputStream.batches(prepare=...)``) while the revolutions are analysed.
    """
    n = batch.num_rows  # type: ignore[attr-defined]
    if n == 0:
        return None
    t, rising = _times(batch, source)
    u = mean_reading(batch, spec.coordinate, source)
    if spec.mean:
        values = mean_reading(batch, spec.channels, source, minus=u)[None, :]
    else:
        values = np.empty((len(spec.channels), n))
        for i, h in enumerate(spec.channels):
            values[i] = mean_reading(batch, (h,), source, minus=u)
    sense = 1 if bool(np.all(u[1:] > u[:-1])) else -1 if bool(np.all(u[1:] < u[:-1])) else 0
    return BatchChannels(t, u, values, rising, sense if n > 1 else 0)


class RevolutionCutter:
    """The sequential half of :func:`revolution_spectra`: checks across batches, and
    the cut into whole revolutions of the coordinate.

    Call it on each readings batch in order, on any one thread (e.g. a reader
    thread: ``InputStream.batches(prepare=cutter)``); it returns the revolutions the
    batch completes. :meth:`finish` after the last batch gives the last revolution
    if only a sample's gap is missing.
    """

    def __init__(self, spec: ChannelSpec, source: str = "input") -> None:
        self.spec = spec
        self.source = source
        self._splitter = RevolutionSplitter()
        self._last_t = -np.inf
        self._last_u: float | None = None
        self._direction = 0
        self._spacing = np.inf

    def __call__(self, batch: object) -> list[Revolution]:
        b = batch_channels(batch, self.spec, self.source)
        if b is None:
            return []
        t, u, n = b.t, b.u, b.u.size
        if not (t[0] > self._last_t and b.t_rising):
            where = int(np.argmax(np.diff(np.concatenate([[self._last_t], t])) <= 0))
            msg = (f"{self.source}: time t does not increase at sample {where} of a batch; "
                   "is this a continuous run, sorted by time?")
            raise DataError(msg)
        self._last_t = float(t[-1])
        last_u = self._last_u
        first = u[0] if last_u is None else last_u
        if self._direction == 0 and u[-1] != first:
            self._direction = 1 if u[-1] > first else -1
        d = self._direction
        steady = last_u is None or (u[0] > first if d > 0 else u[0] < first)
        if not steady or (n > 1 and (d == 0 or b.u_sense != d)):
            names = ", ".join(h.name for h in self.spec.coordinate)
            msg = (f"{self.source}: the angle coordinate (mean of {names}) stands still or "
                   "turns back; self-calibration and comparison need a continuous run in "
                   "one direction")
            raise DataError(msg)
        if n > 1 and not np.isfinite(self._spacing):
            _check_stroboscopic(float(np.median(np.abs(np.diff(u[:4097])))), self.spec)
        if n > 1:  # the mean step over the batch
            self._spacing = abs(float(u[-1] - u[0])) / (n - 1)
        self._last_u = float(u[-1])
        return list(self._splitter.feed(u, b.values))

    def finish(self) -> list[Revolution]:
        """The last revolution, if it lacks at most 2.5 sample steps (see close())."""
        if not np.isfinite(self._spacing):
            return []
        last = self._splitter.close(2.5 * self._spacing)
        return [last] if last is not None else []


def revolution_spectra(batches: Iterator[object], spec: ChannelSpec, band: int,
                       source: str = "input", progress: object = None,
                       grid_points: int = 0, cutter: RevolutionCutter | None = None
                       ) -> Iterator[tuple[int, np.ndarray, np.ndarray | None]]:
    """Per revolution of the coordinate, the spectra of each channel's error [rad].

    Reads readings batches (Arrow) one at a time, or the lists of revolutions that
    ``cutter`` made of them ahead (on a reader thread); for each channel k yields the
    coefficients c_0..c_band of ``h_k(u) - u``, u the mean reading of the coordinate
    heads (``readings.head_reading``). Checks that ``t`` increases strictly and that the
    coordinate moves one way; nulls and NaN are errors. Memory holds one revolution.

    Yields ``(index, coefficients (C, band + 1), binned)``; ``binned`` is the
    (C, grid_points) bin average of the revolution when ``grid_points`` > 0.
    """
    cut = cutter if cutter is not None else RevolutionCutter(spec, source)
    for item in batches:
        for rev in item if isinstance(item, list) else cut(item):
            yield _analyse(rev, band, grid_points)
            if progress is not None:
                progress(rev.index + 1)  # type: ignore[operator]
    for rev in cut.finish():
        yield _analyse(rev, band, grid_points)


#: a sample step within this many signal periods of a whole number is "stroboscopic"
STROBOSCOPIC = 0.05


def stroboscopic_heads(step: float, heads: tuple[HeadInfo, ...]) -> list[tuple[str, float]]:
    """Heads whose signal phase barely moves from one sample to the next.

    ``step``: angle between samples [rad]. When it is within :data:`STROBOSCOPIC` of
    a whole number of signal periods, every sample meets the head's interpolation
    error at nearly the same phase: speed jitter then turns it into low harmonics
    that no averaging removes (seed 000 assumes them high-frequency). Returns
    (head, periods per sample).
    """
    out = []
    for h in heads:
        periods = step * h.periods_per_rev / TWO_PI
        if abs(periods - round(periods)) < STROBOSCOPIC and periods > 0.5:
            out.append((h.name, periods))
    return out


def _check_stroboscopic(step: float, spec: ChannelSpec) -> None:
    import logging

    seen = {h.name: h for h in spec.channels + spec.coordinate}
    bad = stroboscopic_heads(step, tuple(seen.values()))
    if bad:
        names = ", ".join(f"{n} ({p:.3f} signal periods per sample)" for n, p in bad)
        logging.getLogger("enctools").warning(
            "sampling is nearly synchronous with the signal period of %s: their "
            "interpolation error aliases into low harmonics; record with another "
            "sample interval (enc acquire --interval)", names)


def _analyse(rev: Revolution, band: int,
             grid_points: int) -> tuple[int, np.ndarray, np.ndarray | None]:
    coef = revolution_coefficients(rev.u, rev.values, rev.start, band)
    binned = bin_average(rev.u[:-1], rev.values[:, :-1], grid_points) if grid_points else None
    return rev.index, coef, binned
