"""The uncertainty budget of a polygon step run: every formula against an independent
computation, the budget through the real commands, and its Monte Carlo coverage.

The Monte Carlo (GUM Supplement 1) is benchmarks/budget_mc.py's: each run is seed 001's
polygon calibration on a rig drawn from the bundled ciomp-23bit's declarations.
"""

from __future__ import annotations

import json
import math
import sys

import numpy as np
import pytest
from conftest import ROOT, one_error_line, run, simulate

from enctools.data.uncertainty import Declaration, declaration
from enctools.errors import DataError
from enctools.methods import budget as B
from enctools.units import ARCSEC

sys.path.insert(0, str(ROOT / "benchmarks"))
import budget_mc

# ------------------------------------------------------------------ the formulas


def _bias_rms(q: float, sigma: float, grid: int = 400) -> float:
    """rms over x in one count of E[round((x + n)/q) q] - x, n ~ N(0, sigma): summed
    over the quantiser's levels with the normal distribution, not by the Fourier series
    (scipy.special.ndtr is the normal CDF scipy.stats.norm.cdf returns, without importing
    scipy.stats: 0.5 s of CPU in each worker of make check)."""
    from scipy.special import ndtr
    x = (np.arange(grid) + 0.5) / grid * q
    levels = np.arange(-60, 61) * q
    if sigma == 0.0:
        bias = np.round(x / q) * q - x
    else:
        lo = ndtr((levels[:, None] - q / 2 - x) / sigma)
        hi = ndtr((levels[:, None] + q / 2 - x) / sigma)
        bias = np.sum(levels[:, None] * (hi - lo), axis=0) - x
    return float(np.sqrt(np.mean(bias ** 2)))


@pytest.mark.parametrize("sigma", [0.0, 0.02, 0.05, 0.1])
def test_dithered_quantisation_is_the_rms_of_the_quantisers_bias(sigma: float) -> None:
    q = 1296000.0 / 2 ** 23
    assert B.dithered_quantisation(q, sigma) == pytest.approx(_bias_rms(q, sigma), rel=2e-3,
                                                              abs=1e-6)


def test_without_noise_quantisation_is_the_rectangular_half_count() -> None:
    assert B.dithered_quantisation(0.2, 0.0) == pytest.approx(0.1 / math.sqrt(3), rel=1e-3)


def _psi(h: float, arm: float, k_p: float, d_t: float, alpha: float) -> float:
    return h * (1 + k_p) / (arm * (1 + alpha * d_t)) / ARCSEC


def test_probe_sensitivities_are_the_derivatives_of_psi_h_over_l() -> None:
    h, arm, alpha = 2e-6, 0.2, 11.5e-6
    psi = _psi(h, arm, 0, 0, alpha)
    step = 1e-7
    num_l = (_psi(h, arm + step, 0, 0, alpha) - _psi(h, arm - step, 0, 0, alpha)) / (2 * step)
    num_k = (_psi(h, arm, 1e-4, 0, alpha) - _psi(h, arm, -1e-4, 0, alpha)) / 2e-4
    num_t = (_psi(h, arm, 0, 0.1, alpha) - _psi(h, arm, 0, -0.1, alpha)) / 0.2
    assert B.probe_arm_sensitivity(psi, arm) == pytest.approx(num_l, rel=1e-6)
    assert B.probe_scale_sensitivity(psi) == pytest.approx(num_k, rel=1e-6)
    assert B.temperature_sensitivity(psi, alpha) == pytest.approx(num_t, rel=1e-6)


def t_quantile(p: float, nu: float) -> float:
    """Student's t quantile at probability ``p`` (> 0.5) on ``nu`` degrees of freedom, by
    the incomplete beta function (Abramowitz & Stegun 26.7.1: P(|T| > t) = I_x(nu/2, 1/2),
    x = nu / (nu + t^2)): a route of its own to the number the library takes from
    scipy.special.stdtrit, without importing scipy.stats (0.5 s of CPU)."""
    from scipy.special import betaincinv

    x = float(betaincinv(nu / 2, 0.5, 2 * (1 - p)))
    return math.sqrt(nu * (1 / x - 1))


