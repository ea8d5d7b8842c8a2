"""The Monte Carlo coverage of the budget of an interpolation error measured against the
probes (benchmarks/interp_mc.py, on fewer curves than make bench's): the probe's scale, the
arm's length and its temperature drawn from sjtu-dual's declarations and propagated through
psi = e (1 + k_p) / ((1 + dL / L)(1 + alpha dT)), not through the budget's own
linearisation."""

from __future__ import annotations

import sys

import pytest
from conftest import ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))
import interp_mc

#: curves of the check
CURVES = 800


@pytest.mark.heavy
def test_the_probe_budget_covers_95_percent_of_the_true_interpolation_error():
    """At 800 curves the binomial standard error at 0.95 is sqrt(0.95 0.05 / 800) = 0.0077,
    so 0.92..0.98 is +-3.9 of it (the seed is fixed: the test is deterministic; make bench
    runs 4000 curves: 0.947 to 0.948 over seeds 1 to 3). The probe's scale row is most of
    the Type B (0.25 % of curves up to 30"): left out, the budget covers about 0.59 and
    must fail."""
    assert 0.92 <= interp_mc.monte_carlo(CURVES, seed=3) <= 0.98
    assert interp_mc.monte_carlo(CURVES, seed=3, leave_out="probe") < 0.8
