"""Gaussian radial-basis-function (RBF) error model on the circle (seed 001 sec. 4).

A network of Gaussian units (seed 001 eqs. 5-7) whose output is the error [arcsec]
at an angle. Unit i, centred at angle c_i, answers an input angle x with::

    R_i(x) = exp(-0.8326**2 * d(x, c_i)**2 / s**2)          (seed 001 eq. 6)
    y(x)   = sum_i w_i R_i(x)                                 (seed 001 eq. 7)

(eq. 7 has no output bias; the networks enc fit-rbf fits add one, unpenalised). The
model is periodic in angle:
``d`` is the chord between the two angles on the unit circle, ``2 sin(|x - c| / 2)``,
so the network sees 359 deg and 1 deg as neighbours. The spread ``s`` is given as
an arc [deg]: a unit's output falls to one half (``exp(-0.8326**2) = 0.5``) at that
arc from its centre, the meaning of the spread constant c = 0.8326 / b of eq. (6).

The paper's training follows MATLAB ``newrb`` (:func:`fit_rbf`, kept to reproduce
seed 001 sec. 5.4): start with no unit, add the unit centred on the training point of
largest residual, refit all output weights by least squares, and stop when every
residual is within the goal ("training accuracy 0.0001 arcsec") or every point is a
centre (24 polygon points: 24 units). On noisy points that passes through the noise,
and its leave-one-out residuals need N trainings.

enc fit-rbf fits :func:`choose_network` instead: min(N, 256) units on a uniform grid of
centres, an unpenalised bias and ridge-penalised weights, with the spread and the
smoothing chosen by the smallest leave-one-out residual, computed in closed form from
one SVD a spread (a linear smoother: ``e_i = r_i / (1 - H_ii)``); a goal
(``goal_arcsec``) keeps only the networks within it. With little noise the search
keeps the smoothing at rounding level and the network interpolates, as the paper's
does (seed 001 table 1: 24 units through the 24 points).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from enctools.data.limits import MAX_ABS_ARCSEC
from enctools.errors import DataError
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


# ------------------------------------------- the default: a smoothed network chosen by LOO

#: most units of the default network: with more points the units sit on a uniform grid
#: of this many, which keeps the spread search one (N x 256) factorisation a spread
MAX_UNITS = 256
#: spreads the default search tries, in centre spacings (capped at 180 deg)
SPREAD_STEPS = 2.0 ** np.arange(-1.0, 5.01, 0.5)
#: smoothing the search tries: the ridge lambda as a fraction of the largest squared
#: singular value of the centred design (1e-12: interpolation to rounding)
SMOOTHING = 10.0 ** np.arange(-12.0, 0.01, 0.5)
#: the largest |weight| [arcsec] a network may have: what a model stream holds
MAX_WEIGHT = MAX_ABS_ARCSEC


def default_centres(n_points: int) -> np.ndarray:
    """The centres [deg] of the default network: min(n, :data:`MAX_UNITS`) units equally
    spaced from 0 deg (24 polygon points every 15 deg: a unit at each, seed 001)."""
    m = max(1, min(int(n_points), MAX_UNITS))
    return np.arange(m) * (360.0 / m)


def search_grid(angle_deg: np.ndarray, error_arcsec: np.ndarray, spread_deg: float | None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[float]]:
    """What a spread search works on: the angles [deg] within one turn, the errors
    [arcsec], the default centres [deg] and the spreads [deg] to try (``spread_deg``
    alone when given, else :data:`SPREAD_STEPS` centre spacings, at most 180 deg)."""
    x = np.mod(np.asarray(angle_deg, dtype=np.float64), 360.0)
    y = np.asarray(error_arcsec, dtype=np.float64)
    centres = default_centres(x.size)
    spacing = 360.0 / centres.size
    spreads = ([float(spread_deg)] if spread_deg is not None
               else sorted({min(float(f) * spacing, 180.0) for f in SPREAD_STEPS}))
    return x, y, centres, spreads


@dataclass
class Choice:
    """The network the leave-one-out search chose and its residuals.

    spread_deg : the spread [deg]; smoothing : lambda as a fraction of the largest
    squared singular value (dimensionless); loo : each point's residual [arcsec]
    against the network fitted without it; effective : trace of the hat matrix, the
    number of parameters the data effectively determine; tried : spreads x smoothings;
    reached : whether the network reaches the training goal (None: no goal given);
    best_rms : the smallest RMS leave-one-out residual [arcsec] of any network tried,
    goal or not; spread_range : the narrowest and widest spread tried [deg].
    """

    spread_deg: float
    smoothing: float
    loo: np.ndarray
    effective: float
    tried: int
    reached: bool | None = None
    best_rms: float = float("nan")
    spread_range: tuple[float, float] = (float("nan"), float("nan"))


class _Ridge:
    """A network of fixed units at one spread, fitted with an unpenalised bias and
    ridge-penalised weights: ``min |y - b - Phi w|^2 + lambda |w|^2``.

    One thin SVD of the column-centred design ``P Phi = U S V^T`` (P removes the mean)
    serves every lambda: the hat matrix is ``11^T/N + U diag(S^2/(S^2+lambda)) U^T``, a
    linear smoother, so the leave-one-out residual of point i is ``r_i / (1 - H_ii)``
    exactly (the network refitted without point i, the same units), no refit needed.
    Both ``r`` and ``1 - H_ii`` are summed from their parts outside the design's span
    and the shrunk ``lambda / (S^2 + lambda)`` parts, never as a difference from 1, so
    a network that nearly interpolates keeps its leave-one-out residuals accurate.
    """

    def __init__(self, x_deg: np.ndarray, y: np.ndarray, centres_deg: np.ndarray,
                 spread_deg: float) -> None:
        self.x, self.y, self.centres, self.spread = x_deg, y, centres_deg, spread_deg
        phi = design_matrix(x_deg * DEG, centres_deg * DEG, spread_deg)
        self.mu = phi.mean(axis=0)
        u, s, vt = np.linalg.svd(phi - self.mu, full_matrices=False)
        n = y.size
        rank = int(np.sum(s > (s[0] if s.size else 0.0) * max(phi.shape) * np.finfo(float).eps))
        self.u, self.s, self.vt = u[:, :rank], s[:rank], vt[:rank]
        self.ybar = float(y.mean())
        centred = y - self.ybar
        self.uy = self.u.T @ centred
        self.u2 = self.u * self.u
        if rank >= n - 1:   # the bias and the units span every point: nothing is outside
            self.outside, self.leverage_out = np.zeros(n), np.zeros(n)
        else:
            self.outside = centred - self.u @ self.uy
            self.leverage_out = np.maximum(1.0 - 1.0 / n - self.u2.sum(axis=1), 0.0)

    def _shrink(self, smoothing: float) -> np.ndarray:
        """lambda / (S^2 + lambda) per singular value (1 - the gain)."""
        s2 = self.s * self.s
        lam = smoothing * float(s2[0]) if s2.size else 0.0
        return lam / (s2 + lam) if s2.size else s2

    def _gain(self, smoothing: float) -> np.ndarray:
        s2 = self.s * self.s
        lam = smoothing * float(s2[0]) if s2.size else 0.0
        return s2 / (s2 + lam) if s2.size else s2

    def _residuals(self, smoothing: float) -> np.ndarray:
        return self.outside + self.u @ (self._shrink(smoothing) * self.uy)

    def training_max(self, smoothing: float) -> float:
        """The largest |training residual| [arcsec] with this smoothing."""
        return float(np.max(np.abs(self._residuals(smoothing))))

    def loo(self, smoothing: float) -> tuple[np.ndarray, float]:
        """Leave-one-out residuals [arcsec] and the trace of the hat matrix."""
        one_minus_h = self.leverage_out + self.u2 @ self._shrink(smoothing)
        with np.errstate(divide="ignore", invalid="ignore"):
            loo = self._residuals(smoothing) / one_minus_h
        return loo, float(1.0 + self._gain(smoothing).sum())

    def weights(self, smoothing: float) -> np.ndarray:
        """The output weights [arcsec] fitted to all points with this smoothing."""
        g = self._gain(smoothing)
        positive = self.s > 0
        inverse = np.where(positive, g / np.where(positive, self.s, 1.0), 0.0)
        return np.asarray(self.vt.T @ (inverse * self.uy))

    def model(self, smoothing: float) -> RBFModel:
        """The network fitted to all points with this smoothing."""
        weights = self.weights(smoothing)
        bias = self.ybar - float(self.mu @ weights)
        resid = self.y - bias - design_matrix(self.x * DEG, self.centres * DEG,
                                              self.spread) @ weights
        return RBFModel(self.centres.copy(), weights, bias, self.spread, float(resid @ resid))


def fit_smoothed(angle_deg: np.ndarray, error_arcsec: np.ndarray, spread_deg: float,
                 smoothing: float, centres_deg: np.ndarray | None = None) -> RBFModel:
    """The smoothed network (see :class:`_Ridge`) through points [deg, arcsec] at one spread
    [deg] and smoothing (lambda / largest squared singular value); centres [deg] default to
    :func:`default_centres`."""
    x = np.mod(np.asarray(angle_deg, dtype=np.float64), 360.0)
    y = np.asarray(error_arcsec, dtype=np.float64)
    c = default_centres(x.size) if centres_deg is None else np.asarray(centres_deg, np.float64)
    return _Ridge(x, y, c, spread_deg).model(smoothing)


def choose_network(angle_deg: np.ndarray, error_arcsec: np.ndarray,
                   spread_deg: float | None = None,
                   progress: Callable[[int, int], object] | None = None,
                   goal: float | None = None) -> tuple[RBFModel, Choice]:
    """The default network: spread (unless given) and smoothing by the smallest RMS
    leave-one-out residual, in closed form (one SVD a spread, :class:`_Ridge`).

    Parameters
    ----------
    angle_deg, error_arcsec : distinct positions [deg] and deviations [arcsec].
    spread_deg : a fixed spread [deg]; None tries :data:`SPREAD_STEPS` centre spacings.
    progress : ``progress(done, total)`` after each spread.
    goal : a training goal [arcsec]: only networks whose every training residual is
        within it are candidates (none: every network is, and ``Choice.reached`` is
        False).

    Returns
    -------
    The network fitted to every point with the chosen spread and smoothing, and the
    :class:`Choice` with its leave-one-out residuals [arcsec].
    """
    x, y, centres, spreads = search_grid(angle_deg, error_arcsec, spread_deg)
    best: tuple[tuple[bool, float], _Ridge, float, np.ndarray, float] | None = None
    best_rms = np.inf
    for k, spread in enumerate(spreads):
        ridge = _Ridge(x, y, centres, spread)
        for smoothing in SMOOTHING:
            loo, effective = ridge.loo(float(smoothing))
            rms = float(np.sqrt(np.mean(loo * loo)))
            # networks that reach the goal first, then the smaller leave-one-out residual;
            # never one whose weights a model stream cannot hold (interpolated noise)
            key = (goal is not None and ridge.training_max(float(smoothing)) > goal, rms)
            if not np.max(np.abs(ridge.weights(float(smoothing))), initial=0.0) <= MAX_WEIGHT:
                continue
            best_rms = min(best_rms, rms) if np.isfinite(rms) else best_rms
            if np.isfinite(rms) and (best is None or key[0] < best[0][0] or (
                    key[0] == best[0][0] and rms < best[0][1] * (1 - 1e-9))):
                best = (key, ridge, float(smoothing), loo, effective)
        if progress is not None:
            progress(k + 1, len(spreads))
    if best is None:
        msg = "no spread gives finite leave-one-out residuals"
        raise DataError(msg)
    key, ridge, smoothing, loo, effective = best
    return ridge.model(smoothing), Choice(ridge.spread, smoothing, loo, effective,
                                          len(spreads) * SMOOTHING.size,
                                          None if goal is None else not key[0], best_rms,
                                          (spreads[0], spreads[-1]))