def test_t_quantile_is_students() -> None:
    """Where the quantile has a closed form: Cauchy's at 1 dof, tan(pi (p - 1/2)); at 2 dof,
    (2p - 1) / sqrt(2 p (1 - p)); the normal's 1.959964 in the limit."""
    for p in (0.975, 0.995):
        assert t_quantile(p, 1) == pytest.approx(math.tan(math.pi * (p - 0.5)), rel=1e-12)
        assert t_quantile(p, 2) == pytest.approx((2 * p - 1) / math.sqrt(2 * p * (1 - p)),
                                                 rel=1e-12)
    assert t_quantile(0.975, 1e9) == pytest.approx(1.959964, abs=1e-6)


def test_polygon_run_budget_by_hand() -> None:
    run_ = B.PolygonRun(s_arcsec=0.05, dof=96, readings=5, span_arcsec=4.0, lsb_arcsec=0.1545,
                        heads=2, head_s_arcsec=0.06)
    face = Declaration("polygon", 0.1, "arcsec", "rectangular", source="cert P-1")
    scale = Declaration("autocollimator", 0.2, "%", "normal", k=2.0)
    b = B.polygon_run_budget({"polygon": face, "autocollimator": scale}, run_)
    sigma = math.sqrt(0.06 ** 2 - 0.1545 ** 2 / 12)
    u = [0.05 * math.sqrt(2 / 5), _bias_rms(0.1545, sigma) * math.sqrt(2 / 2),
         0.1 / math.sqrt(3), 0.1 / math.sqrt(3), 4.0 * 0.002 / 2]
    u_c = math.sqrt(sum(x * x for x in u))
    nu = u_c ** 4 / (u[0] ** 4 / 96)
    assert [c.u_arcsec for c in b.contributions] == pytest.approx(u, rel=3e-3)
    assert b.u_c == pytest.approx(u_c, rel=1e-3)
    assert b.nu_eff == pytest.approx(nu, rel=1e-2)
    expanded = b.U
    assert expanded == pytest.approx(t_quantile(0.975, nu) * u_c, rel=1e-3)
    assert [c.sensitivity for c in b.contributions[2:4]] == [-1.0, 1.0]
    assert b.contributions[2].source == "cert P-1"


def test_a_certificates_face_uncertainty_replaces_the_rigs() -> None:
    run_ = B.PolygonRun(0.05, 96, 5, 4.0, 0.1545, 2, 0.06)
    rig_face = Declaration("polygon", 0.5, "arcsec", "normal")
    certified = Declaration("polygon", 0.02, "arcsec", "normal", k=2.0, source="cert")
    b = B.polygon_run_budget({"polygon": rig_face}, run_, face=certified)
    assert [c.u_arcsec for c in b.contributions[2:]] == pytest.approx([0.01, 0.01])


@pytest.mark.parametrize("table, unit_base", [
    ({"value": 1, "unit": "urad"}, ARCSEC ** -1 * 1e-6),
    ({"value": 1, "unit": "deg"}, 3600.0),
    ({"value": 1, "unit": "arcmin"}, 60.0)])
def test_declared_angles_are_converted_to_arcsec(table: dict, unit_base: float) -> None:
    assert declaration("polygon", table, "x").base_value == pytest.approx(unit_base, rel=1e-12)


def test_declarations_of_the_bundled_rigs_match_what_the_simulator_draws() -> None:
    from enctools.data.rig import load_rig

    rig = load_rig("ciomp-23bit")
    face = declaration("polygon", rig.uncertainty["polygon"], "polygon")
    assert face.distribution == "normal"
    assert face.standard == pytest.approx(rig.polygon["face_error_arcsec"])
    scale = declaration("autocollimator", rig.uncertainty["autocollimator"], "ac")
    assert abs(rig.autocollimator["scale_error_ppm"] * 1e-6) <= 2 * scale.standard


