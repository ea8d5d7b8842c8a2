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


def test_monte_carlo_coverage_of_U_and_without_the_reference_row():
    p = comparison_mc.monte_carlo(800, seed=3)
    assert 0.92 <= p <= 0.98
    assert comparison_mc.monte_carlo(800, seed=3, leave_out_reference=True) < 0.88


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
