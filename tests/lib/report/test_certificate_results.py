"""enc report: the results per calibrated position (target, deviation per direction and
mean, U with k), the same numbers in the text, the JSON, the HTML and the PDF."""

from __future__ import annotations

import json
import math
import re

import pytest
from conftest import ROOT, run
from test_report import make_deviations

CERT = ROOT / "examples" / "ciomp-23bit-certificate.toml"


@pytest.fixture(scope="module")
def step_run(tmp_path_factory):
    """A bidirectional polygon run of 3 runs (24 targets, 1 reading each) as points."""
    d = tmp_path_factory.mktemp("results")
    raw, points = d / "raw.parquet", d / "points.parquet"
    for cmd in (f"enc acquire --rig ciomp-23bit --mode steps --runs 3 --bidirectional "
                f"--readings 1 -o {raw}", f"enc points {raw} -o {points}"):
        r = run(cmd)
        assert r.returncode == 0, r.stderr.decode()
    return points


@pytest.fixture(scope="module")
def rendered(step_run, tmp_path_factory):
    """The text, the JSON, the HTML and the PDF's text of one report of ``step_run``."""
    from pypdf import PdfReader

    d = tmp_path_factory.mktemp("rendered")
    html, pdf = d / "r.html", d / "r.pdf"
    r = run(["enc", "report", str(step_run), "--certificate", str(CERT), "--html", str(html),
             "--pdf", str(pdf)])
    assert r.returncode == 0, r.stderr.decode()
    j = run(["enc", "report", "--json", str(step_run)])
    assert j.returncode == 0, j.stderr.decode()
    text = "\n".join(p.extract_text() for p in PdfReader(pdf).pages)
    return r.stdout.decode(), json.loads(j.stdout), html.read_text(), text


def test_one_row_per_target_with_both_directions_mean_and_U(rendered):
    _, doc, _, _ = rendered
    tables = doc["sections"][0]["results"]
    assert len(tables) == 1
    rows = tables[0]["rows"]
    assert [r["target_deg"] for r in rows] == [15.0 * i for i in range(24)]
    k = doc["sections"][0]["budget"]["k"]     # Student's, at the budget's nu_eff
    for r in rows:
        assert r["expanded_u_arcsec"] > 0 and r["coverage_k"] == pytest.approx(k, abs=6e-3)
        mean = (r["deviation_up_arcsec"] + r["deviation_down_arcsec"]) / 2
        step = 10.0 ** -_decimals(r["expanded_u_arcsec"])     # each rounded to U's decade
        assert r["deviation_arcsec"] == pytest.approx(mean, abs=1.01 * step)


def _decimals(U: float) -> int:
    """The decimals of U given to two significant digits (GUM 7.2.6): 0.16 is 2."""
    return 1 - math.floor(math.log10(U))


def test_the_same_numbers_in_text_json_html_and_pdf(rendered):
    out, doc, page, pdf = rendered
    rows = doc["sections"][0]["results"][0]["rows"]
    flat = re.sub(r"\s+", " ", pdf)
    lines = out.splitlines()
    for r in rows:
        d = _decimals(r["expanded_u_arcsec"])     # the row's deviations to U's decade
        cells = [f"{r['target_deg']:.3f}"] + [
            f"{r[k]:.{d}f}" for k in ("deviation_up_arcsec", "deviation_down_arcsec",
                                       "deviation_arcsec", "expanded_u_arcsec")
        ] + [f"{r['coverage_k']:.2f}"]
        cells = [c.lstrip("-") if float(c) == 0 else c for c in cells]
        assert any(line.split() == cells for line in lines), cells
        assert "".join(f'<td align="right" class="r">{c}</td>' for c in cells) in page, cells
        assert " ".join(cells) in flat, cells


def test_a_dense_curve_is_listed_every_10_degrees_with_its_U(tmp_path):
    dev = make_deviations(tmp_path / "dev.parquet")
    r = run(["enc", "report", "--json", str(dev)])
    assert r.returncode == 0, r.stderr.decode()
    tables = json.loads(r.stdout)["sections"][0]["results"]
    assert tables and all(t["listed_every_deg"] == 10.0 for t in tables)
    for t in tables:
        assert len(t["rows"]) == 36
        assert all(row["expanded_u_arcsec"] is not None for row in t["rows"])


def test_a_step_run_lists_every_target_per_direction(step_run):
    """The readings of the step run itself (its positioning deviation per target): every
    target with both directions' means, even where no ISO 230-2 figures are given."""
    r = run(["enc", "report", "--json", str(step_run.parent / "raw.parquet")])
    assert r.returncode == 0, r.stderr.decode()
    rows = json.loads(r.stdout)["sections"][0]["results"][0]["rows"]
    assert [row["target_deg"] for row in rows] == [15.0 * i for i in range(24)]
    for row in rows:
        assert {"deviation_up_arcsec", "deviation_down_arcsec"} <= set(row)
        assert row["expanded_u_arcsec"] > 0 and row["coverage_k"] > 2   # rounding: never 0
