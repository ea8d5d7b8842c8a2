"""Student's t quantile: the coverage factor k of an expanded uncertainty (GUM G.3).

The one place the commands needed ``scipy.special`` was ``stdtrit`` (and ``ndtri``), and
importing scipy.special costs 0.14-0.35 s of every command's start (scipy 1.17: its
array-API layer loads numpy.f2py and numpy.testing), more than the command's own work on
a small input. This module gives the same quantile from the standard library alone; the
tests hold it to 1e-12 (relative) as a root of the distribution's tail (scipy's
``stdtr``) over the degrees of freedom and probabilities a budget meets, and to the
closed forms of 1, 2 and 4 degrees of freedom near the median.

- nu = inf: the normal quantile (:class:`statistics.NormalDist`, Wichura's AS 241).
- nu >= :data:`LARGE`: the expansion of the t quantile in powers of 1/nu about the normal
  one (Abramowitz and Stegun 26.7.5, terms to 1/nu^4; the first neglected one is below
  1e-17 there).
- otherwise: Newton's method on P(T <= t) = p from the normal quantile, which lies below
  the root: the distribution function is concave there, so the iterates rise to the
  root without overshooting. P is taken from the central probability I_y(1/2, nu/2) or
  the tail I_x(nu/2, 1/2) / 2 (y = t^2 / (nu + t^2), x = 1 - y), whichever has the
  continued fraction that converges fast (modified Lentz; Numerical Recipes, 3rd ed.,
  6.4): each is then accurate to rounding, where the other would be 1 minus it.
"""

from __future__ import annotations

import math
from statistics import NormalDist

#: degrees of freedom from which the 1/nu expansion is used
LARGE = 1.0e4
#: Newton steps and continued-fraction terms at most (neither is reached in practice)
MAX_STEPS = 200
MAX_TERMS = 100_000
_TINY = 1.0e-300
_EPS = 2.0 ** -53
_LOG_SQRT_PI = 0.5 * math.log(math.pi)


def t_quantile(nu: float, p: float) -> float:
    """The quantile t_p of Student's t with ``nu`` degrees of freedom (``math.inf``: the
    normal quantile), P(T <= t_p) = ``p``, for 0 < p < 1 and nu > 0 [dimensionless]."""
    if not 0.0 < p < 1.0:
        raise ValueError(f"probability {p} is not between 0 and 1")
    if not nu > 0.0:
        raise ValueError(f"degrees of freedom {nu} are not positive")
    if p < 0.5:
        return -t_quantile(nu, 1.0 - p)
    if p == 0.5:
        return 0.0
    z = NormalDist().inv_cdf(p)
    if math.isinf(nu):
        return z
    if nu >= LARGE:
        return _expansion(z, nu)
    return _newton(nu, p, z)


def _expansion(z: float, nu: float) -> float:
    """A&S 26.7.5: t = z + g1/nu + g2/nu^2 + g3/nu^3 + g4/nu^4."""
    z2 = z * z
    g1 = (z2 + 1.0) * z / 4.0
    g2 = ((5.0 * z2 + 16.0) * z2 + 3.0) * z / 96.0
    g3 = (((3.0 * z2 + 19.0) * z2 + 17.0) * z2 - 15.0) * z / 384.0
    g4 = ((((79.0 * z2 + 776.0) * z2 + 1482.0) * z2 - 1920.0) * z2 - 945.0) * z / 92160.0
    return z + (g1 + (g2 + (g3 + g4 / nu) / nu) / nu) / nu


def _newton(nu: float, p: float, start: float) -> float:
    """t > 0 with P(T <= t) = ``p`` (> 1/2), from ``start`` <= t."""
    a = nu / 2.0
    log_beta = _log_gamma_ratio(a) - _LOG_SQRT_PI    # ln(1 / B(a, 1/2)), once for all steps
    log_norm = log_beta - 0.5 * math.log(nu)            # the density's at t = 0
    t, last = start, math.inf
    for _ in range(MAX_STEPS):
        step = _short(a, log_beta, t, p) / math.exp(log_norm
                                                     - (a + 0.5) * math.log1p(t * t / nu))
        t += step
        # done at the unit roundoff, or once the steps are rounding noise (no longer halving)
        if abs(step) <= 8.0 * _EPS * t or (abs(step) <= 1e-9 * t and abs(step) > last / 2):
            return t
        last = abs(step)
    raise ArithmeticError(f"t quantile for nu={nu}, p={p} did not converge")


def _short(a: float, log_beta: float, t: float, p: float) -> float:
    """p - P(T <= t) for t >= 0, nu = 2a and ``log_beta`` = ln(1 / B(a, 1/2)), from
    whichever of the central probability P(|T| <= t) = I_y(1/2, a) and the tail
    2 P(T > t) = I_x(a, 1/2) (y = t^2 / (nu + t^2), x = 1 - y) has the fraction that
    converges fast: that one is accurate to rounding where the other would be 1 minus it."""
    if t <= 0.0:
        return p - 0.5
    t2, nu = t * t, a + a
    x, y = nu / (nu + t2), t2 / (nu + t2)
    # x^a y^(1/2) Gamma(a + 1/2) / (Gamma(a) Gamma(1/2)), logs taken without cancellation
    front = math.exp(-a * math.log1p(t2 / nu) + 0.5 * math.log(y) + log_beta)
    if y < 1.5 / (a + 2.5):
        central = front * _fraction(0.5, a, y) / 0.5
        return ((p - 0.5) * 2.0 - central) / 2.0      # both exact: p - 1/2, times 2
    return 0.5 * front * _fraction(a, 0.5, x) / a - (1.0 - p)


def _log_gamma_ratio(a: float) -> float:
    """ln(Gamma(a + 1/2) / Gamma(a)): from math.lgamma for small a, else its asymptotic
    series (DLMF 5.11.13, with B_n(1/2) - B_n(0) = (2^(1-n) - 2) B_n), which keeps the
    digits a difference of two large lgammas loses."""
    if a < 20.0:
        return math.lgamma(a + 0.5) - math.lgamma(a)
    r = 1.0 / (a * a)
    series = (-1.0 / 8.0 + r * (1.0 / 192.0 + r * (-1.0 / 640.0 + r * (17.0 / 14336.0
              + r * (-31.0 / 18432.0))))) / a
    return 0.5 * math.log(a) + series


def _fraction(a: float, b: float, x: float) -> float:
    """The continued fraction of I_x(a, b) (modified Lentz)."""
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > _TINY else _TINY)
    h = d
    for m in range(1, MAX_TERMS):
        m2 = 2 * m
        for num in (m * (b - m) * x / ((qam + m2) * (a + m2)),
                    -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))):
            d = 1.0 + num * d
            d = 1.0 / (d if abs(d) > _TINY else _TINY)
            c = 1.0 + num / c
            c = c if abs(c) > _TINY else _TINY
            h *= d * c
        if abs(d * c - 1.0) <= _EPS:
            return h
    raise ArithmeticError(f"incomplete beta fraction for a={a}, b={b}, x={x} did not converge")
