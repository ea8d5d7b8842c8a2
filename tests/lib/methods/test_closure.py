"""enc closure: the polygon's face errors and the encoder's deviations separated by circle
closure (enc-closure(1)), against the simulator's truth over several seeds and against an
independent least-squares separation; the closure run of enc acquire; bad runs refused."""

from __future__ import annotations

import json

import numpy as np
import pyarrow as pa
import pytest
from conftest import one_error_line, run, run_in_process, simulate
from test_polygon import encoder_error, fine_rig
from test_summaries import check_keys

from enctools.data import streams
from enctools.data.polygon import read_certificate
from enctools.data.truth import Truth
from enctools.methods import closure
from enctools.methods.points import Settings, from_table
from enctools.units import ARCSEC, TWO_PI


def lstsq_separation(y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The closure solved as a general least-squares problem (not by the Latin square's
    margins): unknowns e (F), d (F), b (F) for y[s, j] = e[j] + d[(j + s) % F] + b[s];
    the minimum-norm solution moved to the gauge e[0] = 0, sum(d) = 0 (the fit does not
    change); s from the residual sum of squares over F^2 - rank degrees of freedom."""
    n = y.shape[0]
    rows = []
    for s in range(n):
        for j in range(n):
            a = np.zeros(3 * n)
            a[j] = a[n + (j + s) % n] = a[2 * n + s] = 1.0
            rows.append(a)
    design = np.array(rows)
    x, _, rank, _ = np.linalg.lstsq(design, y.ravel(), rcond=None)
    e, d = x[:n] - x[0], x[n:2 * n] - x[n:2 * n].mean()
    resid = y.ravel() - design @ x
    return e, d, float(np.sqrt(resid @ resid / (n * n - rank)))


def matrix_from_rows(table: pa.Table, heads: list[str], cpr: int, faces: int) -> np.ndarray:
    """y[s, j] [arcsec] straight from the readings: per (run, step) the mean of the heads'
    counts as an angle and of the autocollimator."""
    run_, step = (table.column(c).to_numpy() for c in ("run", "step"))
    angle = np.mean([table.column(h).to_numpy() for h in heads], axis=0) * TWO_PI / cpr
    ac = table.column("AC").to_numpy()
    y = np.empty((faces, faces))
    for s in range(faces):
        for j in range(faces):
            at = (run_ == s) & (step == j)
            off = np.angle(np.exp(1j * (angle[at].mean() - j * TWO_PI / faces)))  # rad
            y[s, j] = off / ARCSEC - ac[at].mean()
    return y


def test_separation_recovers_what_it_is_given():
    """Exact without noise (any gauge moved to the module's); with noise equal to the
    general least squares and s near the noise put in."""
    rng = np.random.default_rng(3)
    n = 12
    e, d, b = rng.normal(0, 1.0, n), rng.normal(0, 0.3, n), rng.normal(0, 5.0, n)
    s_idx, j_idx = np.indices((n, n))
    clean = e[j_idx] + d[(j_idx + s_idx) % n] + b[s_idx]
    sep = closure.separate(clean)
    assert sep.deviation == pytest.approx(e - e[0], abs=1e-12)
    assert sep.face_error == pytest.approx(d - d.mean(), abs=1e-12)
    assert sep.s < 1e-12 and sep.dof == (n - 1) * (n - 2)
    noisy = clean + rng.normal(0, 0.05, (n, n))
    sep = closure.separate(noisy)
    e_ls, d_ls, s_ls = lstsq_separation(noisy)
    assert sep.deviation == pytest.approx(e_ls, abs=1e-9)
    assert sep.face_error == pytest.approx(d_ls, abs=1e-9)
    assert sep.s == pytest.approx(s_ls, rel=1e-9)
    assert 0.035 < sep.s < 0.065
    with pytest.raises(ValueError, match="F x F"):
        closure.separate(np.zeros((2, 2)))


SEEDS = tuple(range(8))


@pytest.fixture(scope="module")
def closure_runs(tmp_path_factory):
    """Closure runs of ciomp-23bit with a 2^28-count encoder and 0.5" face errors, one per
    noise seed (in-process), with the separation of each."""
    rig = fine_rig(tmp_path_factory.mktemp("closure"))
    out = []
    for seed in SEEDS:
        header, batches = simulate(str(rig), seed, mode="closure")
        table = pa.Table.from_batches(batches)
        out.append((rig, header, table, closure.closure_points(header, table, Settings(), "x")))
    return out


@pytest.mark.slow
def test_faces_and_encoder_within_2u_of_truth(closure_runs):
    """Over 8 seeds, 184 deviations and 192 face errors against the truth, in units of the
    u the method states from its residuals: at least 88 % within 2u (95 % expected; the
    deviations of one run share the error of its position 0), none beyond 4.5u, and
    their RMS near 1 (0.7..1.4: u neither too small nor too large)."""
    z_dev, z_face = [], []
    for rig, header, _, (_, pts, sep) in closure_runs:
        truth = Truth.from_dict(header.meta["truth"])
        e = encoder_error(truth, rig, pts.position_deg)
        z_dev.append((pts.deviation - (e - e[0]))[1:] / sep.u_deviation)
        z_face.append((sep.face_error - np.asarray(truth.polygon)) / sep.u_face)
        assert sep.dof == 23 * 22 and 0.015 < sep.s < 0.03  # 5 readings of heads and AC
    for name, z in (("deviation", np.concatenate(z_dev)), ("face", np.concatenate(z_face))):
        within = np.mean(np.abs(z) <= 2)
        rms = float(np.sqrt(np.mean(z**2)))
        assert within >= 0.88 and np.abs(z).max() < 4.5 and 0.7 < rms < 1.4, (name, within, rms)


@pytest.mark.slow
def test_separation_equals_an_independent_one(closure_runs):
    """The readings turned into y and separated here, by general least squares, without
    the module: equal to 1e-9 arcsec."""
    for _, _, table, (_, pts, sep) in closure_runs:
        cpr = 4096 * 65536
        y = matrix_from_rows(table, ["F1", "F2"], cpr, 24)
        e, d, s = lstsq_separation(y)
        assert pts.deviation == pytest.approx(e, abs=1e-9)
        assert sep.face_error == pytest.approx(d, abs=1e-9)
        assert sep.s == pytest.approx(s, rel=1e-9)


@pytest.mark.slow
def test_closure_pipeline_and_its_certificate_in_enc_points(tmp_path):
    """acquire --mode closure | enc closure --faces-out; the faces file is a certificate
    enc points reads: a step run corrected by it agrees with the closure's deviations
    within their uncertainties."""
    rig = fine_rig(tmp_path)
    pts, faces = tmp_path / "closure.parquet", tmp_path / "polygon.csv"
    r = run(f"enc acquire --rig {rig} --mode closure -q | enc closure -o {pts} "
            f"--faces-out {faces} --json")
    assert r.returncode == 0, r.stderr.decode()
    doc = json.loads(r.stdout)
    check_keys(doc)  # each key in enc-streams(5), SUMMARIES
    assert doc["n_positions"] == 24 and doc["dof"] == 506
    header, table = streams.read_table(str(pts), "points")
    meta = header.meta["closure"]
    assert meta["u_face_arcsec"] == pytest.approx(doc["u_face_arcsec"])
    cert = read_certificate(str(faces))
    assert cert.number.startswith("closure") and "no external standard" in cert.traceability
    assert cert.error_arcsec == pytest.approx(meta["face_error_arcsec"], abs=1e-6)
    truth = Truth.from_dict(header.meta["truth"])
    assert np.abs(cert.error_arcsec - truth.polygon).max() < 4 * meta["u_face_arcsec"]
    steps = tmp_path / "steps.parquet"
    r = run(f"enc acquire --rig {rig} --mode steps --seed 9 -q -o {steps} && "
            f"enc points {steps} --polygon-certificate {faces} -o {tmp_path}/p.parquet")
    assert r.returncode == 0, r.stderr.decode()
    step_dev = from_table(streams.read_table(str(tmp_path / "p.parquet"), "points")[1]).deviation
    closure_dev = from_table(table).deviation
    # the step run's noise (heads, autocollimator; relative to the first point), the
    # certificate's u at two faces, the closure's u
    u = np.sqrt(2 * (0.05**2 / 10 + 0.03**2 / 5) + 2 * meta["u_face_arcsec"] ** 2
                + meta["u_deviation_arcsec"] ** 2)
    assert np.abs(step_dev - closure_dev).max() < 4 * u


def test_not_a_closure_run_is_refused(ciomp_steps, tmp_path):
    out = tmp_path / "p.parquet"
    r = run_in_process(["enc", "closure", str(ciomp_steps), "-o", str(out)])
    assert "not a closure run (mode 'steps')" in one_error_line(r, 2, "enc closure")
    assert not out.exists()


def test_a_closure_run_with_a_hole_is_refused(tmp_path):
    header, batches = simulate("ciomp-23bit", 0, mode="closure", readings=1, settle_s=0.0)
    table = pa.Table.from_batches(batches)
    keep = ~((table.column("run").to_numpy() == 5) & (table.column("step").to_numpy() == 7))
    with pytest.raises(Exception, match="setting 5 lacks position 7"):
        closure.closure_points(header, table.filter(pa.array(keep)), Settings(), "in")
    twice = pa.concat_tables([table, table.slice(0, 1)])
    with pytest.raises(Exception, match="does not fit a closure of 24 faces"):
        closure.closure_points(header, twice, Settings(), "in")


@pytest.mark.parametrize("opts, what", [
    ("--count 12", "--count: not for --mode closure"),
    ("--runs 2", "--runs: not for --mode closure"),
    ("--bidirectional", "--bidirectional: not for --mode closure"),
])
def test_closure_mode_refuses_step_options(tmp_path, opts, what):
    out = tmp_path / "c.parquet"
    r = run_in_process(f"enc acquire --rig ciomp-23bit --mode closure {opts} -o {out}")
    assert what in one_error_line(r, 2)
    assert not out.exists()


def test_closure_mode_needs_a_polygon(tmp_path):
    out = tmp_path / "c.parquet"
    r = run_in_process(f"enc acquire --rig sjtu-dual --mode closure -o {out}")
    assert "has no [polygon]" in one_error_line(r, 2)
    assert not out.exists()


def test_faces_out_and_output_must_differ(tmp_path):
    out = tmp_path / "same.csv"
    r = run_in_process(f"enc closure x.parquet -o {out} --faces-out {out}")
    assert "--faces-out and -o both name" in one_error_line(r, 2, "enc closure")
    assert not out.exists()


def test_a_run_of_one_reading_batches_is_read_as_the_whole_table(tmp_path, monkeypatch):
    """read_run joins the many small batches enc acquire writes into a few arrays (here
    every 7 batches): the same points and face errors as the whole table read at once."""
    path = tmp_path / "run.arrows"
    run(["enc", "acquire", "--rig", "ciomp-23bit", "--mode", "closure", "--readings", "2",
         "--settle", "0", "--seed", "3", "-o", str(path)])
    monkeypatch.setattr(closure, "JOIN_EVERY", 7)
    with streams.open_input(str(path)) as src:
        joined = closure.read_run(src, Settings())
        _, pts, sep = closure.closure_points(src.header, joined, Settings(), "run")
    with streams.open_input(str(path)) as src:
        _, pts0, sep0 = closure.closure_points(src.header, src.read_all(), Settings(), "run")
    assert joined.num_rows == 24 * 24 * 2
    np.testing.assert_array_equal(pts.deviation, pts0.deviation)
    np.testing.assert_array_equal(sep.face_error, sep0.face_error)
    assert sep.s == sep0.s
