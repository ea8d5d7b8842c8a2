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

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from .errors import DataError
from .readings import HeadInfo
from .units import TWO_PI


def head_reading(counts: np.ndarray, counts_per_rev: int, zero_count: int,
                 alpha: float) -> np.ndarray:
    """A head's reading of the spindle angle theta [rad]: theta + its errors.

    The counter of a head at nominal angle ``alpha`` [rad] is zeroed at the grating
    line ``zero_count`` [count]; ``(counts + zero_count) * 2 pi / counts_per_rev`` is
    then the scale angle under the head, and subtracting ``alpha`` leaves the spindle
    angle plus the head's error (seed 000 eq. (1)).
    """
    c = np.asarray(counts, dtype=np.int64) + np.int64(zero_count)
    return c.astype(np.float64) * (TWO_PI / counts_per_rev) - alpha


def trapezoid_weights(x: np.ndarray) -> np.ndarray:
    """Trapezoid-rule weights [rad] of samples at ``x`` [rad] (monotonic either way)."""
    dx = np.abs(np.diff(x))
    w = np.empty_like(x)
    w[0] = dx[0] / 2
    w[-1] = dx[-1] / 2
    np.add(dx[:-1], dx[1:], out=w[1:-1])
    w[1:-1] *= 0.5
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

    The trapezoid sum ``sum_j w_j f(u_j) exp(-i n x_j)`` is evaluated block by block
    (:func:`_block_sums`): exact to rounding, about ten times fewer operations than
    the (K + 1) x S matrix of the direct sum, and in cache.
    """
    x = np.asarray(u, dtype=np.float64) - start
    v = np.atleast_2d(np.asarray(values, dtype=np.float64))
    w = trapezoid_weights(x)
    c = _block_sums(x, v, w, band)
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


#: truncation of the block expansion: the first neglected term is below this (relative)
_TAYLOR_EPS = 2.0 ** -56


def _block_sums(x: np.ndarray, v: np.ndarray, w: np.ndarray,
                band: int) -> np.ndarray | None:
    """``sum_j w_j v_cj exp(-i n x_j)``, n = 0..K, by local expansion in blocks of samples.

    In a block of L consecutive samples around its centre x_b (half-width h),
    ``exp(-i n x_j) = exp(-i n x_b) sum_p (-i n h)^p / p! s_j^p`` with
    ``s_j = (x_j - x_b) / h`` in [-1, 1]. Summing the series to P terms, where the
    first neglected one ``(K h)^P / P!`` is below 2^-56, leaves only rounding: the
    moments ``sum_j w_j v_cj s_j^p`` (C x B x P), a small matrix product with
    ``(-i n h)^p / p!`` and one phase per block. Returns None where this would not pay
    (few samples, or spacing so uneven that many terms are needed).
    """
    import math

    s1 = x.size
    if band == 0:
        return (v @ w)[:, None].astype(np.complex128)
    span = abs(float(x[-1] - x[0]))
    if s1 < 512 or span == 0.0:
        return None
    # blocks with K h about 1: ~19 terms
    step = span / (s1 - 1)
    block = int(2 ** np.clip(np.floor(np.log2(2.0 / (band * step))), 3, 8))
    nb = -(-s1 // block)
    if nb < 4:
        return None
    pad = nb * block - s1
    c = v.shape[0]
    # the weighted values w_j v_cj, padded with zeros to whole blocks
    g = np.empty((c, nb * block))
    np.multiply(v, w, out=g[:, :s1])
    g[:, s1:] = 0.0
    if pad:
        x = np.concatenate([x, np.full(pad, x[-1])])
    xb = x.reshape(nb, block)
    lo = xb.min(axis=1)
    hi = xb.max(axis=1)
    centre = (lo + hi) * 0.5
    h = float(np.max(hi - lo)) * 0.5
    if h == 0.0:
        return None
    z = band * h
    terms, last = 1, 1.0
    while last > _TAYLOR_EPS or terms <= z:
        last *= z / terms
        terms += 1
        if terms > 40:
            return None
    s = (xb - centre[:, None]) * (1.0 / h)
    # powers s^p, the even ones first: p = 0, 2, 4, ..., 1, 3, 5, ...
    order = np.concatenate([np.arange(0, terms, 2), np.arange(1, terms, 2)])
    ne = (terms + 1) // 2
    s2 = s * s
    spow = np.empty((terms, nb, block))
    spow[0] = 1.0
    for k in range(1, ne):
        np.multiply(spow[k - 1], s2, out=spow[k])
    np.multiply(spow[: terms - ne], s, out=spow[ne:])
    gb = g.reshape(c, nb, block).transpose(1, 0, 2)  # (B, C, L)
    moments = np.matmul(gb, spow.transpose(1, 2, 0))  # (B, C, P)
    n = np.arange(band + 1, dtype=np.float64)
    fact = np.array([math.factorial(k) for k in order], dtype=np.float64)
    # (-i n h)^p / p!: real for even p (sign (-1)^(p/2)), imaginary for odd p
    sign = np.array([1.0, -1.0, -1.0, 1.0])[order % 4]
    t = ((n[:, None] * h) ** order * (sign / fact)).T  # (P, K+1)
    # phases exp(-i n x_b) as exp(-i 10 m x_b) exp(-i r x_b), n = 10 m + r: rounding only
    tens = np.exp(-1j * np.outer(centre, np.arange(0, band + 1, 10)))
    ones = np.exp(-1j * np.outer(centre, np.arange(10)))
    e = (tens[:, :, None] * ones[:, None, :]).reshape(nb, -1)[:, : band + 1]  # (B, K+1)
    # r[c, p, n] = sum_b moments[b, c, p] exp(-i n x_b): two real products over the blocks
    mt = np.ascontiguousarray(moments.transpose(1, 2, 0)).reshape(c * terms, nb)
    r_re = (mt @ np.ascontiguousarray(e.real)).reshape(c, terms, band + 1)
    r_im = (mt @ np.ascontiguousarray(e.imag)).reshape(c, terms, band + 1)
    # out[c, n] = sum_p t[p, n] r[c, p, n], t real (even p) or imaginary (odd p)
    te, to = t[:ne], t[ne:]
    out = np.empty((c, band + 1), dtype=np.complex128)
    out.real = (r_re[:, :ne] * te).sum(axis=1) - (r_im[:, ne:] * to).sum(axis=1)
    out.imag = (r_im[:, :ne] * te).sum(axis=1) + (r_re[:, ne:] * to).sum(axis=1)
    return out


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
    ``pending`` says how much of a revolution it was.
    """

    def __init__(self) -> None:
        self.start: float | None = None
        self.direction = 0.0
        self.index = 0
        self._u = np.zeros(0)
        self._v: np.ndarray | None = None

    @property
    def pending(self) -> float:
        """Fraction of a revolution buffered but not complete."""
        if self._u.size == 0 or self.start is None:
            return 0.0
        return float(abs(self._u[-1] - self.start) / TWO_PI)

    def feed(self, u: np.ndarray, values: np.ndarray) -> Iterator[Revolution]:
        """Add a block (u: (S,) [rad]; values: (C, S)); yield the revolutions it completes."""
        if u.size == 0:
            return
        if self._v is None:
            self._u, self._v = u, values
            self.start = float(u[0])
        else:
            self._u = np.concatenate([self._u, u])
            self._v = np.concatenate([self._v, values], axis=1)
        if self.direction == 0.0:
            if self._u.size < 2:
                return
            self.direction = 1.0 if self._u[-1] > self._u[0] else -1.0
        d = self.direction
        assert self.start is not None
        while True:
            end = self.start + d * TWO_PI
            k = int(np.searchsorted(d * self._u, d * end, side="left"))
            if k >= self._u.size:
                return
            uu, vv = self._u, self._v
            if uu[k] == end:
                eu, ev = uu[k], vv[:, k]
                rest_u, rest_v = uu[k:], vv[:, k:]
            else:
                f = (end - uu[k - 1]) / (uu[k] - uu[k - 1])
                eu, ev = end, vv[:, k - 1] * (1.0 - f) + vv[:, k] * f
                rest_u = np.concatenate([[eu], uu[k:]])
                rest_v = np.concatenate([ev[:, None], vv[:, k:]], axis=1)
            ru = np.append(uu[:k], eu)
            rv = np.concatenate([vv[:, :k], ev[:, None]], axis=1)
            yield Revolution(self.index, self.start, ru, rv)
            self.index += 1
            self.start = end
            self._u, self._v = rest_u, rest_v

    def close(self, max_gap: float) -> Revolution | None:
        """The last revolution if it lacks at most ``max_gap`` [rad] at its end.

        A run of N revolutions sampled from t = 0 stops one sample short of the Nth
        turn; the gap is closed with the revolution's first sample (the channels are
        periodic). Returns None when more is missing.
        """
        if self._v is None or self.start is None or self._u.size < 3:
            return None
        end = self.start + self.direction * TWO_PI
        if abs(end - self._u[-1]) > max_gap:
            return None
        ru = np.append(self._u, end)
        rv = np.concatenate([self._v, self._v[:, :1]], axis=1)
        rev = Revolution(self.index, self.start, ru, rv)
        self.index += 1
        self._u, self._v = np.zeros(0), None
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
    """Coefficients with the harmonics above ``band`` set to zero (last axis = n)."""
    c = np.array(coefficients, dtype=np.complex128, copy=True)
    c[..., band + 1:] = 0
    return c


