"""How well a sweep or a continuous run covers the signal period, gathered batch by batch.

An interpolation error is only determined when the device's phase goes through
the signal period: every run of a sweep must span one period, every window of a
continuous run must carry the phase through every quarter of it, and the sampled
phases must be fine enough for the harmonics fitted (pi / largest gap). All is
kept in constant memory: a bitmap of the period, sums per closed group.
"""

from __future__ import annotations

import functools

import numpy as np

from enctools.errors import DataError
from enctools.units import ARCSEC, TWO_PI

#: quarters of the signal period a window's phases must all visit to count as covering it
SECTORS = 4


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

    def add(self, phase: np.ndarray | None, positions: np.ndarray | None = None,
            step: np.ndarray | None = None, steps: int = 0) -> None:
        """Add phases [rad] (with ``step`` [count]: phase = 2 pi step / steps, from counts,
        and ``phase`` may be None)."""
        if positions is None and step is not None and self.BINS % steps == 0:
            self.samples += step.size
            self._mask[step * (self.BINS // steps)] = True
            return
        phase = np.asarray(phase_of(phase, step, steps), dtype=np.float64)
        self.samples += phase.size
        if positions is None:
            k = np.rint(np.mod(phase, TWO_PI) * (self.BINS / TWO_PI)).astype(np.int64)
            self._mask[np.mod(k, self.BINS)] = True
            return
        keys, inv = np.unique(np.asarray(positions), return_inverse=True)
        z = np.bincount(inv, np.cos(phase), keys.size) + 1j * np.bincount(inv, np.sin(phase),
                                                                         keys.size)
        for key, v in zip(keys.tolist(), z.tolist(), strict=True):
            self._pos[key] = self._pos.get(key, 0j) + v

    def add_steps(self, per_step: np.ndarray) -> None:
        """Add samples by their count at each step of the period (phase 2 pi j / steps [rad]
        at step j of ``per_step``'s length): as :meth:`add` of their phases."""
        steps = per_step.size
        self.samples += int(per_step.sum())
        seen = np.flatnonzero(per_step)
        if self.BINS % steps == 0:
            self._mask[seen * (self.BINS // steps)] = True
        else:
            self.add(seen * (TWO_PI / steps))
            self.samples -= seen.size

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


@functools.lru_cache(maxsize=8)
def _sector_bits_table(steps: int) -> np.ndarray:
    """1 << the quarter of each step 0 .. steps - 1 of a period (step * SECTORS // steps)."""
    table = np.left_shift(1, np.arange(steps, dtype=np.int64) * SECTORS // steps).astype(np.uint8)
    table.flags.writeable = False
    return table


def phase_of(phase: np.ndarray | None, step: np.ndarray | None, steps: int) -> np.ndarray:
    """``phase`` [rad], or when None 2 pi ``step`` / ``steps`` (a phase from counts)."""
    if phase is not None:
        return phase
    assert step is not None, "a phase or its step"
    return step * (TWO_PI / steps)


def sector_bits(phase: np.ndarray | None, step: np.ndarray | None = None, steps: int = 0,
                out: np.ndarray | None = None) -> np.ndarray:
    """1 << the quarter of the signal period (0 .. :data:`SECTORS` - 1) each sample's
    phase is in, as uint8 (into ``out`` when given).

    ``phase`` [rad], or with ``step`` [count] its count within ``steps`` per period.
    The fit ORs them per group (a window covers the period when every quarter has a
    sample: all :data:`SECTORS` bits).
    """
    if step is not None:  # looked up: a division per sample costs more
        return np.take(_sector_bits_table(steps), step, out=out, mode="clip")
    assert phase is not None, "a phase or its step"
    quarter = np.minimum((np.mod(phase, TWO_PI) * (SECTORS / TWO_PI)).astype(np.int64),
                         SECTORS - 1)
    bits = np.left_shift(1, quarter).astype(np.uint8)
    if out is None:
        return bits
    out[...] = bits
    return out


class RunCoverage:
    """The runs of a sweep: each must span one signal period (to within a step).

    :meth:`closed` receives per closed run its samples, the quarters of the period its
    phases visited (:func:`sector_bits` OR-ed), and its least and greatest reference
    angle [rad].
    """

    def __init__(self) -> None:
        self._short: tuple[float, float] | None = None   # (span + step, span) of the worst run
        self._min_span = np.inf

    def closed(self, count: np.ndarray, seen: np.ndarray, lo: np.ndarray,
               hi: np.ndarray) -> None:
        """Runs that closed: their samples ``count``, quarters ``seen``, ``lo``, ``hi`` [rad]."""
        span = hi - lo
        step = np.where(count > 1, span / np.maximum(count - 1, 1), 0.0)
        worst = int(np.argmin(span + step))
        if self._short is None or span[worst] + step[worst] < self._short[0]:
            self._short = (float(span[worst] + step[worst]), float(span[worst]))
        self._min_span = min(self._min_span, float(span.min()))

    def periods_swept(self, period: float) -> float:
        """Signal periods [1] the shortest run spans; DataError when under one ``period`` [rad]."""
        if self._short is not None and self._short[0] < period * 0.999:
            msg = (f"the sweep covers {self._short[1] / ARCSEC:.3g}\" but the signal period is "
                   f"{period / ARCSEC:.4g}\": sweep at least one period")
            raise DataError(msg)
        return self._min_span / period


class WindowCoverage:
    """The windows of a continuous run: which carry the phase through a whole period.

    ``window`` [rad]. :meth:`closed` receives per closed window its samples, the
    quarters of the period its phases visited (:func:`sector_bits` OR-ed), and its
    least and greatest reference angle [rad].
    """

    def __init__(self, window: float) -> None:
        self.window = window
        self.windows = 0      # closed windows
        self.covering = 0     # windows whose phases visit every quarter of the period
        self.covered = 0      # the samples of those
        self._lo, self._hi = np.inf, -np.inf

    def closed(self, count: np.ndarray, seen: np.ndarray, lo: np.ndarray,
               hi: np.ndarray) -> None:
        """Windows that closed: their samples ``count``, quarters ``seen``, ``lo``, ``hi`` [rad]."""
        full = seen == (1 << SECTORS) - 1
        self.windows += count.size
        self.covering += int(np.count_nonzero(full))
        self.covered += int(count[full].sum())
        self._lo, self._hi = min(self._lo, float(lo.min())), max(self._hi, float(hi.max()))

    def periods_swept(self, period: float) -> float:
        """Signal periods [1] of the whole run; DataError when no window covers ``period`` [rad]."""
        if self.covering == 0:
            msg = (f"no window of {self.window / ARCSEC:.4g}\" carries the device's phase "
                   f"through a whole signal period ({self.windows} windows): widen `window_arcsec` "
                   f"or sample at another interval")
            raise DataError(msg)
        return (self._hi - self._lo) / period

    def partial_warning(self, samples: int) -> str | None:
        """A warning when most of ``samples`` lie in windows that do not cover the period."""
        partial = samples - self.covered
        if partial > samples / 2:
            return (f"{partial / samples:.0%} of the samples lie in windows whose phases do not "
                    f"go through a whole signal period; they add little: widen the window")
        return None
