"""The harmonic core: samples over one revolution to spectra, and spectra to curves.

Array maths only; :mod:`enctools.methods.revolutions` reads the readings streams
and cuts them into the revolutions analysed here.

Per revolution of an angle coordinate u the Fourier coefficients of a channel f(u)
are the integral

    c_n = 1/pi * integral f(u) exp(-i n u) du        (c_0 = 1/(2 pi) * integral f du)

over the revolution, evaluated with the trapezoid rule on the (nearly uniform,
jittered) samples, the revolution's ends interpolated. This is the resampling onto a
uniform angle grid and the DFT in one step: unlike binning or decimating onto a
coarse grid, it does not alias the interpolation error (tens of thousands of cycles
per revolution) into the low harmonics. With the convention of
:mod:`enctools.data.truth`, ``f(u) = Re(sum_n c_n exp(i n u))`` and
``a cos(n u) + b sin(n u)`` has ``c_n = a - i b``.

Units: angles in rad; a channel's coefficients carry the channel's unit.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from enctools import kernel
from enctools.errors import SettingsError
from enctools.units import TWO_PI


def check_grid(points: int, band: int) -> None:
    """SettingsError unless a grid of ``points`` points carries harmonics 1..``band``.

    A curve of K harmonics needs more than 2 K points (:func:`synthesize`); the
    message names the fields `points` and `band`.
    """
    if points <= 2 * band:
        msg = f"`points` {points} cannot carry `band` {band}: give more than {2 * band}"
        raise SettingsError(msg)


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


def revolution_coefficients(u: np.ndarray, values: np.ndarray | tuple[np.ndarray, ...],
                            start: float, band: int, shift: FourierSeries | None = None,
                            minus: np.ndarray | None = None) -> np.ndarray:
    """Fourier coefficients c_0..c_band of channels over one revolution of ``u``.

    Parameters
    ----------
    u : (S,) angle coordinate [rad], monotonic, covering ``[start, start + 2 pi]``
        with its first and last samples exactly on the ends.
    values : (C, S) channel values (any unit) at ``u``, or a tuple of (C, S_i) pieces
        whose join along the samples they are (the compiled kernel reads them in place).
    start : where the revolution starts [rad].
    band : highest harmonic K.
    shift : the samples' angles are ``u - shift(u)`` [rad] (an angle map's correction,
        ``start`` then being that angle's start); None: ``u`` itself.
    minus : (C,) taken off each channel's values first (their unit), without changing
        ``values``; None: nothing.

    Returns
    -------
    (C, K + 1) complex coefficients with ``f(u) = Re(sum c_n exp(i n u))``.

    The trapezoid sum ``sum_j w_j f(u_j) exp(-i n x_j)`` is evaluated bin by bin of
    angle (:func:`_binned_sums`): exact to rounding, a few passes over the samples
    and FFTs instead of the (K + 1) x S exponentials of the direct sum. The compiled
    kernel (:mod:`enctools.kernel`) makes the angles and the bins' moments in one pass.
    """
    parts = values if isinstance(values, tuple) else (values,)
    parts = tuple(np.atleast_2d(np.asarray(p, dtype=np.float64)) for p in parts)
    c = _kernel_sums(u, parts, start, band, shift, minus)
    if c is None:
        v = parts[0] if len(parts) == 1 else np.concatenate(parts, axis=1)
        if minus is not None:
            v = v - np.asarray(minus, dtype=np.float64)[:, None]
        theta = np.asarray(u, dtype=np.float64) if shift is None else u - shift(u)
        x = theta - start
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
    if band == 0:
        return (v @ w)[:, None].astype(np.complex128)
    nb = _bins(band, x.size)
    if x.size < 256 or nb > 16 * x.size:
        return None
    if x[-1] < x[0]:  # turning backwards: the same sums over x + 2 pi, increasing
        x, v, w = x[::-1] + TWO_PI, v[:, ::-1], w[::-1]
    h = math.pi / nb
    layout = _bin_layout(x, nb)
    if layout is None:
        return None
    terms = _taylor_terms(band * h)
    return _combined(_bin_moments(v * w, layout, terms), band, h)  # moments: (P, C, B)


def _bins(band: int, samples: int) -> int:
    """B, the bins of :func:`_binned_sums` for harmonics 0..``band`` over ``samples``."""
    return 1 << max(3, math.ceil(math.log2(band * BINS_PER_HARMONIC)),
                    math.ceil(math.log2(samples / SAMPLES_PER_BIN)))


def _combined(moments: np.ndarray, band: int, h: float) -> np.ndarray:
    """``sum_b M_pcb exp(-i n x_b)`` of moments (P, C, B) summed over p: (C, K + 1)."""
    f = np.fft.rfft(moments, axis=-1)[..., : band + 1]  # sum_b M exp(-2 pi i n b / B)
    return np.einsum("pcn,pn->cn", f, _expansion(band, h, moments.shape[0]))


def _kernel_sums(u: np.ndarray, parts: tuple[np.ndarray, ...], start: float, band: int,
                 shift: FourierSeries | None, minus: np.ndarray | None = None
                 ) -> np.ndarray | None:
    """:func:`_binned_sums` of the samples at ``u - shift(u) - start`` [rad] of the channels
    held in ``parts`` ((C, S_i) pieces, joined along the samples; ``minus`` (C,) taken off
    each), the angles, weights and moments made in one pass of the compiled kernel; None
    where it is not installed or leaves the choice to the numpy passes (falling angles, few
    samples, bins too unevenly filled)."""
    lib = kernel.library()
    size, channels = u.size, parts[0].shape[0]
    if (lib is None or band == 0 or size < 256
            or any(p.shape[0] != channels or (p.shape[1] > 1 and p.strides[1] != p.itemsize)
                   for p in parts)):
        return None
    nb = _bins(band, size)
    h = math.pi / nb
    terms = _taylor_terms(band * h)
    if nb > 16 * size or channels > kernel.MAX_CHANNELS or terms > kernel.MAX_TERMS:
        return None
    u = np.ascontiguousarray(u, dtype=np.float64)
    lengths = np.array([p.shape[1] for p in parts], dtype=np.int64)
    rows = np.array([p.ctypes.data + k * p.strides[0] for p in parts for k in range(channels)],
                    dtype=np.uintp)
    if minus is not None:
        minus = np.ascontiguousarray(minus, dtype=np.float64)
    table = None if shift is None else shift.by_bin
    moments, angles = np.empty((terms, channels, nb)), np.empty(size)  # all written
    rc = lib.enc_rev_moments(
        size, u.ctypes.data, channels, len(parts), lengths.ctypes.data, rows.ctypes.data,
        None if minus is None else minus.ctypes.data,
        None if table is None else table.ctypes.data, 0 if table is None else table.shape[1],
        0 if table is None else table.shape[0], start, nb, terms, angles.ctypes.data,
        moments.ctypes.data)
    return _combined(moments, band, h) if rc == 0 else None


@dataclass
class _BinLayout:
    """Where each sample of a revolution goes in the padded (L, B) layout of its bins.

    ``slot``: flat index row * B + bin of each sample (row: its place in its bin);
    ``s``: its offset from the bin centre in half-widths, in [-1, 1]; ``rows``: L,
    the most samples in one bin; ``bins``: B.
    """

    slot: np.ndarray
    s: np.ndarray
    rows: int
    bins: int


def _bin_layout(x: np.ndarray, nb: int) -> _BinLayout | None:
    """The padded layout of samples ``x`` [rad] (increasing over [0, 2 pi]) in ``nb`` bins.

    None when the bins are too unevenly filled for padding to pay (a long stop).
    """
    s1 = x.size
    # the bin of every sample (x >= 0 up to rounding: truncation is the floor) ...
    pos = x * (nb / TWO_PI)
    b = pos.astype(np.intp)  # a first sample rounded below 0 truncates to bin 0
    if b[-1] >= nb:  # the last sample on 2 pi (or rounded past it) is in the last bin
        b[int(np.searchsorted(b, nb)):] = nb - 1
    counts = np.bincount(b, minlength=nb)
    width = int(counts.max())
    if nb * width > 4 * s1 + 4096:
        return None
    # ... and s = (x - x_b) / h = 2 (pos - b) - 1
    s = pos
    s -= b
    s *= 2.0
    s -= 1.0
    # padded layout (L, B): sample j of bin b goes to row j - first(b)
    first = np.cumsum(counts)
    first -= counts
    slot = first[b]
    np.subtract(_indices(s1), slot, out=slot)
    slot *= nb
    slot += b
    return _BinLayout(slot, s, width, nb)


def _bin_moments(weighted: np.ndarray, layout: _BinLayout, terms: int) -> np.ndarray:
    """Moments ``M_pcb = sum_(j in b) weighted_cj s_j^p`` (P, C, B) of (C, S) ``weighted``."""
    size = layout.rows * layout.bins
    c = weighted.shape[0]
    g = np.zeros((c, size))
    g[:, layout.slot] = weighted
    spow = np.empty((terms, size))
    spow[0] = 1.0
    spow[1] = 0.0
    spow[1, layout.slot] = layout.s
    for k in range(2, terms):
        np.multiply(spow[k - 1], spow[1], out=spow[k])
    return np.einsum("clb,plb->pcb", g.reshape(c, layout.rows, layout.bins),
                     spow.reshape(terms, layout.rows, layout.bins))


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
    spec = np.zeros((*c.shape[:-1], points // 2 + 1), dtype=np.complex128)
    spec[..., : k + 1] = c * (points / 2.0)
    spec[..., 0] = c[..., 0].real * points
    return np.fft.irfft(spec, points, axis=-1)


class FourierSeries:
    """A curve ``Re(sum_n c_n exp(i n x))`` evaluated at any angles x [rad], exact to rounding.

    ``coefficients`` c_0..c_K in the curve's unit. The turn is cut into B equal bins
    (half-width h = pi / B, centres x_b = (2 b + 1) h); in bin b the curve is the
    polynomial ``sum_p Q_pb s^p`` in ``s = (x - x_b) / h``, with
    ``Q_pb = Re sum_n c_n (i n h)^p / p! exp(i n x_b)``, made once by P inverse FFTs
    (the transpose of :func:`_binned_sums`). P is the fewest terms whose first neglected
    one, ``sum_n |c_n| (n h)^P / P!``, is below the unit roundoff of ``sum_n |c_n|``.
    Each evaluation is then P gathers and multiply-adds per angle. ``slope``: one term
    more, for :meth:`slope`.
    """

    def __init__(self, coefficients: np.ndarray, slope: bool = False) -> None:
        c = np.asarray(coefficients, dtype=np.complex128)
        band = c.size - 1
        self.bins = 1 << max(6, math.ceil(math.log2(64 * (band + 1))))
        h = math.pi / self.bins
        n = np.arange(band + 1)
        size = np.abs(c)
        total = float(size.sum()) or 1.0
        term, terms = size.copy(), 1
        while float(term.sum()) > _TAYLOR_EPS * total and terms < 40:
            term = term * (n * h) / terms
            terms += 1
        terms += slope
        shift = c * np.exp(1j * n * h)
        table = np.empty((terms, self.bins))
        for p in range(terms):
            table[p] = synthesize(shift, self.bins)
            shift = shift * (1j * n * h) / (p + 1)
        self.table = table

    @functools.cached_property
    def by_bin(self) -> np.ndarray:
        """The table transposed, (bins, terms): one bin's terms side by side, as the
        compiled kernel reads them."""
        return np.ascontiguousarray(self.table.T)

    def slope(self) -> FourierSeries:
        """The curve's derivative [its unit/rad] from the same table: in bin b the
        derivative of ``sum_p Q_pb s^p`` is ``sum_p (p + 1) / h Q_(p+1)b s^p`` (exact to
        rounding when made with ``slope=True``)."""
        out = object.__new__(FourierSeries)
        out.bins = self.bins
        p = np.arange(1, self.table.shape[0], dtype=np.float64)
        out.table = self.table[1:] * (p * (self.bins / math.pi))[:, None]
        return out

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The curve at angles ``x`` [rad] (any shape), in the coefficients' unit."""
        pos = np.asarray(x, dtype=np.float64) * (self.bins / TWO_PI)
        b = np.floor(pos)
        s = pos - b
        s *= 2.0
        s -= 1.0
        idx = b.astype(np.intp)
        idx &= self.bins - 1  # the bin within the turn (bins is a power of 2)
        out = np.take(self.table[-1], idx)
        for row in self.table[-2::-1]:
            out *= s
            out += np.take(row, idx)
        return out


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
