"""The angle coordinate of a self-calibration, its own error found and taken out exactly.

Every head is read against an angle coordinate u, the mean reading of some heads
(seed 000 eqs. (3), (6)); u is the spindle angle theta plus those heads' errors and
their constant offset:

    u = theta + delta(theta),   delta(theta) = e(theta) + c

with e the coordinate heads' mean graduation error and radial motion (no constant
term) and c their mean constant offset against the reference head (a counter zeroed
elsewhere, a zero_count that is not the simulator's). The reference head fixes the
origin of theta: its reading has no constant offset. c is then minus the constant
term of the reference head's reading against theta, so delta is known once the
graduation error is, and the graduation error is known once theta is.

The iteration (all angles in rad):

1. On the first revolution: the head spectra against theta_i = u - delta_i(u) are
   solved, the solution gives delta_(i+1), until the graduation error stops changing
   (:func:`settle`). Each head's constant term is measured there too and taken off
   its readings from then on, so that no sum carries a large constant.
2. Every revolution is analysed against the theta of that map (:class:`AngleMap`):
   samples taken at equal steps of theta are then integrated exactly.
3. On the mean spectra: what the map of one revolution left (its noise) is corrected
   to second order in the difference of the coordinate errors, solved again until
   the solution stops changing (:func:`refine`).

A constant offset of any head's reading therefore leaves only the constant terms of
the spectra (which no method uses), and the graduation error comes out against
theta, not against the coordinate; an offset of the reference head moves the origin
of theta (the curve shifts along its angle by as much).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from enctools.methods.harmonics import (
    FourierSeries,
    analyse,
    grid,
    revolution_coefficients,
    synthesize,
)
from enctools.methods.revolutions import Revolution

#: head spectra (heads, K + 1) [rad], the reference first -> the coordinate's error e
#: (K + 1) [rad] without constant term, and the solution's coefficient arrays by name:
#: ``graduation`` [rad] first, then ``x``, ``y`` [m] when the method solves them
Model = Callable[[np.ndarray], tuple[np.ndarray, dict[str, np.ndarray]]]

#: most iterations of each loop; it stops earlier once the change stops shrinking
MAX_ITERATIONS = 50
#: the graduation error has converged when it changes by less than this, relative
CONVERGED = 4 * np.finfo(np.float64).eps
#: points of the grid the map from u to theta is found on, at least; and at most
_MAP_POINTS = (1 << 10, 1 << 18)
#: a coordinate error whose slope reaches this [rad/rad] is not taken out: a coordinate
#: that moves one way slopes by less than 1, and one this steep is noise amplified through
#: ill-conditioned harmonics, not the scale (Newton's method needs the margin too)
MAX_SLOPE = 0.5

log = logging.getLogger("enctools")


def _steep(error: np.ndarray, where: str) -> bool:
    """Whether ``error`` (coefficients [rad]) slopes by MAX_SLOPE or more; warns if so."""
    points = 1 << max(6, math.ceil(math.log2(8 * error.size)))
    slope = float(np.max(np.abs(synthesize(error * (1j * np.arange(error.size)), points))))
    if np.isfinite(slope) and slope < MAX_SLOPE:
        return False
    log.warning("the angle coordinate's error as solved %s slopes by up to %.3g rad/rad "
                "(at most %g is taken out): it is left as it was; noise amplified through "
                "ill-conditioned harmonics? narrow the band or move heads", where, slope,
                MAX_SLOPE)
    return True


def _rms(c: np.ndarray) -> float:
    """RMS over the angle of the curve of coefficients ``c`` (its unit), constant term aside."""
    return float(np.sqrt(np.sum(np.abs(c[1:]) ** 2) / 2))


def invert(error: np.ndarray) -> np.ndarray:
    """Coefficients of delta_hat(u) = u - theta(u) [rad], theta solving u = theta + delta(theta).

    ``error``: coefficients c_0..c_K of delta(theta) [rad] (c_0 the constant offset).
    Newton's method on a uniform grid of u, doubled until the coefficients above half
    its band are at the grid's rounding (delta_hat is not band-limited: the composition
    adds harmonics above K, falling off as (K |delta|)^p); the coefficients are cut
    where they reach it.
    """
    err = np.asarray(error, dtype=np.complex128)
    value = FourierSeries(err, slope=True)
    slope = value.slope()
    floor = 4 * np.finfo(np.float64).eps * float(np.abs(err).sum())  # rounding of delta [rad]
    points = max(_MAP_POINTS[0], 1 << math.ceil(math.log2(16 * err.size)))
    while True:
        u = grid(points)
        shift = value(u)  # delta_hat(u) = delta(u - delta_hat(u)), solved for delta_hat
        last = math.inf
        for _ in range(MAX_ITERATIONS):
            theta = u - shift
            step = (shift - value(theta)) / (1.0 + slope(theta))
            shift -= step
            size = float(np.max(np.abs(step)))
            if size <= floor or size > last / 2:  # converged, or down to rounding
                break
            last = size
        coef = analyse(shift, points // 2 - 1)
        size = np.abs(coef)
        if float(size[points // 4:].max()) <= floor or points >= _MAP_POINTS[1]:
            break
        points *= 2
    keep = np.nonzero(size > floor)[0]
    return coef[: int(keep[-1]) + 1 if keep.size else 1]


@dataclass
class AngleMap:
    """theta = u - delta_hat(u) [rad]: the spindle angle from the coordinate.

    ``error``: coefficients of delta(theta) [rad] it was made from (None: theta = u).
    """

    error: np.ndarray | None = None

    def __post_init__(self) -> None:
        self._series = None if self.error is None else FourierSeries(invert(self.error))

    @property
    def shift(self) -> FourierSeries | None:
        """delta_hat, theta = u - delta_hat(u) [rad]; None for theta = u."""
        return self._series

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """theta [rad] at coordinate values ``u`` [rad]."""
        if self._series is None:
            return np.asarray(u, dtype=np.float64)
        return u - self._series(u)

    def error_coefficients(self, band: int) -> np.ndarray:
        """c_0..c_band of the delta(theta) [rad] the map takes out (zeros for theta = u)."""
        out = np.zeros(band + 1, dtype=np.complex128)
        if self.error is not None:
            k = min(band, self.error.size - 1)
            out[: k + 1] = self.error[: k + 1]
        return out


def spectra_against(rev: Revolution, values: np.ndarray | tuple[np.ndarray, ...],
                    angle: AngleMap, band: int, minus: np.ndarray | None = None) -> np.ndarray:
    """Coefficients c_0..c_band (rad) of ``values`` (C, S) [rad] of revolution ``rev`` (or
    its pieces, :attr:`Revolution.parts`), ``minus`` (C,) [rad] taken off each channel,
    against theta = ``angle(u)``: the revolution's ends map to theta0 and theta0 +/- 2 pi."""
    start = float(angle(np.array([rev.start]))[0])
    return revolution_coefficients(rev.u, values, start, band, angle.shift, minus)


