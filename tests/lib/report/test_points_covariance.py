"""enc report's covariance statement of a polygon run's points (report/covariance.py):
JSON and text, from the model that the budget holds, through GTC."""

from __future__ import annotations

import json

import pytest
from conftest import run


@pytest.fixture(scope="module")
def points(tmp_path_factory, ciomp_steps):
    out = tmp_path_factory.mktemp("cov") / "points.parquet"
    r = run(f"enc points {ciomp_steps} -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    return out


def test_json_states_r_the_difference_and_p_p_of_the_same_model(points):
    r = run(f"enc report {points} --json")
    assert r.returncode == 0, r.stderr.decode()
    section = json.loads(r.stdout)["sections"][0]
    budget, cov = section["budget"], section["covariance"]
    U = [p["U_arcsec"] for p in cov["points"]]
    assert len(U) == 24 and U[0] == 0.0
    assert max(U) == pytest.approx(budget["U_arcsec"], rel=1e-8)   # the budget's worst point
    assert 0.45 < cov["r_min"] <= cov["r_max"] < 0.55
    # a difference of two points: the datum's terms cancel, not sqrt(2) U
    assert cov["difference"]["U_arcsec"] < 1.05 * budget["U_arcsec"]
    pp = cov["pp"]
    assert pp["value_arcsec"] == pytest.approx(section["curves"][-1]["pp_arcsec"])
    assert len(cov["harmonics"]) == 11 and len(cov["correlation"]) == 24


def test_text_prints_the_statement(points):
    r = run(f"enc report {points}")
    text = r.stderr.decode() + r.stdout.decode()
    assert "covariance (GTC, the budget's model per point)" in text
    assert "two points correlate with r = 0.50" in text
    assert "Peak-to-peak, as the difference of the extreme points" in text
