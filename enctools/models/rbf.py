"""Gaussian radial-basis-function (RBF) error model on the circle (seed 001 sec. 4).

A network of Gaussian units (seed 001 eqs. 5-7) whose output is the error [arcsec]
at an angle. Unit i, centred at angle c_i, answers an input angle x with::

    R_i(x) = exp(-0.8326**2 * d(x, c_i)**2 / s**2)          (seed 001 eq. 6)
    y(x)   = sum_i w_i R_i(x)                                 (seed 001 eq. 7)

(no output bias, as eq. 7: with N points the exact network has N units, the
paper's 24-node result). The model is periodic in angle:
``d`` is the chord between the two angles on the unit circle, ``2 sin(|x - c| / 2)``,
so the network sees 359 deg and 1 deg as neighbours. The spread ``s`` is given as
an arc [deg]: a unit's output falls to one half (``exp(-0.8326**2) = 0.5``) at that
arc from its centre, the meaning of the spread constant c = 0.8326 / b of eq. (6).

Training follows MATLAB ``newrb``: start with no unit, add the unit centred on the
training point of largest residual, refit all output weights by least squares,
and stop when every residual is within the goal (the paper's "training accuracy
0.0001 arcsec") or every point is a centre (24 polygon points: 24 units, seed 001
sec. 5.4). The spread can be chosen by leave-one-out cross-validation
(:func:`choose_spread`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from enctools.units import DEG

if TYPE_CHECKING:
    from enctools.models.fourier import FourierModel

#: the factor of seed 001 eq. (6): exp(-0.8326**2) = 0.5
SPREAD_FACTOR = 0.8326


def chord(x: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Chord distance on the unit circle between angles ``x`` and ``c`` [rad]."""
    return 2.0 * np.abs(np.sin((np.asarray(x) - np.asarray(c)) / 2.0))


def spread_chord(spread_deg: float) -> float:
    """The spread as a chord on the unit circle (dimensionless) from an arc [deg]."""
    return 2.0 * np.sin(min(spread_deg, 359.999) * DEG / 2.0)


def design_matrix(x_rad: np.ndarray, centres_rad: np.ndarray, spread_deg: float) -> np.ndarray:
    """Unit outputs R_i(x) (seed 001 eq. 6) for angles ``x_rad`` [rad]: shape (len(x), len(c))."""
    x = np.asarray(x_rad, dtype=np.float64).reshape(-1, 1)
    c = np.asarray(centres_rad, dtype=np.float64).reshape(1, -1)
    # d^2 = 2 - 2 cos(x - c): no sqrt needed
    d2 = 2.0 - 2.0 * np.cos(x - c)
    return np.exp(-(SPREAD_FACTOR ** 2) * d2 / spread_chord(spread_deg) ** 2)