def coordinate_error(model: Model, spectra: np.ndarray
                     ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """delta(theta) [rad] and the solution of ``spectra`` (heads against theta, rad).

    delta's constant term is c, minus the constant term of the reference head (row 0).
    """
    error, parts = model(spectra)
    error = np.array(error, dtype=np.complex128)
    error[0] = -spectra[0, 0].real
    return error, parts


@dataclass
class Settled:
    """What :func:`settle` found on the first revolution.

    ``angle``: the map from u to theta; ``offsets``: each channel's constant term
    against theta [rad] (taken off its readings before they are summed);
    ``iterations`` and ``change``: the iterations made and the RMS change of the
    graduation error in the last [rad].
    """

    angle: AngleMap
    offsets: np.ndarray
    iterations: int
    change: float


def settle(rev: Revolution, band: int, model: Model) -> Settled:
    """Iterate theta on one revolution until the graduation error stops changing.

    ``rev.values``: (heads, S) readings minus the coordinate [rad], the reference first.
    """
    offsets = rev.values.mean(axis=1)  # near enough for the sums to add small numbers
    values = rev.values - offsets[:, None]
    angle = AngleMap()
    previous: np.ndarray | None = None
    change, last = math.inf, math.inf
    iterations = 0
    while iterations < MAX_ITERATIONS:
        iterations += 1
        g = spectra_against(rev, values, angle, band)
        g[:, 0] += offsets
        error, parts = coordinate_error(model, g)
        f = parts["graduation"]
        if _steep(error, "on the first revolution"):
            break
        angle = AngleMap(error)
        if previous is not None:
            change = _rms(f - previous)
            if change <= CONVERGED * _rms(f) or change >= last:
                break
            last = change
        previous = f
    return Settled(angle, g[:, 0].real.copy(), iterations, change)


def taylor_terms(spectra: np.ndarray, shift: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First- and second-order terms that move spectra from theta_hat to theta = theta_hat - d.

    ``spectra`` are those of curves g of samples placed at theta_hat = theta + d(theta);
    placed at theta, the same samples make the curves ``g(x + d) = g + g' d + g'' d^2 / 2``
    to second order, whose spectra are ``spectra + first + second``.
    ``spectra`` (heads, K + 1) and ``shift`` (coefficients of d, K + 1) in rad; the
    products are formed on a grid fine enough that the band 0..K is free of aliasing.
    """
    k = spectra.shape[1] - 1
    points = 1 << max(6, math.ceil(math.log2(4 * k + 2)))
    n = np.arange(k + 1)
    d = synthesize(shift, points)
    first = analyse(synthesize(spectra * (1j * n), points) * d, k)
    second = analyse(synthesize(spectra * -(n**2.0), points) * (0.5 * d * d), k)
    return first, second


@dataclass
class Refined:
    """The solution of the mean spectra against theta, and what bounds its own error.

    ``parts``: the solution's arrays by name (see :data:`Model`); ``change``: their
    change in the last iteration; ``second``: the solution of the second-order term
    alone (what a first-order correction would have left); ``iterations``.
    """

    parts: dict[str, np.ndarray]
    change: dict[str, np.ndarray]
    second: dict[str, np.ndarray]
    iterations: int


def refine(spectra: np.ndarray, used: np.ndarray, model: Model) -> Refined:
    """Solve mean ``spectra`` taken against the theta of delta ``used``, correcting for
    the delta the solution gives (:func:`taylor_terms`) until the solution stops changing.

    ``spectra`` (heads, K + 1) and ``used`` (K + 1) in rad.
    """
    error, parts = coordinate_error(model, spectra)
    change = {name: np.zeros_like(c) for name, c in parts.items()}
    second = np.zeros_like(spectra)
    last = math.inf
    iterations = 0
    while iterations < MAX_ITERATIONS:
        if _steep(error - used, "on the mean of the revolutions"):
            break
        iterations += 1
        first, second = taylor_terms(spectra, error - used)
        corrected = spectra + first + second
        error, new = coordinate_error(model, corrected)
        change = {name: new[name] - parts[name] for name in parts}
        parts = new
        step = _rms(change["graduation"])
        if step <= CONVERGED * _rms(parts["graduation"]) or step >= last:
            break
        last = step
    _, alone = model(second)
    return Refined(parts, change, alone, iterations)
