"""The budget of a step run per target (ISO 230-2): the Type A over the approaches, the
reference instrument's certificate, resolution and alignment, each row's source named
(from the rig file, and from the certificate file's reference standard); of a polygon
step run of several runs or directions; and the Monte Carlo coverage of its U
(benchmarks/steprun_mc.py, on fewer targets than make bench's)."""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest
from conftest import ROOT, run

sys.path.insert(0, str(ROOT / "benchmarks"))
import steprun_mc

from enctools.methods.budget import resolution, step_run_budget

SJTU_CERT = ROOT / "examples" / "sjtu-dual-certificate.toml"


@pytest.fixture(scope="module")
def sjtu_steps(tmp_path_factory):
    """A bidirectional step run of sjtu-dual (axis on encoder II, read on encoder I)."""
    path = tmp_path_factory.mktemp("steprun") / "steps.arrows"
    r = run(f"enc acquire --rig sjtu-dual --mode steps --count 8 --readings 2 --runs 3 "
            f"--bidirectional --seed 5 -o {path}")
    assert r.returncode == 0, r.stderr.decode()
    return path


def _section(*args) -> dict:
    r = run(["enc", "report", "--json", *map(str, args)])
    assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout)["sections"][0]


def test_a_step_run_has_a_budget_with_the_reference_encoders_rows(sjtu_steps):
    sec = _section(sjtu_steps)
    b = sec["budget"]
    rows = {r["name"].split(":")[0]: r for r in b["contributions"]}
    # encoder I is read as it reads (no calibrated curve applied): its row is its accuracy,
    # the rig's bound of 0.37" (rectangular), not its calibration's U of 0.06" at k = 2
    assert list(rows) == ["repeatability of the approaches", "resolution of encoder I",
                          "accuracy of the reference encoder, used without its calibrated "
                          "curve"]
    a = rows["repeatability of the approaches"]
    assert a["type"] == "A" and a["source"] == "this run" and 2 <= a["dof"] <= 4
    res = rows["resolution of encoder I"]
    lsb = 1296000.0 / (180000 * 4096)           # one count of encoder I [arcsec]
    assert res["type"] == "B" and res["u_arcsec"] == pytest.approx(lsb / math.sqrt(24))
    ref = rows["accuracy of the reference encoder, used without its calibrated curve"]
    assert ref["u_arcsec"] == pytest.approx(0.37 / math.sqrt(3))
    assert ref["sensitivity_arcsec_per_unit"] == -1 and ref["distribution"] == "rectangular"
    assert ref["source"].startswith("seed 000: graduation of P within +-0.27 arcsec")
    # each target: U = k sqrt(u_A(target)^2 + u_B^2) with the budget's k
    curve = sec["curves"][0]
    assert curve["coverage_k"] == pytest.approx(b["k"])
    u_b2 = res["u_arcsec"] ** 2 + ref["u_arcsec"] ** 2
    assert curve["expanded_u_max_arcsec"] > b["k"] * math.sqrt(u_b2)
    assert any("temperature: no row" in n for n in sec["notes"])


def test_on_a_certificate_the_reference_row_names_the_standard(sjtu_steps, tmp_path):
    r = run(["enc", "report", str(sjtu_steps), "--certificate", str(SJTU_CERT),
             "--html", str(tmp_path / "c.html")])
    assert r.returncode == 0, r.stderr.decode()
    page = (tmp_path / "c.html").read_text()
    assert "accuracy of the reference encoder, used without its calibrated curve" in page
    assert "certificate LAB-EI-2026-012" in page and "due 2027-06-30" in page
    assert "No uncertainty budget is declared" not in page


def test_the_model_alignment_and_the_feedback_encoder():
    decl = steprun_mc.declared()
    row = resolution(0.1, 4, "encoder X")
    b = step_run_budget(0.02, 5.0, row, decl)
    names = [c.name for c in b.contributions]
    assert names[-1] == "alignment of the reference instrument to the axis"
    assert names[-2] == "accuracy of the reference encoder, used without its calibrated curve"
    assert b.contributions[-1].u_arcsec == pytest.approx(0.03 / math.sqrt(3))
    corrected = step_run_budget(0.02, 5.0, row, decl, corrected=True)
    assert corrected.contributions[-2].name == "calibrated deviation of the reference encoder"
    assert corrected.contributions[-2].u_arcsec == pytest.approx(0.03)
    assert row.u_arcsec == pytest.approx(0.1 / math.sqrt(48))
    u = np.array([c.u_arcsec for c in b.contributions])
    assert b.u_c == pytest.approx(math.sqrt(np.sum(u ** 2)))
    # read on the axis' feedback (the servo loop): its calibration is not a term
    loop = step_run_budget(0.02, 5.0, row, decl, reference=False)
    assert [c.kind for c in loop.contributions] == ["A", "B"]


