"""An uncertainty budget per the GUM (JCGM 100:2008): contributions combined and expanded.

Each input quantity X_i of the measurement model contributes a standard uncertainty
u_i = |c_i| * value_i / divisor_i to the measured deviation [arcsec]: ``value`` is
what was declared or measured, in its own unit (a half-width, an expanded
uncertainty, a standard deviation), the divisor turns it into a standard uncertainty
(sqrt 3 for a rectangular half-width, k for an expanded one, 1 for a standard
deviation) and c_i is the sensitivity coefficient [arcsec per unit of value].

The combined standard uncertainty is u_c = sqrt(sum u_i^2) (uncorrelated inputs,
GUM 5.1.2), its effective degrees of freedom by Welch-Satterthwaite (GUM G.4.1)

    nu_eff = u_c^4 / sum(u_i^4 / nu_i)

and the expanded uncertainty U = k u_c with k the two-sided Student t quantile at
the coverage probability and nu_eff (GUM G.3.2; 1.96 at 95 % when nu_eff is
infinite, as for Type B inputs declared exactly).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from enctools.errors import DataError

#: divisors of the GUM for a declared value of each distribution (GUM 4.3.7-4.3.9)
DIVISORS: dict[str, float] = {
    "normal": 1.0,           # a standard deviation (or an expanded U with divisor k)
    "rectangular": math.sqrt(3.0),
    "triangular": math.sqrt(6.0),
    "u-shaped": math.sqrt(2.0),
}


@dataclass(frozen=True)
class Contribution:
    """One input quantity of the budget (one row of the table).

    ``value`` is in ``unit``; ``sensitivity`` in arcsec per ``unit``; ``dof`` the
    degrees of freedom of u_i (``math.inf`` for a Type B value taken as exact).
    """

    name: str
    source: str
    kind: str
    distribution: str
    value: float
    unit: str
    divisor: float
    sensitivity: float
    dof: float = math.inf

    @property
    def u_arcsec(self) -> float:
        """Standard uncertainty contributed to the deviation [arcsec]."""
        return abs(self.sensitivity) * self.value / self.divisor


@dataclass(frozen=True)
class Budget:
    """A combined budget: its rows, u_c and U [arcsec], nu_eff, k and the coverage."""

    contributions: tuple[Contribution, ...]
    u_c: float
    nu_eff: float
    k: float
    U: float
    coverage: float = 0.95


def coverage_factor(nu_eff: float, coverage: float = 0.95) -> float:
    """Two-sided Student t quantile k at ``coverage`` for ``nu_eff`` degrees of freedom."""
    if not 0.0 < coverage < 1.0:
        msg = f"coverage probability {coverage} is not between 0 and 1"
        raise DataError(msg)
    from scipy import stats

    q = 0.5 + coverage / 2.0
    if math.isinf(nu_eff):
        return float(stats.norm.ppf(q))
    return float(stats.t.ppf(q, nu_eff))


def effective_dof(u: Iterable[float], dof: Iterable[float]) -> float:
    """Welch-Satterthwaite degrees of freedom of the sum of ``u`` [any one unit]."""
    pairs = list(zip(u, dof, strict=True))
    total = math.fsum(ui * ui for ui, _ in pairs)
    denominator = math.fsum(ui ** 4 / nu for ui, nu in pairs if not math.isinf(nu) and ui > 0)
    if denominator == 0.0:
        return math.inf
    return total * total / denominator


def combine(contributions: Iterable[Contribution], coverage: float = 0.95) -> Budget:
    """The budget of uncorrelated ``contributions``: u_c, nu_eff, k and U [arcsec]."""
    rows = tuple(contributions)
    for row in rows:
        if not (math.isfinite(row.value) and row.value >= 0.0 and row.divisor > 0.0
                and math.isfinite(row.sensitivity) and row.dof > 0.0):
            msg = (f"uncertainty contribution {row.name!r}: value {row.value:g} {row.unit}, "
                   f"divisor {row.divisor:g}, sensitivity {row.sensitivity:g} and degrees of "
                   f"freedom {row.dof:g} must be finite, value >= 0, divisor and dof > 0")
            raise DataError(msg)
    u = [row.u_arcsec for row in rows]
    u_c = math.sqrt(math.fsum(ui * ui for ui in u))
    nu_eff = effective_dof(u, (row.dof for row in rows))
    k = coverage_factor(nu_eff, coverage)
    return Budget(rows, u_c, nu_eff, k, k * u_c, coverage)
