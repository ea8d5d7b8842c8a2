"""Student's t quantile (enctools.methods.student): a root of the t distribution's tail as
scipy.special.stdtr gives it (the distribution, not scipy's quantile: the oldest declared
scipy's stdtrit is off by 3e-9 and its betaincinv by 1e-5 at 1e9 dof), the closed forms of
1, 2 and 4 degrees of freedom near the median, where a distribution function cannot
resolve the root, and the normal quantile; and the coverage factor the budgets print."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import special

from enctools.methods import budget
from enctools.methods.student import LARGE, t_quantile

#: the probabilities a budget meets: one- and two-sided 68 %, 90 %, 95 %, 95.45 %, 99 %,
#: 99.73 %, 99.9 % and beyond
PROBABILITIES = [0.6, 0.8413, 0.9, 0.95, 0.975, 0.97725, 0.99, 0.995, 0.99865, 0.9995,
                 0.99999]
#: degrees of freedom: whole and fractional (Welch-Satterthwaite), both sides of LARGE
DOFS = sorted({*np.geomspace(1.0, 1e7, 240).tolist(), 1.0, 1.5, 2.0, 3.0, 4.0, 10.0,
               LARGE * (1 - 1e-9), LARGE, 1e12})


def relative_error(nu: float, p: float) -> float:
    """|t - t_p| / t_p to first order: the miss of the tail P(T > t) = stdtr(nu, -t) at the
    quantile's t, over the density there times t (the density by lgamma: one route of its
    own)."""
    t = t_quantile(nu, p)
    miss = float(special.stdtr(nu, -t)) - (1.0 - p)
    log_pdf = (math.lgamma((nu + 1) / 2) - math.lgamma(nu / 2) - 0.5 * math.log(nu * math.pi)
               - (nu + 1) / 2 * math.log1p(t * t / nu))
    return abs(miss) / (math.exp(log_pdf) * t)


@pytest.mark.parametrize("p", PROBABILITIES)
def test_it_is_the_root_of_the_distributions_tail_to_1e_12(p):
    assert max(relative_error(nu, p) for nu in DOFS) <= 1e-12


def closed(nu: int, p: float) -> float:
    """The t quantiles of 1, 2 and 4 degrees of freedom from their closed forms."""
    if nu == 1:  # tan(pi (p - 1/2)), from the tail 1 - p (exact) where p nears 1
        return math.tan(math.pi * (p - 0.5)) if p < 0.75 else 1 / math.tan(math.pi * (1 - p))
    if nu == 2:
        return (2 * p - 1) / math.sqrt(2 * p * (1 - p))
    # nu = 4: 2 F(t) - 1 = s (3 - s^2) / 2, s = t / sqrt(4 + t^2) (A&S 26.7.4), which has
    # no cancellation near the median: bisected to the last bit
    lo, hi = 0.0, 1e3
    for _ in range(200):
        mid = (lo + hi) / 2
        s = mid / math.sqrt(4 + mid * mid)
        lo, hi = (mid, hi) if s * (3 - s * s) / 2 < 2 * (p - 0.5) else (lo, mid)
    return (lo + hi) / 2


@pytest.mark.parametrize("nu", [1, 2, 4])
def test_the_closed_forms_near_the_median_where_scipy_is_coarse(nu):
    for p in [0.5 + 1e-9, 0.5 + 1e-6, 0.5001, 0.51, *PROBABILITIES]:
        assert t_quantile(nu, p) == pytest.approx(closed(nu, p), rel=1e-12, abs=0), p


def test_infinite_dof_is_the_normal_quantile_and_large_dof_tend_to_it():
    for p in PROBABILITIES:
        z = float(special.ndtri(p))
        assert t_quantile(math.inf, p) == pytest.approx(z, rel=1e-15)
        ts = [t_quantile(nu, p) for nu in (1, 3, 10, 100, 1e4, 1e6, 1e9)]
        assert all(a > b for a, b in itertools.pairwise(ts))  # falls to z from above
        assert ts[-1] == pytest.approx(z, rel=1e-8)


def test_it_is_odd_about_the_median_and_zero_there():
    assert t_quantile(5.5, 0.5) == 0.0
    for p in PROBABILITIES:
        assert t_quantile(7.3, 1 - p) == -t_quantile(7.3, p)


@pytest.mark.parametrize("nu, p", [(0.0, 0.9), (-1.0, 0.9), (math.nan, 0.9), (3.0, 0.0),
                                   (3.0, 1.0), (3.0, math.nan)])
def test_impossible_arguments_are_refused(nu, p):
    with pytest.raises(ValueError):
        t_quantile(nu, p)


def test_the_coverage_factor_is_the_two_sided_quantile():
    for nu in (1.0, 2.0, 9.0, 14.6, 200.0, 2001.0, 6446655606.0, math.inf):
        for coverage in (0.6827, 0.95, 0.9545, 0.99, 0.999):
            assert budget.coverage_factor(nu, coverage) == t_quantile(nu, 0.5 + coverage / 2)
    assert budget.coverage_factor(math.inf) == pytest.approx(1.959963984540054, rel=1e-15)
    assert budget.coverage_factor(2.0) == pytest.approx(4.302652729749464, rel=1e-13)
    # 6446655606 dof (a budget of H - P): z + (z^3 + z) / (4 nu), the next term 1e-19
    z = 1.959963984540054
    assert budget.coverage_factor(6446655606.0) == pytest.approx(
        z + (z ** 3 + z) / (4 * 6446655606.0), rel=1e-15)
