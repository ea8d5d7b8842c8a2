"""The budget of a self-calibration (enc report of enc selfcal's curve): the Type A over
the revolutions on R - 1 degrees of freedom, the method's own bound, and the harmonics
the head arrangement cannot see (W(n) = 0), bounded by their neighbours and checked
against the simulator's truth."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import run

from enctools.data.streams import open_input
from enctools.data.truth import Truth


@pytest.fixture(scope="module")
def raw(tmp_path_factory):
    path = tmp_path_factory.mktemp("selfcal_budget") / "raw.parquet"
    r = run(f"enc acquire --rig sjtu-dual --revolutions 3 -o {path}")
    assert r.returncode == 0, r.stderr.decode()
    return path


def _selfcal(raw, heads: str, band: int):
    out = raw.parent / f"grad-{heads.replace(',', '')}-{band}.parquet"
    r = run(f"enc selfcal {raw} --method esa --ref-head H1 --heads {heads} --band {band} "
            f"-o {out}")
    assert r.returncode == 0, r.stderr.decode()
    rep = run(f"enc report --json {out}")
    assert rep.returncode == 0, rep.stderr.decode()
    return json.loads(rep.stdout)["sections"][0]


def test_the_demo_arrangement_has_its_type_a_and_bound_and_the_stated_U(raw):
    sec = _selfcal(raw, "H5,H6,H7", 100)
    b = sec["budget"]
    rows = b["contributions"]
    assert [r["type"] for r in rows] == ["A", "B"]
    assert rows[0]["name"] == "repeatability over the 3 revolutions" and rows[0]["dof"] == 2
    # the same U enc selfcal states (its u column and k), now as a budget
    curve = next(c for c in sec["curves"] if c["name"] == "graduation")
    assert curve["coverage_k"] == pytest.approx(b["k"]) == pytest.approx(4.30265, abs=1e-4)
    assert any("no order with W(n) = 0" in n for n in sec["notes"])
    assert any("head_mounting is declared but not in this budget" in n for n in sec["notes"])


def test_blind_harmonics_are_a_row_bounded_as_the_truth_is(raw):
    """H1/H2/H3/H5 (0/90/180/60 deg, all multiples of 30 deg) are blind at 11..13, 23..25,
    ... up to 60: the method sets them to 0, so the curve lacks the truth's content there.
    The row's amplitude (the largest neighbouring order, per blind order, root sum of
    squares) must be of the truth's own there: within a factor 2."""
    sec = _selfcal(raw, "H2,H3,H5", 60)
    rows = sec["budget"]["contributions"]
    blind = rows[2]
    assert blind["name"].startswith("harmonics the heads cannot see (n = 11, 12, 13, 23")
    assert blind["distribution"] == "u-shaped"
    assert blind["divisor"] == pytest.approx(math.sqrt(2))
    truth = Truth.from_dict(open_input(str(raw)).meta["truth"])
    orders = [11, 12, 13, 23, 24, 25, 35, 36, 37, 47, 48, 49, 59, 60]
    amplitude = np.abs(truth.graduation["II"].harmonics(60)[orders])      # arcsec
    rss = float(np.sqrt(np.sum(amplitude ** 2)))
    assert 0.5 * rss <= blind["value"] <= 2.0 * rss
    # U now covers the rms of what the curve lacks there (rss / sqrt 2 at a point) twice
    assert sec["budget"]["U_arcsec"] > 1.96 * rss / math.sqrt(2)
