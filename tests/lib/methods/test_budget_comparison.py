"""The budget of a comparison against a reference encoder: its rows, the reference
encoder's certificate as a Type B row, and the Monte Carlo coverage of its U
(benchmarks/comparison_mc.py, on fewer runs than make bench's)."""

from __future__ import annotations

import math
import sys

import pytest
from conftest import ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))
import comparison_mc

from enctools.methods.budget import comparison_budget


def test_the_reference_encoder_is_a_row_of_the_budget():
    ref = comparison_mc.reference()
    b = comparison_budget(0.01, 19.0, ref)
    names = [c.name for c in b.contributions]
    assert names == ["repeatability of the mean over the revolutions",
                     "calibrated deviation of the reference encoder"]
    row = b.contributions[1]
    assert row.kind == "B" and row.quantity == "reference_encoder"
    assert row.u_arcsec == pytest.approx(0.03) and row.sensitivity == -1.0
    assert b.u_c == pytest.approx(math.hypot(0.01, 0.03))


def test_the_row_of_a_reference_used_without_its_curve_is_its_accuracy():
    """sjtu-dual's encoder I as read: a rectangular bound of 0.37" (seed 000's +-0.27" of
    graduation and +-0.1" of interpolation), u = 0.37 / sqrt 3, four times the
    calibration's 0.03"."""
    ref = comparison_mc.reference("reference_encoder_uncorrected")
    b = comparison_budget(0.01, 19.0, ref)
    row = b.contributions[1]
    assert row.name == "accuracy of the reference encoder, used without its calibrated curve"
    assert row.quantity == "reference_encoder_uncorrected" and row.distribution == "rectangular"
    assert row.u_arcsec == pytest.approx(0.37 / math.sqrt(3)) and row.sensitivity == -1.0
    expanded = b.U
    assert expanded == pytest.approx(1.96 * math.hypot(0.01, 0.37 / math.sqrt(3)), rel=1e-3)


def test_monte_carlo_coverage_of_U_and_without_the_reference_row():
    p = comparison_mc.monte_carlo(800, seed=3)
    assert 0.92 <= p <= 0.98
    assert comparison_mc.monte_carlo(800, seed=3, leave_out_reference=True) < 0.88


@pytest.mark.heavy
def test_monte_carlo_of_an_uncorrected_reference_draws_its_truth():
    """The reference used as it reads: its error is the simulator's encoder I at a random
    angle, not a draw from a declaration. Its bound covers all of it (a bound's U covers
    more than 95 % by construction: at least 0.93 asked); the calibration's row in its
    place, the budget before the row depended on the case, covers about half."""
    assert comparison_mc.monte_carlo(800, seed=3, case="uncorrected") >= 0.93
    assert comparison_mc.monte_carlo(800, seed=3, case="uncorrected",
                                     row="reference_encoder") < 0.6


def test_interpolation_against_the_probes_has_their_rows():
    from enctools.data.rig import load_rig
    from enctools.data.uncertainty import declarations
    from enctools.methods.budget import probe_interpolation_budget

    declared = declarations(load_rig("sjtu-dual").uncertainty, "sjtu-dual")
    b = probe_interpolation_budget(0.004, math.inf, 0.2, 0.2, declared)
    rows = {c.quantity: c for c in b.contributions[1:]}
    assert set(rows) == {"probe", "probe_arm", "temperature"}
    # psi = h (1 + k_p) / L: c = psi per unit scale, -psi / L per metre, -psi alpha per K
    assert rows["probe"].sensitivity == pytest.approx(0.2 * 1e-2)          # per %
    assert rows["probe_arm"].sensitivity == pytest.approx(-0.2 / 0.2 * 1e-3)  # per mm
    assert rows["temperature"].sensitivity == pytest.approx(-0.2 * 11.5e-6)
    assert b.u_c == pytest.approx(math.sqrt(sum(c.u_arcsec ** 2 for c in b.contributions)))