def synthesize(coefficients: np.ndarray, points: int) -> np.ndarray:
    """Curves ``Re(sum_n c_n exp(i n theta))`` on the grid theta_j = 2 pi j / points.

    ``coefficients``: (..., K + 1); returns (..., points). Needs points > 2 K.
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
    """Coefficients c_0..c_band of a curve sampled on a uniform grid over 2 pi."""
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


def revolution_spectra(batches: Iterator[object], spec: ChannelSpec, band: int,
                       source: str = "input", progress: object = None,
                       grid_points: int = 0) -> Iterator[tuple[int, np.ndarray, np.ndarray | None]]:
    """Per revolution of the coordinate, the spectra of each channel's error [rad].

    Reads readings batches (Arrow) one at a time; for each channel k yields the
    coefficients c_0..c_band of ``h_k(u) - u``, u the mean reading of the coordinate
    heads (:func:`head_reading`). Checks that ``t`` increases strictly and that the
    coordinate moves one way; nulls and NaN are errors. Memory holds one revolution.

    Yields ``(index, coefficients (C, band + 1), binned)``; ``binned`` is the
    (C, grid_points) bin average of the revolution when ``grid_points`` > 0.
    """
    splitter = RevolutionSplitter()
    last_t = -np.inf
    last_u: float | None = None
    spacing = np.inf
    for batch in batches:
        if batch.num_rows == 0:  # type: ignore[attr-defined]
            continue
        t = _column(batch, "t", source).astype(np.float64)
        if not (t[0] > last_t and np.all(np.diff(t) > 0)):
            where = int(np.argmax(np.diff(np.concatenate([[last_t], t])) <= 0))
            msg = (f"{source}: time t does not increase at sample {where} of a batch; "
                   "is this a continuous run, sorted by time?")
            raise DataError(msg)
        last_t = float(t[-1])
        u = np.mean([head_reading(_column(batch, h.name, source), h.counts_per_rev,
                                  h.zero_count, h.alpha) for h in spec.coordinate], axis=0)
        du = np.diff(u if last_u is None else np.concatenate([[last_u], u]))
        if splitter.direction == 0.0 and du.size:
            nonzero = du[du != 0]
            direction = np.sign(nonzero[0]) if nonzero.size else 0.0
        else:
            direction = splitter.direction
        if du.size and direction != 0 and not np.all(du * direction > 0):
            names = ", ".join(h.name for h in spec.coordinate)
            msg = (f"{source}: the angle coordinate (mean of {names}) stands still or turns "
                   "back; self-calibration and comparison need a continuous run in one direction")
            raise DataError(msg)
        last_u = float(u[-1])
        values = np.stack([head_reading(_column(batch, h.name, source), h.counts_per_rev,
                                        h.zero_count, h.alpha) - u for h in spec.channels])
        if spec.mean:
            values = values.mean(axis=0, keepdims=True)
        if du.size and not np.isfinite(spacing):
            _check_stroboscopic(float(np.median(np.abs(du[:4096]))), spec)
        # the typical step at the end of the batch (a median of its last samples)
        spacing = float(np.median(np.abs(du[-4096:]))) if du.size else spacing
        for rev in splitter.feed(u, values):
            yield _analyse(rev, band, grid_points)
            if progress is not None:
                progress(rev.index + 1)  # type: ignore[operator]
    last = splitter.close(2.5 * spacing) if np.isfinite(spacing) else None
    if last is not None:
        yield _analyse(last, band, grid_points)


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
