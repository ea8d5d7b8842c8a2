"""Revolutions of a continuous run: readings batches in, per-revolution spectra out.

A continuous run samples every head at times t; the spindle angle is not known, so
the mean reading of one or more heads stands in for it as the *angle coordinate* u
(seed 000 eqs. (3), (6)). This module reads the Arrow batches of a readings stream,
takes every other channel's error against u, cuts the stream into whole revolutions
of u (``[u0 + 2 pi r, u0 + 2 pi (r + 1))``) and hands each to the harmonic core
(:mod:`enctools.methods.harmonics`), so that methods can average revolutions and
measure the spread between them (:class:`RunningMean`). Memory holds one revolution.

The per-batch work (readings to angles, the checks, the cut) runs on the stream's
read-ahead thread while the caller analyses the revolutions already cut.

Units: angles in rad, times in s; a channel's coefficients carry the channel's unit.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from enctools.data.readings import HeadInfo
from enctools.errors import DataError
from enctools.methods.harmonics import bin_average, revolution_coefficients
from enctools.methods.stroboscopic import warn_stroboscopic
from enctools.units import TWO_PI

if TYPE_CHECKING:
    import pyarrow as pa

    from enctools.data.streams import InputStream

#: (index, coefficients (C, K + 1), bin averages (C, points) or None) of one revolution
Spectra = tuple[int, np.ndarray, np.ndarray | None]

#: values (channels x samples) of one revolution held at once: 32 MB of float64 a copy,
#: so that the few copies its analysis makes stay well under 500 MB. A batch is cut
#: into slices of at most half of it; a revolution beyond it is refused [values]
MAX_REVOLUTION_VALUES = 1 << 22


def require_continuous(source: InputStream, needs: str) -> None:
    """DataError unless the readings are a continuous run; ``needs`` ends the message."""
    mode = source.meta.get("mode")
    if mode not in (None, "continuous"):
        msg = f"{source.source}: a {mode} run; {needs}"
        raise DataError(msg)


class Revolution:
    """One revolution of channels against the angle coordinate.

    ``u``: coordinate samples [rad], the ends on ``start`` and ``start +/- 2 pi``;
    ``values``: (C, S) channels, given whole or as ``parts``: the (C, S_i) pieces of the
    batches the revolution was cut from, in order. The pieces are joined (copied) the first
    time :attr:`values` is read; what reads :attr:`parts` instead (the moments' kernel)
    needs no copy. A piece may be shared with the next revolution (its interpolated end):
    it is never written to.
    """

    __slots__ = ("_values", "index", "parts", "start", "u")

    def __init__(self, index: int, start: float, u: np.ndarray,
                 values: np.ndarray | tuple[np.ndarray, ...]) -> None:
        self.index = index
        self.start = start
        self.u = u
        self.parts = values if isinstance(values, tuple) else (values,)
        self._values = values if isinstance(values, np.ndarray) else None

    @property
    def values(self) -> np.ndarray:
        """(C, S) channels, the parts joined."""
        if self._values is None:
            self._values = np.concatenate(self.parts, axis=1)
        return self._values

    @values.setter
    def values(self, values: np.ndarray) -> None:
        self._values = values
        self.parts = (values,)


class RevolutionSplitter:
    """Cut a stream of (u, values) blocks into whole revolutions of u.

    Feed blocks in order (u strictly monotonic, checked by the caller); each
    complete revolution is yielded with its end interpolated linearly onto the
    boundary, which also starts the next one. The first revolution starts at the
    first sample. What is left at the end (less than a revolution) is not yielded;
    ``pending`` says how much of a revolution it was. Blocks are held as views: a
    revolution's u is copied out of them, its values are handed on as the pieces
    (:class:`Revolution`).
    """

    def __init__(self) -> None:
        self.start: float | None = None
        self.direction = 0.0
        self.index = 0
        self._u: list[np.ndarray] = []
        self._v: list[np.ndarray] = []

    @property
    def held(self) -> int:
        """Samples buffered towards the revolution not yet complete."""
        return sum(p.size for p in self._u)

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
                nxt_u, nxt_v = [], []
            else:
                pu, pv = ((u[k - 1], values[:, k - 1]) if k > lo
                          else (self._u[-1][-1], self._v[-1][:, -1]))
                f = (end - pu) / (u[k] - pu)
                eu = np.array([end])
                ev = (pv * (1.0 - f) + values[:, k] * f)[:, None]
                nxt_u, nxt_v = [eu], [ev]
            ru = np.concatenate([*self._u, u[lo:k], eu])
            yield Revolution(self.index, self.start, ru, (*self._v, values[:, lo:k], ev))
            self.index += 1
            self.start = end
            self._u, self._v, lo = nxt_u, nxt_v, k

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
        ru = np.concatenate([*self._u, np.array([end])])
        rev = Revolution(self.index, self.start, ru, (*self._v, self._v[0][:, :1]))
        self.index += 1
        self._u, self._v = [], []
        return rev


class RunningMean:
    """Mean and spread of arrays of a fixed shape, one per revolution (Welford).

    Memory does not grow with the number of revolutions; :meth:`sem` gives the
    standard uncertainty of the mean (in the arrays' unit).
    """

    def __init__(self) -> None:
        self.count = 0
        self.mean: np.ndarray | None = None
        self._m2_re: np.ndarray | None = None
        self._m2_im: np.ndarray | None = None

    def add(self, x: np.ndarray) -> None:
        """Take in one revolution's array (any unit; real or complex)."""
        x = np.asarray(x)
        self.count += 1
        if self.mean is None or self._m2_re is None or self._m2_im is None:
            self.mean = x.astype(np.complex128 if np.iscomplexobj(x) else np.float64).copy()
            self._m2_re = np.zeros(x.shape)
            self._m2_im = np.zeros(x.shape)
            return
        d = x - self.mean
        self.mean = self.mean + d / self.count
        d2 = x - self.mean
        self._m2_re += d.real * d2.real
        self._m2_im += np.imag(d) * np.imag(d2)

    def rows(self) -> list[RunningMean]:
        """The running mean of each row of the arrays taken in (views, not copies): what
        one RunningMean per row would hold, the arithmetic being elementwise."""
        if self.mean is None or self._m2_re is None or self._m2_im is None:
            return []
        out = []
        for mean, re, im in zip(self.mean, self._m2_re, self._m2_im, strict=True):
            row = RunningMean()
            row.count, row.mean, row._m2_re, row._m2_im = self.count, mean, re, im
            out.append(row)
        return out

    def variance(self) -> tuple[np.ndarray, np.ndarray]:
        """Sample variances (re, im) between revolutions; NaN with fewer than 2."""
        if self.count < 2 or self._m2_re is None or self._m2_im is None:
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


def _column(batch: pa.RecordBatch, name: str, source: str) -> np.ndarray:
    """A column of an Arrow batch as numpy, refusing nulls and NaN."""
    col = batch.column(name)
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


def mean_reading(batch: pa.RecordBatch, heads: tuple[HeadInfo, ...], source: str = "input",
                 minus: np.ndarray | None = None) -> np.ndarray:
    """The mean of the heads' readings [rad] (:func:`~enctools.data.readings.head_reading`)
    over a batch.

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


def _times(batch: pa.RecordBatch, source: str) -> tuple[np.ndarray, bool]:
    """Column t [s] as numpy, refusing nulls, NaN and infinities; and whether it rises.

    Rising samples with finite ends are all finite: the full check runs only when
    this quick one fails.
    """
    col = batch.column("t")
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
    when u rises or falls strictly within the batch, else 0; ``u_step``: the largest
    |step| of u within the batch [rad], when the kernel found it (else None).
    """

    t: np.ndarray
    u: np.ndarray
    values: np.ndarray
    t_rising: bool
    u_sense: int
    u_step: float | None = None


def batch_channels(batch: pa.RecordBatch, spec: ChannelSpec,
                   source: str = "input") -> BatchChannels | None:
    """The per-batch half of :func:`revolution_spectra` (None for an empty batch).

    It needs nothing of the batches before it, so the reader thread runs it (in
    :class:`RevolutionCutter`) while the revolutions are analysed.
    """
    n = batch.num_rows
    if n == 0:
        return None
    t, rising = _times(batch, source)
    fused = None if spec.mean else _kernel_channels(batch, spec)
    if fused is not None:
        u, values, sense, step = fused
        return BatchChannels(t, u, values, rising, sense if n > 1 else 0, step)
    u = mean_reading(batch, spec.coordinate, source)
    if spec.mean:
        values = mean_reading(batch, spec.channels, source, minus=u)[None, :]
    else:
        values = np.empty((len(spec.channels), n))
        for i, h in enumerate(spec.channels):
            values[i] = mean_reading(batch, (h,), source, minus=u)
    sense = 1 if bool(np.all(u[1:] > u[:-1])) else -1 if bool(np.all(u[1:] < u[:-1])) else 0
    return BatchChannels(t, u, values, rising, sense if n > 1 else 0)


def _kernel_channels(batch: pa.RecordBatch, spec: ChannelSpec
                     ) -> tuple[np.ndarray, np.ndarray, int, float] | None:
    """u [rad], the channels minus u [rad], u's sense and its largest step [rad]
    (:func:`batch_channels`) in one pass of the compiled kernel (:mod:`enctools.kernel`),
    the same doubles as :func:`mean_reading`'s; None where it does not apply (no kernel,
    counts not int64 or with nulls, coordinate heads of different counts per revolution)."""
    import pyarrow as pa  # a batch's own library: imported already

    from enctools import kernel

    lib = kernel.library()
    coordinate = spec.coordinate
    if lib is None or len({h.counts_per_rev for h in coordinate}) != 1:
        return None
    columns = []
    for h in coordinate + spec.channels:
        col = batch.column(h.name)
        if col.null_count or not pa.types.is_int64(col.type):
            return None
        columns.append(col.to_numpy())
    m, cpr = len(coordinate), coordinate[0].counts_per_rev
    u_offset = 0.0 + sum(h.zero_count * (TWO_PI / cpr) - h.alpha for h in coordinate) / m
    scales = np.array([TWO_PI / h.counts_per_rev for h in spec.channels])
    offsets = np.array([0.0 + (h.zero_count * (TWO_PI / h.counts_per_rev) - h.alpha)
                        for h in spec.channels])
    pointers = np.array([c.ctypes.data for c in columns], dtype=np.uintp)
    n = batch.num_rows
    u, values, step = np.empty(n), np.empty((len(spec.channels), n)), np.zeros(1)
    sense = lib.enc_head_channels(n, m, pointers.ctypes.data, TWO_PI / (cpr * m), u_offset,
                                  len(spec.channels), pointers[m:].ctypes.data,
                                  scales.ctypes.data, offsets.ctypes.data, u.ctypes.data,
                                  values.ctypes.data, step.ctypes.data)
    return u, values, int(sense), float(step[0])


def _check_steps(u: np.ndarray, before: float, spec: ChannelSpec, source: str,
                 largest: float | None = None) -> None:
    """No step of the coordinate ``u`` [rad] (from ``before``, the last of the batch before)
    of half a turn or more: such samples cannot be cut into revolutions, and a few rows
    would make millions of them (a counts_per_rev far below the counts recorded).
    ``largest``: the largest step within ``u`` [rad] when known (the kernel's), so that
    only a batch that fails is looked at again."""
    if largest is not None and max(largest, abs(float(u[0]) - before)) < np.pi:
        return
    steps = np.abs(np.diff(u, prepend=before))
    if steps.size and float(steps.max()) >= np.pi:
        k = int(np.argmax(steps))
        names = ", ".join(h.name for h in spec.coordinate)
        msg = (f"{source}: the angle coordinate (mean of {names}) moves {steps[k] / TWO_PI:.4g} "
               "turns between two samples; at most half a turn is read (is counts_per_rev "
               "in the field metadata right?)")
        raise DataError(msg)


class RevolutionCutter:
    """The sequential half of :func:`revolution_spectra`: checks across batches, and
    the cut into whole revolutions of the coordinate.

    Call it on each readings batch in order, on any one thread (the reader thread:
    ``InputStream.batches(prepare=cutter)``); it returns the revolutions the batch
    completes. :meth:`finish` after the last batch gives the last revolution if only
    a sample's gap is missing.
    """

    def __init__(self, spec: ChannelSpec, source: str = "input") -> None:
        self.spec = spec
        self.source = source
        self._splitter = RevolutionSplitter()
        self._last_t = -np.inf
        self._last_u: float | None = None
        self._direction = 0
        self._spacing = np.inf

    def __call__(self, batch: pa.RecordBatch) -> list[Revolution]:
        channels = 1 if self.spec.mean else len(self.spec.channels)
        rows = max(1, MAX_REVOLUTION_VALUES // (2 * channels))
        out: list[Revolution] = []
        for start in range(0, batch.num_rows, rows):
            out += self._cut(batch.slice(start, rows))
            if self._splitter.held * channels > MAX_REVOLUTION_VALUES:
                msg = (f"{self.source}: a revolution of the angle coordinate holds at least "
                       f"{self._splitter.held} samples of {channels} channels; at most "
                       f"{MAX_REVOLUTION_VALUES} values (channels x samples of a revolution) "
                       "are analysed at once: give fewer `heads`, or record with a longer "
                       "`interval_s`")
                raise DataError(msg)
        return out

    def _cut(self, batch: pa.RecordBatch) -> list[Revolution]:
        """The revolutions one slice of a batch completes (see :meth:`__call__`)."""
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
        _check_steps(u, first, self.spec, self.source, b.u_step)
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


def revolution_spectra(source: InputStream, spec: ChannelSpec, band: int,
                       progress: Callable[[int], Any] | None = None,
                       grid_points: int = 0) -> Iterator[Spectra]:
    """Per revolution of the coordinate, the spectra of each channel's error [rad].

    Reads the readings batches of ``source`` once; for each channel k yields the
    coefficients c_0..c_band of ``h_k(u) - u``, u the mean reading of the coordinate
    heads. Checks that ``t`` increases strictly and that the coordinate moves one
    way; nulls and NaN are errors. ``progress`` is called with the number of
    revolutions done.

    Yields ``(index, coefficients (C, band + 1), binned)``; ``binned`` is the
    (C, grid_points) bin average of the revolution when ``grid_points`` > 0.
    """
    # the harmonics the result resolves: the band, or half the bins of an unfiltered grid
    resolved = band if band > 0 else max(1, grid_points // 2)
    for rev in revolutions(source, spec, progress, resolved):
        yield _analyse(rev, band, grid_points)


def revolutions(source: InputStream, spec: ChannelSpec,
                progress: Callable[[int], Any] | None = None,
                resolved: int = 0) -> Iterator[Revolution]:
    """The whole revolutions of the coordinate in ``source``, each with every channel's
    error against it [rad] (see :func:`revolution_spectra`, which analyses them).

    They are cut on the stream's reader thread; ``progress`` is called with the number
    of revolutions done once the caller has taken each. With ``resolved`` > 0 (the
    harmonics the result resolves) the first revolution is checked for synchronous
    sampling (:func:`warn_stroboscopic`).
    """
    cutter = RevolutionCutter(spec, source.source)
    for cut in source.batches(prepare=cutter):
        for rev in cut:
            if rev.index == 0 and resolved > 0:
                warn_stroboscopic(rev.u, rev.start, spec.channels + spec.coordinate, resolved)
            yield rev
            if progress is not None:
                progress(rev.index + 1)
    for rev in cutter.finish():
        if rev.index == 0 and resolved > 0:
            warn_stroboscopic(rev.u, rev.start, spec.channels + spec.coordinate, resolved)
        yield rev


def _analyse(rev: Revolution, band: int, grid_points: int) -> Spectra:
    """The coefficients (and with ``grid_points`` the bin averages) of one revolution."""
    coef = revolution_coefficients(rev.u, rev.values if grid_points else rev.parts,
                                   rev.start, band)
    binned = bin_average(rev.u[:-1], rev.values[:, :-1], grid_points) if grid_points else None
    return rev.index, coef, binned
