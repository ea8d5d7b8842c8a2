"""The GUM combination of a budget (enctools.methods.budget) against hand computation."""

from __future__ import annotations

import math

import pytest

from enctools.errors import DataError
from enctools.methods.budget import DIVISORS, Contribution, combine, coverage_factor


def row(name: str, value: float, divisor: float, c: float, dof: float = math.inf) -> Contribution:
    return Contribution(name, "test", "B", "normal", value, "arcsec", divisor, c, dof)


def test_student_t_factors_of_the_gum_table_g2() -> None:
    # GUM table G.2, p = 95.45 % is not used; p = 95 %: nu 10 -> 2.23, nu 4 -> 2.78
    assert coverage_factor(10) == pytest.approx(2.228, abs=5e-4)
    assert coverage_factor(4) == pytest.approx(2.776, abs=5e-4)
    assert coverage_factor(math.inf) == pytest.approx(1.95996, abs=1e-5)
    assert coverage_factor(math.inf, 0.9973) == pytest.approx(3.0, abs=1e-3)


def test_combined_and_welch_satterthwaite_by_hand() -> None:
    # a Type A standard deviation of 0.3" on 4 dof, a rectangular half-width of 0.5"
    # and an expanded 0.2 um (k = 2) at 2.06"/um
    rows = [row("A", 0.3, 1.0, 1.0, 4.0),
            row("rect", 0.5, DIVISORS["rectangular"], 1.0),
            row("probe", 0.2, 2.0, 2.06, 12.0)]
    b = combine(rows)
    u = [0.3, 0.5 / math.sqrt(3.0), 0.2 / 2.0 * 2.06]
    u_c = math.sqrt(sum(x * x for x in u))
    nu = u_c ** 4 / (u[0] ** 4 / 4.0 + u[2] ** 4 / 12.0)
    assert b.u_c == pytest.approx(u_c, rel=1e-12)
    assert b.nu_eff == pytest.approx(nu, rel=1e-12)
    expanded = b.U
    assert expanded == pytest.approx(coverage_factor(nu) * u_c, rel=1e-12)
    assert [r.u_arcsec for r in b.contributions] == pytest.approx(u, rel=1e-12)


def test_all_type_b_is_infinite_dof_and_a_negative_sensitivity_counts_by_magnitude() -> None:
    b = combine([row("x", 1.0, 1.0, -2.0), row("y", 0.0, 1.0, 1.0, 3.0)])
    assert math.isinf(b.nu_eff) and b.u_c == pytest.approx(2.0)


@pytest.mark.parametrize("bad", [row("nan", math.nan, 1.0, 1.0), row("neg", -1.0, 1.0, 1.0),
                                 row("div", 1.0, 0.0, 1.0), row("dof", 1.0, 1.0, 1.0, 0.0)])
def test_a_bad_contribution_is_a_data_error_naming_it(bad: Contribution) -> None:
    with pytest.raises(DataError, match=bad.name):
        combine([bad])
