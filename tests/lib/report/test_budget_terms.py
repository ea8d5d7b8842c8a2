"""The polygon method's terms beyond the faces and the scale (issue 41 item 2): what a rig
declares (enc-rig(5): autocollimator resolution and noise, face flatness, pyramidal error,
alignment, temperature drift) is a row with its source and sensitivity, carried the same
way through the GTC model of the points; what it does not is named "not declared"."""

from __future__ import annotations

import json
import math

import pytest
from conftest import ROOT, run

from enctools.methods.polygon_terms import POLYGON_TERMS, not_declared

DECLARED = {
    "autocollimator_resolution": (0.05, "rectangular", "display digit 0.1 arcsec"),
    "autocollimator_noise": (0.03, "normal", "turbulence, 100 readings over 10 min"),
    "face_flatness": (0.02, "normal", "flatness 0.05 um over 20 mm"),
    "pyramidal": (0.01, "rectangular", "pyramidal error 5 arcsec, tilt 20 arcsec"),
    "alignment": (0.04, "rectangular", "eccentricity 1 um at 20 mm, after centring"),
    "temperature_drift": (0.03, "rectangular", "0.1 K over a run at 0.3 arcsec/K"),
}


def _section(tmp_path, declared: dict) -> dict:
    rig = (ROOT / "enctools/rigs/ciomp-23bit.toml").read_text()
    for q, (v, dist, src) in declared.items():
        rig += (f'\n[uncertainty.{q}]\nvalue = {v}\nunit = "arcsec"\n'
                f'distribution = "{dist}"\nsource = "{src}"\n')
    (tmp_path / "rig.toml").write_text(rig)
    raw, points = tmp_path / "raw.parquet", tmp_path / "points.parquet"
    for cmd in (f"enc acquire --rig {tmp_path / 'rig.toml'} --mode steps -o {raw}",
                f"enc points {raw} -o {points}", f"enc report --json {points}"):
        r = run(cmd)
        assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout)["sections"][0]


def test_declared_terms_are_rows_with_their_source_and_sensitivity(tmp_path):
    """Each declared term a row: a pair (point and datum) at c = sqrt 2, alignment at
    c = -1, the drift at c = 1, u = |c| value / divisor; u_c holds them; the GTC model's
    largest U per point is the budget's U (to 8 digits); the note names none of them."""
    sec = _section(tmp_path, DECLARED)
    b = sec["budget"]
    rows = {c["name"]: c for c in b["contributions"]}
    for q, (v, dist, src) in DECLARED.items():
        name, kind = POLYGON_TERMS[q]
        row = rows[name]
        c = {"pair": math.sqrt(2.0), "point": -1.0, "common": 1.0}[kind]
        div = math.sqrt(3.0) if dist == "rectangular" else 1.0
        assert row["source"] == src and row["distribution"] == dist
        assert row["sensitivity_arcsec_per_unit"] == pytest.approx(c)
        assert row["u_arcsec"] == pytest.approx(abs(c) * v / div, rel=1e-9)
    assert b["u_c_arcsec"] == pytest.approx(
        math.sqrt(sum(c["u_arcsec"] ** 2 for c in b["contributions"])), rel=1e-12)
    gtc = max(p["U_arcsec"] for p in sec["covariance"]["points"])
    assert gtc == pytest.approx(b["U_arcsec"], rel=1e-8)
    note = next(n for n in sec["notes"] if n.startswith("not declared"))
    assert note == not_declared(set(DECLARED))
    assert "flatness" not in note and "pyramidal" not in note


def test_undeclared_terms_are_named():
    """With none declared, the note names all six and what no key declares yet."""
    note = not_declared(set())
    for words in ("resolution", "air turbulence", "flatness", "pyramidal", "eccentricity",
                  "temperature and drift over the run", "non-linearity", "reversed"):
        assert words in note
    assert "temperature; " in not_declared(set(), closed=True) + "; "