def test_a_bad_declaration_is_one_data_error() -> None:
    with pytest.raises(DataError, match=r"polygon\.value must be finite"):
        declaration("polygon", {"value": float("nan"), "unit": "arcsec"}, "polygon")


# ------------------------------------------------------- the run's own figures


def test_points_metadata_pools_the_readings_as_an_independent_loop() -> None:
    import pyarrow as pa

    from enctools.methods.points import Settings, points_from_steps

    header, batches = simulate("ciomp-23bit", 3, mode="steps", count=6, readings=4)
    table = pa.Table.from_batches(batches)
    meta = points_from_steps(header, table, Settings()).run_meta
    cpr = 2 ** 23
    ss = ss_head = 0.0
    dof = 0
    spans = []
    for batch in batches:      # one batch per position
        f1, f2 = (batch.column(h).to_numpy() * (1296000.0 / cpr) for h in ("F1", "F2"))
        ac = batch.column("AC").to_numpy()
        d = (f1 + f2) / 2 - ac
        ss += float(np.sum((d - d.mean()) ** 2))
        ss_head += float(np.sum((f1 - f1.mean()) ** 2) + np.sum((f2 - f2.mean()) ** 2))
        dof += d.size - 1
        spans.append(ac.mean())
    assert meta["dof"] == dof == 6 * 3
    assert meta["s_arcsec"] == pytest.approx(math.sqrt(ss / dof), rel=1e-6)
    assert meta["head_s_arcsec"] == pytest.approx(math.sqrt(ss_head / 2 / dof), rel=1e-6)
    assert meta["span_arcsec"] == pytest.approx(max(abs(a - spans[0]) for a in spans))
    assert meta["readings"] == 4 and meta["heads"] == 2
    assert meta["lsb_arcsec"] == pytest.approx(1296000.0 / cpr)


# --------------------------------------------------------- through the commands


@pytest.fixture(scope="module")
def polygon_points(tmp_path_factory) -> tuple:
    d = tmp_path_factory.mktemp("budget")
    r = run(["enc", "acquire", "--rig", "ciomp-23bit", "--mode", "steps", "-q", "-o",
             str(d / "run.parquet")])
    assert r.returncode == 0, r.stderr.decode()
    r = run(["enc", "points", str(d / "run.parquet"), "-q", "-o", str(d / "pts.parquet")])
    assert r.returncode == 0, r.stderr.decode()
    return d, d / "pts.parquet"


def test_report_prints_every_contribution_and_uses_the_budgets_u(polygon_points) -> None:
    _, pts = polygon_points
    r = run(["enc", "report", str(pts), "--json"])
    assert r.returncode == 0, r.stderr.decode()
    section = json.loads(r.stdout)["sections"][0]
    b = section["budget"]
    names = [c["name"] for c in b["contributions"]]
    assert any("repeatability" in n for n in names) and any("quantisation" in n for n in names)
    assert sum("polygon face" in n for n in names) == 2
    assert any("autocollimator" in n for n in names)
    u = [c["u_arcsec"] for c in b["contributions"]]
    assert b["u_c_arcsec"] == pytest.approx(math.sqrt(sum(x * x for x in u)), rel=1e-12)
    assert b["U_arcsec"] == pytest.approx(b["k"] * b["u_c_arcsec"], rel=1e-12)
    curve = section["curves"][0]
    assert curve["expanded_u_max_arcsec"] == pytest.approx(b["U_arcsec"], rel=1e-12)
    assert curve["coverage_k"] == pytest.approx(b["k"])
    text = run(["enc", "report", str(pts), "--unit", "urad"]).stdout.decode()
    assert "uncertainty budget (GUM) [urad]" in text
    assert f"U {b['U_arcsec'] * ARCSEC * 1e6:.2g}" in text     # two digits (GUM 7.2.6)


