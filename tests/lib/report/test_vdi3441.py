"""VDI/DGQ 3441 and ISO 230-2 of the same simulated step run, each against an independent
computation written from the definitions in enc-report(1); --standard, --max-vdi and the
runs that get no figures."""

from __future__ import annotations

import json

import numpy as np
import pyarrow as pa
import pytest
from conftest import one_error_line, run

from enctools.errors import DataError
from enctools.report.vdi3441 import vdi3441
from enctools.units import ARCSEC

TARGETS, RUNS = 8, 5


@pytest.fixture(scope="module")
def points(tmp_path_factory):
    """A bidirectional polygon step run of ciomp-23bit, 5 runs, 3 readings per approach,
    turned into points."""
    path = tmp_path_factory.mktemp("vdi") / "points.arrows"
    r = run(f"enc acquire --rig ciomp-23bit --mode steps --count {TARGETS} --readings 3 "
            f"--bidirectional --runs {RUNS} --seed 11 | enc points -o {path}")
    assert r.returncode == 0, r.stderr.decode()
    return path


def _approaches(path) -> tuple[np.ndarray, np.ndarray]:
    """x_ij per target and run [arcsec] of each direction, arrays (targets, runs), from the
    points stream's columns: the mean of one run's points at one target in one direction,
    with the standards' sign x = actual - target = -deviation (indicated - true)."""
    with pa.ipc.open_stream(str(path)) as reader:
        table = reader.read_all()
    col = {c: table.column(c).to_numpy() for c in ("position", "deviation", "direction", "run")}
    target = np.round(np.mod(np.degrees(col["position"]), 360.0) / (360.0 / TARGETS))
    target = target.astype(int) % TARGETS
    x = {}
    for d in (1, -1):
        x[d] = np.array([[-col["deviation"][(target == i) & (col["direction"] == d)
                                            & (col["run"] == j)].mean()
                          for j in np.unique(col["run"])] for i in range(TARGETS)])
    return x[1], x[-1]


def _mean_s(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    mean = x.mean(axis=1)
    return mean, np.sqrt(((x - mean[:, None]) ** 2).sum(axis=1) / (x.shape[1] - 1))


def _iso(x_up: np.ndarray, x_dn: np.ndarray) -> dict[str, float]:
    """ISO 230-2:2014 axis figures as enc-report(1) states them [arcsec]."""
    (mu, su), (md, sd) = _mean_s(x_up), _mean_s(x_dn)
    B_i = mu - md
    R_i = np.maximum(np.maximum(2 * su + 2 * sd + np.abs(B_i), 4 * su), 4 * sd)
    both = np.concatenate([mu, md])
    return {"B": np.abs(B_i).max(), "B_mean": B_i.mean(), "R_up": 4 * su.max(),
            "R_down": 4 * sd.max(), "R": R_i.max(), "E_up": np.ptp(mu), "E_down": np.ptp(md),
            "E": both.max() - both.min(), "M": np.ptp((mu + md) / 2),
            "A_up": (mu + 2 * su).max() - (mu - 2 * su).min(),
            "A_down": (md + 2 * sd).max() - (md - 2 * sd).min(),
            "A": max((mu + 2 * su).max(), (md + 2 * sd).max())
            - min((mu - 2 * su).min(), (md - 2 * sd).min())}


def _vdi(x_up: np.ndarray, x_dn: np.ndarray) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """VDI/DGQ 3441 as enc-report(1) states it: axis figures and per-target values [arcsec]."""
    (mu, su), (md, sd) = _mean_s(x_up), _mean_s(x_dn)
    xbar = (mu + md) / 2
    U = np.abs(mu - md)
    Ps = 6 * (su + sd) / 2
    axis = {"P_arcsec": (xbar + (U + Ps) / 2).max() - (xbar - (U + Ps) / 2).min(),
            "Pa_arcsec": xbar.max() - xbar.min(), "Ps_max_arcsec": Ps.max(),
            "U_max_arcsec": U.max(), "U_mean_arcsec": U.mean()}
    per = {"mean_up_arcsec": mu, "s_up_arcsec": su, "mean_down_arcsec": md,
           "s_down_arcsec": sd, "mean_arcsec": xbar, "U_arcsec": U, "Ps_arcsec": Ps}
    return axis, per


def _section(path, *args: str) -> dict:
    r = run(f"enc report --json {' '.join(args)} {path}")
    assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout)["sections"][0]