def test_a_polygon_step_run_of_several_runs_has_a_budget(tmp_path):
    raw, points = tmp_path / "raw.parquet", tmp_path / "points.parquet"
    for cmd in (f"enc acquire --rig ciomp-23bit --mode steps --runs 2 --bidirectional "
                f"--readings 1 -o {raw}", f"enc points {raw} -o {points}"):
        r = run(cmd)
        assert r.returncode == 0, r.stderr.decode()
    sec = _section(points)
    names = [c["name"] for c in sec["budget"]["contributions"]]
    assert names[0] == "repeatability over 2 runs x 2 directions"
    assert "polygon face angle at the point" in names and "autocollimator scale error" in names
    assert not any("no uncertainty budget" in n for n in sec["notes"])


#: targets of the reduced Monte Carlo
TARGETS = 800


@pytest.mark.heavy
def test_monte_carlo_coverage_of_U_and_without_the_reference_row():
    """800 independent targets: at a true coverage of 0.95 the count's standard deviation
    is sqrt(0.95 0.05 / 800) = 0.0077, so 0.92..0.98 is +-3.9 of it (a false alarm about
    1e-4; the seed is fixed, so the test is deterministic). Leaving the reference
    encoder's row out (u 0.03" against u_A up to 0.02") covers about 0.81 and must fail.
    The reference as read (every step run enc report reads), its error the simulator's
    encoder I at a random angle: its bound covers it all (at least 0.93 asked: a bound's U
    covers more than 95 % by construction); the calibration's row in its place, the
    budget before the row depended on the case, covers about 0.43."""
    p = steprun_mc.monte_carlo(TARGETS, seed=3)
    assert 0.92 <= p <= 0.98
    assert steprun_mc.monte_carlo(TARGETS, seed=3, leave_out="reference_encoder") < 0.88
    assert steprun_mc.monte_carlo(TARGETS, seed=3, case="uncorrected") >= 0.93
    assert steprun_mc.monte_carlo(TARGETS, seed=3, case="uncorrected",
                                  row="reference_encoder") < 0.6


def test_the_demo_certificate_of_seed_000_carries_the_step_runs_budget(tmp_path):
    """make demo's seed 000 certificate holds the axis' step run (examples/sjtu-dual.mk):
    read from its PDF as a receiver reads it, every target has its row with U, and the
    budget names encoder I's certificate as the certificate file lists it."""
    from pypdf import PdfReader

    steps, pdf = tmp_path / "steps.parquet", tmp_path / "cert.pdf"
    r = run(f"enc acquire --rig sjtu-dual --mode steps --count 8 --runs 5 --bidirectional "
            f"--readings 2 -o {steps}")
    assert r.returncode == 0, r.stderr.decode()
    r = run(["enc", "report", str(steps), "--certificate", str(SJTU_CERT), "--pdf", str(pdf)])
    assert r.returncode == 0, r.stderr.decode()
    text = "\n".join(p.extract_text() for p in PdfReader(pdf).pages)
    solid = "".join(text.split())       # a table's cell may wrap anywhere
    for i in range(8):                  # every ISO 230-2 target, in the results table
        assert f"{45.0 * i:.3f}" in text
    for row in ("repeatabilityoftheapproaches", "resolutionofencoderI",
                "accuracyofthereferenceencoder,usedwithoutitscalibratedcurve",
                "certificateLAB-EI-2026-012",
                "due2027-06-30", "expandeduncertaintyU=ku_c"):
        assert row in solid, row
    assert "No uncertainty budget is declared" not in text
    assert "calibrationcertificateofencoderI(example)" not in solid    # the rig's words


@pytest.mark.slow  # 9 s of CPU: the largest of make check's tests
def test_monte_carlo_coverage_of_a_polygon_step_run_of_several_runs():
    """60 simulated seed 001 runs of 3 runs each way (benchmarks/polygon_runs_mc.py; make
    bench runs 2000). The targets of one run share its datum and faces, so the count is
    not binomial over targets: by runs, the standard error of the coverage is about 0.012
    on 60 runs (0.9526 over 400 runs with the bench's seed), and 0.91..0.99 is about +-3.3
    of it about 0.95 (the seed is fixed: the test is deterministic). Leaving the
    polygon's rows out (u 0.05" each, the largest Type B) covers about 0.70 and must fail."""
    import polygon_runs_mc

    every, _, _ = polygon_runs_mc.monte_carlo(60, seed=2)
    assert 0.91 <= every <= 0.99
    without, _, _ = polygon_runs_mc.monte_carlo(30, seed=2, leave_out=("polygon",))
    assert without < 0.85
