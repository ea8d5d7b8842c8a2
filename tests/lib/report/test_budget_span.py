"""A polygon run's Type A says what it spans (issue 41 item 4): the readings of one stop
and how far apart, or the runs and directions of the approaches; a closing reading back
on the first face at 360 deg bounds the drift over the run as a row of its own, carried
the same way through the GTC model of the points."""

from __future__ import annotations

import json
import math

import pyarrow.parquet as pq
import pytest
from conftest import run


def _report(*args) -> dict:
    r = run(["enc", "report", "--json", *map(str, args)])
    assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout)["sections"][0]


def _points(tmp_path, *acquire: str):
    raw, points = tmp_path / "raw.parquet", tmp_path / "points.parquet"
    for cmd in (["enc", "acquire", "--rig", "ciomp-23bit", "--mode", "steps", *acquire,
                 "-o", str(raw)], ["enc", "points", str(raw), "-o", str(points)]):
        r = run(cmd)
        assert r.returncode == 0, r.stderr.decode()
    return points


def test_one_runs_type_a_names_its_readings_and_their_spacing(tmp_path):
    """Seed 001's run: 5 readings 1 ms apart at each of 24 stops; no closing reading, so
    no drift row, and the note says the Type A does not hold the drift."""
    sec = _report(_points(tmp_path))
    names = [c["name"] for c in sec["budget"]["contributions"]]
    assert names[0] == "repeatability: 5 readings 1 ms apart at each stop of one run"
    assert not any(n.startswith("drift") for n in names)
    assert any("does not hold re-setting, zero drift" in n for n in sec["notes"])


def test_a_closing_reading_bounds_the_drift(tmp_path):
    """25 stops, the last at 360 deg on the first face again: a drift row, rectangular of
    half-width |D(360) - D(0)|; the notes no longer list the drift as not declared; the
    GTC model's largest U per point is the budget's U (the drift common to every point)."""
    positions = ",".join(str(15 * i) for i in range(25))
    points = _points(tmp_path, "--positions", positions)
    dev = pq.read_table(points).column("deviation").to_pylist()
    sec = _report(points)
    rows = {c["name"].split(":")[0]: c for c in sec["budget"]["contributions"]}
    drift = rows["drift over the run"]
    assert drift["value"] == pytest.approx(abs(dev[-1] - dev[0]), abs=1e-9)
    assert drift["distribution"] == "rectangular"
    assert drift["divisor"] == pytest.approx(math.sqrt(3.0))
    notes = " ".join(sec["notes"])
    assert "temperature and drift over the run" not in notes
    assert "bounded by the closing reading at 360 deg" in notes
    gtc = sec["covariance"]["difference"]["U_arcsec"]
    assert gtc == pytest.approx(sec["budget"]["U_arcsec"], rel=1e-8)
