"""Harmonic figures of an error curve and the expanded uncertainty.

(Peak-to-peak, +/-, mean, s and RMS are in :mod:`enctools.data.statistics`.)

All deviations are in arcsec (radial motion in nm: the functions are unit-blind and
return the unit they are given). Angles are in rad.

- :func:`harmonics`: amplitude and phase of the harmonics of a curve, by FFT on a
  uniform full-period grid, by least squares on anything else.
- :func:`expanded_uncertainty`: U = k u with k = 2 (GUM, about 95 % coverage).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from enctools.errors import DataError
from enctools.methods.harmonics import analyse
from enctools.models.fourier import (
    RESOLVE_LIMIT,
    arc_coverage_deg,
    design_condition,
    fit_fourier,
)
from enctools.units import DEG, TWO_PI

#: coverage factor of the expanded uncertainty
K_COVERAGE = 2.0


@dataclass(frozen=True)
class Harmonics:
    """Harmonics ``amplitude * cos(n x + phase)`` of a curve (spectrum-stream convention).

    ``amplitude`` in the curve's unit, ``phase`` in rad; ``re = a``, ``im = -b`` for
    ``a cos(n x) + b sin(n x)``. Of positions that are not a uniform grid over the
    period: ``limit`` the highest order they resolve (0: none), ``left_out`` the orders
    asked for past it, ``positions`` how many there are, ``arc_deg`` the arc of the
    period they cover [deg of the period] and ``condition`` the condition number of the
    design of the first order past the limit (dimensionless).
    """

    n: np.ndarray
    amplitude: np.ndarray
    phase: np.ndarray
    limit: int | None = None        # uneven positions: the highest order they resolve
    left_out: list[int] = field(default_factory=list)  # orders asked for past that limit
    positions: int = 0
    arc_deg: float = 360.0
    condition: float | None = None

    @property
    def resolved(self) -> bool:
        """True when one order n >= 1 or more is resolved."""
        return self.limit is None or self.limit >= 1

    def note(self) -> str:
        """One line saying why no harmonic, or which orders, are not given; "" when all are."""
        where = f"{self.positions} positions over {self.arc_deg:.3g} deg"
        first = (self.limit or 0) + 1
        past = ""
        if self.condition is not None:
            past = (f" (design condition number {self.condition:.3g} at n={first}, limit "
                    f"{RESOLVE_LIMIT:g})" if np.isfinite(self.condition)
                    else f" (n={first} needs {2 * first + 1} distinct positions)")
        if not self.resolved:
            return f"harmonics: none resolvable from {where}{past}"
        if not self.left_out:
            return ""
        lo, hi = self.left_out[0], self.left_out[-1]
        orders = f"n={lo}" if lo == hi else f"n={lo}..{hi}"
        return f"harmonics {orders} not resolvable from {where}{past}: left out"

    def largest(self, count: int, skip_zero: bool = True) -> Harmonics:
        """The ``count`` harmonics of largest amplitude, largest first."""
        keep = self.n != 0 if skip_zero else np.ones(self.n.shape, bool)
        if self.amplitude.size:  # rounding residue (1e-17") is not a harmonic
            keep &= self.amplitude > 1e-9 * float(np.max(self.amplitude))
        idx = np.flatnonzero(keep)
        order = idx[np.argsort(-self.amplitude[idx], kind="stable")][:count]
        return dataclasses.replace(self, n=self.n[order], amplitude=self.amplitude[order],
                                   phase=self.phase[order])

    def amplitude_of(self, n: int) -> float:
        """Amplitude of harmonic n in the curve's unit (0 when it is not in the set)."""
        hit = np.flatnonzero(self.n == n)
        return float(self.amplitude[hit[0]]) if hit.size else 0.0

    def rows(self) -> list[dict[str, float]]:
        return [{"n": int(n), "amplitude": float(a), "phase": float(p)}
                for n, a, p in zip(self.n, self.amplitude, self.phase, strict=True)]


def _uniform_full_period(x: np.ndarray, period: float) -> bool:
    if x.size < 4:
        return False
    step = period / x.size
    expected = x[0] + step * np.arange(x.size)
    return bool(np.allclose(x, expected, rtol=0, atol=1e-6 * step))


def harmonics(angle: np.ndarray, values: np.ndarray, nmax: int | None = None,
              period: float = TWO_PI) -> Harmonics:
    """Harmonics of a periodic curve sampled at ``angle`` [rad] over ``period`` [rad].

    A uniform grid covering one period exactly (no repeated end point) uses the FFT;
    anything else (sparse polygon points, a closing 360 deg row, part of a turn) the
    least-squares Fourier fit of the models (:func:`enctools.models.fourier.fit_fourier`),
    n = 0..nmax with ``nmax < m/2`` for m distinct positions, on the orders the
    positions resolve: those whose design keeps a condition number within
    :data:`~enctools.models.fourier.RESOLVE_LIMIT` (positions over part of the period
    resolve few orders or none). The orders past it are listed in ``left_out``;
    :meth:`Harmonics.note` says why. Harmonic order n counts cycles per ``period``.
    """
    x = np.asarray(angle, dtype=np.float64).ravel()
    y = np.asarray(values, dtype=np.float64).ravel()
    if x.size != y.size:
        msg = f"{x.size} angles but {y.size} values"
        raise DataError(msg)
    if x.size == 0:
        msg = "no values: no harmonics"
        raise DataError(msg)
    phase_arg = np.mod(x, period) * (TWO_PI / period)
    order = np.argsort(x)
    uniform = _uniform_full_period(x[order], period)
    # positions closer than 1e-4 of the period are one position (repeated readings);
    # a uniform grid's points are all distinct, however fine the grid
    distinct = x.size if uniform else int(np.sum(np.diff(np.sort(phase_arg)) > 1e-4 * TWO_PI)) + 1
    nmax = min((distinct - 1) // 2, nmax if nmax is not None else distinct)
    if uniform and nmax >= 1:  # the harmonic core's FFT, turned to the grid's first angle
        c = analyse(y[order], nmax) * np.exp(-1j * np.arange(nmax + 1) * phase_arg[order][0])
        a, b = c.real, -c.imag
        n = np.arange(nmax + 1)
        return Harmonics(n, np.hypot(a, b), np.arctan2(-b, a), positions=x.size)
    # the orders these positions resolve, as a Fourier model is fitted to them
    nmax = max(nmax, 0)
    series = fit_fourier(phase_arg / DEG, y, nmax, RESOLVE_LIMIT)
    top = int(series.limit if series.limit is not None else nmax)
    a, b = series.a[:top + 1], series.b[:top + 1]
    angles = np.unique(phase_arg)
    past = design_condition(angles, top + 1) if top < nmax or top == 0 else None
    return Harmonics(np.arange(top + 1), np.hypot(a, b), np.arctan2(-b, a), top,
                     list(range(top + 1, nmax + 1)), angles.size,
                     arc_coverage_deg(angles / DEG), past)


def expanded_uncertainty(u: np.ndarray | float, k: float = K_COVERAGE) -> np.ndarray | float:
    """Expanded uncertainty U = k u (k = 2 by default, GUM) of standard uncertainties u,
    in the unit of u (arcsec, nm); k is dimensionless."""
    u_arr = np.asarray(u, dtype=np.float64)
    if np.any(u_arr < 0):
        msg = "a standard uncertainty is negative"
        raise DataError(msg)
    return k * u if isinstance(u, float) else k * u_arr
