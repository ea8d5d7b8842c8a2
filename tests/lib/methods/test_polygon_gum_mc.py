"""JCGM 101 Monte Carlo of the polygon run's model (benchmarks/polygon_gum_mc.py; make
bench runs 2e5 draws): the GTC U of a point, of a difference of two points and of p-p
cover 94..96 % of the draws of the model's inputs."""

from __future__ import annotations

import sys

import pytest
from conftest import ROOT

sys.path.insert(0, str(ROOT / "benchmarks"))
from polygon_gum_mc import BAND, monte_carlo


@pytest.mark.parametrize("closure", [False, True])
def test_gtc_U_covers_95_percent_of_the_model_draws(closure):
    res = monte_carlo(40_000, seed=3, closure=closure)
    for name, (coverage, U, half) in res.items():
        assert BAND[0] <= coverage <= BAND[1], name
        assert half == pytest.approx(U, rel=0.03), name      # MC half-width ~ the GUM's U