@dataclass
class RBFModel:
    """A trained periodic RBF network (angles in deg, outputs in arcsec)."""

    centres_deg: np.ndarray
    weights: np.ndarray  # arcsec
    bias: float  # arcsec
    spread_deg: float
    sse: float = 0.0  # sum of squared training residuals [arcsec^2]
    history: list[float] = field(default_factory=list)  # sse after each added unit

    def __call__(self, angle_deg: np.ndarray | float, chunk: int = 1 << 20) -> np.ndarray:
        """The model's error [arcsec] at angles [deg] (evaluated in chunks: any size)."""
        x = np.asarray(angle_deg, dtype=np.float64)
        flat = x.reshape(-1)
        out = np.empty(flat.shape, dtype=np.float64)
        k = SPREAD_FACTOR ** 2 / spread_chord(self.spread_deg) ** 2
        cc, sc = np.cos(self.centres_deg * DEG), np.sin(self.centres_deg * DEG)
        # exp(-k (2 - 2 cos(x - c))) = exp(2k (cos x cos c + sin x sin c) - 2k)
        for start in range(0, flat.size, chunk):
            xs = flat[start:start + chunk] * DEG
            cx, sx = np.cos(xs), np.sin(xs)
            acc = np.full(xs.shape, self.bias)
            tmp = np.empty_like(xs)
            for ci, si, wi in zip(cc, sc, self.weights, strict=True):
                np.multiply(cx, 2 * k * ci, out=tmp)
                tmp += sx * (2 * k * si) - 2 * k
                np.exp(tmp, out=tmp)
                tmp *= wi
                acc += tmp
            out[start:start + chunk] = acc
        return out.reshape(x.shape)

    def as_fourier(self, max_harmonics: int | None = None) -> FourierModel | None:
        """The network as a Fourier series [arcsec], exact to rounding; None if too long.

        A Gaussian of the chord is smooth and periodic: its series (Jacobi-Anger:
        ``exp(2k cos u) = sum_n I_n(2k) e^(i n u)``) falls faster than geometrically
        once n passes the spread's 2k. The coefficients come from the FFT of the
        network sampled at M points, M doubled until the top half of the spectrum
        is below rounding (1e-15 of the largest value), so aliasing is below it
        too; orders below that level are dropped. None when more than
        ``max_harmonics`` (default 32 per unit: where evaluating the series stops
        paying) would be needed.
        """
        from enctools.models.fourier import FourierModel

        limit = 32 * max(1, self.centres_deg.size) if max_harmonics is None else max_harmonics
        m = 64
        while m <= 4 * limit:
            y = self(np.arange(m) * (360.0 / m))
            c = np.fft.rfft(y) / m
            mag = np.abs(c)
            floor = 1e-15 * max(float(np.max(np.abs(y))), 1e-300)
            if np.all(mag[m // 4:] < floor):
                k = int(np.flatnonzero(mag >= floor).max(initial=0))
                n = np.arange(k + 1)
                a = 2.0 * c.real[:k + 1]
                b = -2.0 * c.imag[:k + 1]
                a[0], b[0] = c.real[0], 0.0
                return FourierModel(n, a, b)
            m *= 2
        return None

    def on_grid(self, first_deg: float, step_deg: float) -> Callable[[int, int], np.ndarray]:
        """The model [arcsec] at ``first_deg + k * step_deg``, k = start..stop-1: ``values(start,
        stop)``.

        By its Fourier series (:meth:`as_fourier`, :meth:`FourierModel.on_grid`) when
        that is short, else unit by unit.
        """
        series = self.as_fourier()
        if series is not None:
            return series.on_grid(first_deg, step_deg)
        return lambda start, stop: self(first_deg + np.arange(start, stop) * step_deg)


def _solve(full: np.ndarray, y: np.ndarray, idx: list[int]) -> tuple[np.ndarray, float, np.ndarray]:
    """Least-squares output weights and bias for units at training points ``idx``.

    ``full`` is the design matrix with a unit at every training point (seed 001 eq. 6):
    the units' columns are taken from it, not recomputed at each step.
    """
    a = full[:, idx]
    sol, *_ = np.linalg.lstsq(a, y, rcond=None)
    return sol, 0.0, y - a @ sol


def fit_rbf(angle_deg: np.ndarray, error_arcsec: np.ndarray, spread_deg: float,
            goal: float = 1e-4, max_units: int | None = None) -> RBFModel:
    """Train a periodic RBF network on points like MATLAB ``newrb`` (seed 001 sec. 5.4).

    Parameters
    ----------
    angle_deg : distinct angles of the training points [deg].
    error_arcsec : error at those angles [arcsec].
    spread_deg : arc at which a unit's output is one half [deg].
    goal : training goal: largest |residual| [arcsec] (the paper: 0.0001).
    max_units : stop after this many units (default: one per point).

    Returns
    -------
    RBFModel with the units added in order of the largest remaining residual.
    """
    x = np.mod(np.asarray(angle_deg, dtype=np.float64), 360.0) * DEG
    y = np.asarray(error_arcsec, dtype=np.float64)
    n = x.size
    limit = n if max_units is None else min(max_units, n)
    idx: list[int] = []
    resid = y.copy()
    weights, bias = np.zeros(0), 0.0
    history: list[float] = []
    full = design_matrix(x, x, spread_deg)
    while len(idx) < limit and (n == 0 or float(np.max(np.abs(resid))) > goal):
        free = [i for i in range(n) if i not in idx]
        nxt = max(free, key=lambda i: abs(resid[i]))
        idx.append(nxt)
        weights, bias, resid = _solve(full, y, idx)
        history.append(float(resid @ resid))
    return RBFModel(np.mod(x[idx] / DEG, 360.0), weights, bias, spread_deg,
                    float(resid @ resid), history)


def loo_residuals(angle_deg: np.ndarray, error_arcsec: np.ndarray, spread_deg: float,
                  goal: float = 1e-4) -> np.ndarray:
    """Leave-one-out residuals [arcsec]: each point minus the network trained without it."""
    x = np.asarray(angle_deg, dtype=np.float64)
    y = np.asarray(error_arcsec, dtype=np.float64)
    out = np.empty(x.size)
    for i in range(x.size):
        keep = np.arange(x.size) != i
        out[i] = y[i] - fit_rbf(x[keep], y[keep], spread_deg, goal)(x[i:i + 1])[0]
    return out


def choose_spread(angle_deg: np.ndarray, error_arcsec: np.ndarray, goal: float = 1e-4,
                  factors: np.ndarray | None = None,
                  progress: Callable[[int, int], object] | None = None) -> float:
    """The spread [deg] with the smallest RMS leave-one-out residual.

    Tries multiples (0.5 to 2.5 by default) of the mean spacing of the points;
    ``progress(done, total)`` is called after each spread tried.
    """
    x = np.sort(np.mod(np.asarray(angle_deg, dtype=np.float64), 360.0))
    spacing = 360.0 / x.size
    factors = np.arange(0.5, 2.51, 0.125) if factors is None else factors
    best, best_rms = spacing, np.inf
    for k, f in enumerate(factors):
        r = loo_residuals(angle_deg, error_arcsec, f * spacing, goal)
        rms = float(np.sqrt(np.mean(r ** 2)))
        if progress is not None:
            progress(k + 1, len(factors))
        if rms < best_rms * (1 - 1e-9):
            best, best_rms = f * spacing, rms
    return float(best)