def test_both_standards_equal_independent_computations(points):
    x_up, x_dn = _approaches(points)
    assert x_up.shape == x_dn.shape == (TARGETS, RUNS)
    iso = _section(points)["iso230_2"]                      # the default standard
    want_iso = _iso(x_up, x_dn)
    assert set(iso["axis"]) == set(want_iso)
    for key, value in want_iso.items():
        assert iso["axis"][key] == pytest.approx(value, abs=1e-9), key
    sec = _section(points, "--standard vdi3441")
    assert "iso230_2" not in sec
    vdi = sec["vdi3441"]
    want, per = _vdi(x_up, x_dn)
    assert set(vdi["axis"]) == set(want)
    for key, value in want.items():
        assert vdi["axis"][key] == pytest.approx(value, abs=1e-9), key
    rows = vdi["positions"]
    index = np.round(np.mod([r["position_deg"] for r in rows], 360.0) / 45.0).astype(int) % 8
    assert sorted(index.tolist()) == list(range(TARGETS))
    for key, values in per.items():
        np.testing.assert_allclose([r[key] for r in rows], values[index], rtol=0, atol=1e-9)
    assert all(r["n_up"] == RUNS and r["n_down"] == RUNS for r in rows)
    # the two standards' scatter differ: VDI's Ps = 6 s mean, ISO's R_i = 4 s per direction
    assert want["Ps_max_arcsec"] != pytest.approx(want_iso["R"], rel=1e-3)
    assert want["P_arcsec"] >= want["Pa_arcsec"] > 0


def test_text_html_pdf_and_thresholds_name_the_chosen_standard(points, tmp_path):
    html, pdf = tmp_path / "r.html", tmp_path / "r.pdf"
    r = run(f"enc report --standard vdi3441 --html {html} --pdf {pdf} {points}")
    assert r.returncode == 0, r.stderr.decode()
    text = r.stdout.decode()
    assert "VDI/DGQ 3441 (Ps = 6s" in text and "ISO 230-2 (R = 4s" not in text
    page = html.read_text()
    assert "VDI/DGQ 3441 (1977)" in page and "ISO 230-2 (2014)" not in page
    assert pdf.read_bytes().startswith(b"%PDF")
    iso_text = run(f"enc report {points}").stdout.decode()
    assert "ISO 230-2 (R = 4s" in iso_text and "VDI/DGQ 3441" not in iso_text
    P = _section(points, "--standard vdi3441")["vdi3441"]["axis"]["P_arcsec"]
    over = run(f"enc report --standard vdi3441 --max-vdi P:{P / 2} --max-vdi U_max:100 {points}")
    assert over.returncode == 1
    assert "VDI/DGQ 3441 P" in over.stderr.decode() and "U_max" not in over.stderr.decode()
    assert run(f"enc report --standard vdi3441 --max-vdi P:{P * 2} {points}").returncode == 0
    urad = run(f"enc report --standard vdi3441 --unit urad {points}").stdout.decode()
    line = next(ln for ln in urad.splitlines() if "VDI/DGQ 3441 (" in ln)
    assert "[urad]" in line
    figures = line.split("]: ")[1].split()
    assert float(figures[figures.index("P") + 1]) == pytest.approx(P * ARCSEC * 1e6, abs=1e-3)


@pytest.mark.parametrize(("args", "message"), [
    ("--max-vdi P:1", "--max-vdi checks figures that --standard iso230-2 does not compute"),
    ("--standard vdi3441 --max-iso A:1", "--max-iso checks figures"),
    ("--standard vdi3441 --max-vdi Q:1", "unknown VDI/DGQ 3441 figure 'Q'"),
])
def test_thresholds_of_the_other_standard_are_usage_errors(points, args, message):
    r = run(f"enc report {args} {points}")
    assert message in one_error_line(r, 2, cmd="enc report")


def test_no_vdi_figures_for_sweeps_continuous_or_one_direction(tmp_path):
    cases = {"sweep": "--mode sweep --range 25 --step 5 --readings 2 --runs 2",
             "continuous": "--revolutions 0.05",
             "one direction": "--mode steps --count 8 --runs 3"}
    for why, acquire in cases.items():
        path = tmp_path / f"{why.replace(' ', '_')}.arrows"
        r = run(f"enc acquire --rig sjtu-dual {acquire} --seed 11 -o {path}")
        assert r.returncode == 0, r.stderr.decode()
        sec = _section(path, "--standard vdi3441")
        assert "vdi3441" not in sec and "iso230_2" not in sec
        notes = [n for n in sec.get("notes", []) if n.startswith("no VDI/DGQ 3441 figures")]
        assert len(notes) == 1, (why, sec.get("notes"))
        assert why.split()[0] in notes[0]


def test_library_rejects_what_has_no_figures():
    one = np.ones(3)
    with pytest.raises(DataError, match="fewer than 2 runs"):
        vdi3441(one, one, one, one, one, [5, 5, 5], [5, 1, 5])
    with pytest.raises(DataError, match="differ in length"):
        vdi3441(one, one, one, one, np.ones(2), [5] * 3, [5] * 3)
    with pytest.raises(DataError, match="NaN"):
        vdi3441(one, one, one, one * np.nan, one, [5] * 3, [5] * 3)
    r = vdi3441([0.0, 90.0], [1.0, -1.0], [0.1, 0.2], [0.5, -1.0], [0.3, 0.2], [5, 5], [5, 5])
    axis = r.axis()         # x = 0.75, -1; U = 0.5, 0; Ps = 1.2, 1.2
    assert axis == pytest.approx({"P": 0.75 + 0.85 - (-1 - 0.6), "Pa": 1.75, "Ps_max": 1.2,
                                  "U_max": 0.5, "U_mean": 0.25})