def test_a_certificate_applied_in_points_is_the_budgets_polygon_row(polygon_points) -> None:
    """enc points --polygon-certificate: the budget's face rows take the certificate's
    largest u (here U 0.02" at k 2 on every face, u 0.01") and name it, not the rig."""
    d, pts = polygon_points
    cert = d / "cert.csv"
    cert.write_text("# certificate: PC-77\n# unit: arcsec\n# k: 2\nface, error, U\n"
                    + "".join(f"{j}, 0.0, {0.04 if j == 5 else 0.02}\n" for j in range(24)))
    certified = d / "certified.parquet"
    r = run(["enc", "points", str(d / "run.parquet"), "--polygon-certificate", str(cert), "-q",
             "-o", str(certified)])
    assert r.returncode == 0, r.stderr.decode()
    rows = {}
    for path in (pts, certified):
        b = json.loads(run(["enc", "report", str(path), "--json"]).stdout)["sections"][0]["budget"]
        rows[path] = [c for c in b["contributions"] if "polygon face" in c["name"]]
    assert len(rows[certified]) == 2
    for c in rows[certified]:
        assert c["u_arcsec"] == pytest.approx(0.02, rel=1e-9)
        assert "PC-77" in c["source"]
    assert all("PC-77" not in c["source"] for c in rows[pts])
    assert rows[pts][0]["u_arcsec"] != pytest.approx(0.02)


def test_max_u_checks_the_budgets_u(polygon_points) -> None:
    _, pts = polygon_points
    U = json.loads(run(["enc", "report", str(pts), "--json"]).stdout)["sections"][0]["budget"][
        "U_arcsec"]
    assert run(["enc", "report", str(pts), "-q", "--max-u", f"{U * 1.01}"]).returncode == 0
    r = run(["enc", "report", str(pts), "-q", "--max-u", f"{U * 0.99}"])
    assert r.returncode == 1 and "U (k=1.96)" in r.stderr.decode()


def test_a_rig_without_declarations_gets_no_budget_and_says_so(polygon_points) -> None:
    d, _ = polygon_points
    text = (ROOT / "enctools" / "rigs" / "ciomp-23bit.toml").read_text()
    (d / "bare.toml").write_text(text.split("# Type B declarations")[0])
    r = run(["enc", "acquire", "--rig", str(d / "bare.toml"), "--mode", "steps", "-q", "-o", "-"])
    r2 = run(["enc", "points", "-q"], input=r.stdout)
    out = run(["enc", "report", "-", "--json"], input=r2.stdout)
    section = json.loads(out.stdout)["sections"][0]
    assert "budget" not in section
    assert any("declares no [uncertainty]" in n for n in section["notes"])


def test_a_hostile_declaration_in_the_points_is_one_line(polygon_points) -> None:
    import pyarrow.parquet as pq

    d, pts = polygon_points
    table = pq.read_table(pts)
    meta = json.loads(table.schema.metadata[b"enctools"])
    meta["rig"]["uncertainty"]["polygon"]["distribution"] = "lorentzian"
    md = {**table.schema.metadata, b"enctools": json.dumps(meta).encode()}
    pq.write_table(table.replace_schema_metadata(md), d / "bad.parquet")
    r = run(["enc", "report", str(d / "bad.parquet")])
    one_error_line(r, 2, cmd="enc report")
    assert "distribution must be one of" in r.stderr.decode()


# ------------------------------------------------------------------ Monte Carlo

#: runs of the reduced Monte Carlo; one random point (not the datum) per run
RUNS = 200
#: the count of covered points a correct U gives with probability >= 0.999
BAND = (179, 198)


def test_the_band_holds_a_correct_u_with_probability_0_999() -> None:
    """The binomial probabilities summed exactly (no scipy.stats: 0.5 s of CPU to import)."""
    p = 0.95
    held = sum(math.comb(RUNS, k) * p ** k * (1 - p) ** (RUNS - k)
               for k in range(BAND[0], BAND[1] + 1))
    assert held >= 0.999


@pytest.mark.slow
def test_monte_carlo_coverage_of_the_budgets_u() -> None:
    """200 simulated seed 001 polygon runs (GUM S1), each on a rig drawn from the
    declarations. One random point other than the datum per run, so the 200 counts are
    independent (points of one run share the datum's readings and face): a correct U
    covers 179..198 of them with probability 0.9991 (binomial, p = 0.95, tails of
    0.00048 below and 0.00040 above). The same runs' U without the polygon's face
    errors (coverage about 63 %) passes with probability 3e-17, and must fail.
    About 15 s here (75 ms a run, in-process)."""
    results = budget_mc.monte_carlo(RUNS, seed=1)
    _, covered, _ = budget_mc.coverage(results, [budget_mc.budget_of(r) for r in results])
    assert BAND[0] <= covered <= BAND[1], covered
    wrong = [budget_mc.budget_of(r, leave_out=("polygon",)) for r in results]
    _, covered_wrong, _ = budget_mc.coverage(results, wrong)
    assert not BAND[0] <= covered_wrong <= BAND[1], covered_wrong


@pytest.mark.heavy
def test_draw_follows_each_distribution() -> None:
    rng = np.random.default_rng(5)
    for dist, k in (("normal", 2.0), ("rectangular", 1.0), ("triangular", 1.0),
                    ("u-shaped", 1.0)):
        d = Declaration("polygon", 0.3, "arcsec", dist, k=k)
        x = np.array([budget_mc.draw(d, rng) for _ in range(20000)])
        assert np.std(x) == pytest.approx(d.standard, rel=0.03), dist


def test_the_simulated_autocollimators_scale_error_scales_its_indication() -> None:
    """Two runs with the same seeds, one with a scale error kappa of 1 %: each point's
    deviation moves by -kappa (a_j - a_0), a the indications of the run without. Those
    hold the autocollimator's noise (0.03"/sqrt 5 a mean), which the scale does not act
    on: kappa times it, below 0.0005", is the tolerance."""
    import dataclasses

    import pyarrow as pa

    from enctools.data.rig import load_rig
    from enctools.hw import acquire as acq
    from enctools.hw.sim import VirtualRig
    from enctools.methods.points import Settings, points_from_steps

    rig = load_rig("ciomp-23bit")
    out = []
    for ppm in (0.0, 1e4):
        r = dataclasses.replace(rig, autocollimator={**rig.autocollimator,
                                                     "scale_error_ppm": ppm})
        header, batches = acq.acquire(r, VirtualRig(r, seed=4),
                                      acq.resolve(r, {"mode": "steps", "count": 8, "seed": 4}))
        table = pa.Table.from_batches(list(batches))
        ac = np.array([b.column("AC").to_numpy().mean() for b in table.to_batches()])
        out.append((points_from_steps(header, table, Settings()).deviation, ac))
    (d0, a0), (d1, _) = out
    assert np.ptp(a0) > 1.0       # the indications span arcseconds: the test can see 1 %
    assert d1 - d0 == pytest.approx(-0.01 * (a0 - a0[0]), abs=5e-4)


def test_rig_check_lists_the_declarations() -> None:
    r = run("enc rig check ciomp-23bit")
    assert r.returncode == 0
    text = r.stdout.decode()
    assert "uncertainty polygon: 0.05 arcsec normal, u 0.05 arcsec" in text
    assert "uncertainty autocollimator: 0.2 % normal (k=2), u 0.1 %" in text


@pytest.mark.parametrize("table, says", [
    ({"value": 1, "unit": ["arcsec"]}, "is not a unit of angle"),
    ({"value": 1, "unit": "arcsec", "distribution": {"a": 1}}, "distribution must be one of"),
    ({"value": True, "unit": "arcsec"}, "value must be a number"),
    ({"value": 1, "unit": "arcsec", "source": 5}, "source must be a string"),
    ({"value": 1, "unit": "arcsec", "dof": float("inf")}, "dof must be finite and > 0"),
    ([1, 2], "must be a table")])
def test_declarations_of_any_shape_are_one_data_error(table: object, says: str) -> None:
    with pytest.raises(DataError, match=says):
        declaration("polygon", table, "uncertainty.polygon")
