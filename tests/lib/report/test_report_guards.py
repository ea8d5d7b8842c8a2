"""Two guards of enc report (enc-report(1)): harmonics only where the positions resolve
them (FIGURES, harmonics), and no positioning figures of a step run read on the axis'
feedback encoder (FEEDBACK ENCODER). Inputs are made here: tables written with numpy,
step runs of the simulator, scored against its truth and an independent least squares."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, run

DEG = np.pi / 180.0
#: the report's condition limit for harmonics (enc-report(1), harmonics)
RESOLVE = 10.0


def write_table(path: Path, position_deg: np.ndarray, deviation: np.ndarray) -> Path:
    rows = "\n".join(f"{float(p)!r},{float(d)!r}"
                     for p, d in zip(position_deg, deviation, strict=True))
    path.write_text("position_deg,deviation_arcsec\n" + rows + "\n")
    return path


def design(x_deg: np.ndarray, order: int) -> np.ndarray:
    """Columns 1, cos x, sin x, ..., cos Kx, sin Kx (written here, not the library's)."""
    x = np.asarray(x_deg) * DEG
    cols = [np.ones_like(x)]
    for k in range(1, order + 1):
        cols += [np.cos(k * x), np.sin(k * x)]
    return np.column_stack(cols)


def lstsq_harmonics(x_deg: np.ndarray, y: np.ndarray, order: int) -> dict[int, tuple]:
    """n -> (amplitude, phase [rad]) of A cos(n x + p), by numpy's least squares."""
    coef = np.linalg.lstsq(design(x_deg, order), y, rcond=None)[0]
    return {k: (float(np.hypot(coef[2 * k - 1], coef[2 * k])),
                float(np.arctan2(-coef[2 * k], coef[2 * k - 1]))) for k in range(1, order + 1)}


def resolved_order(x_deg: np.ndarray, most: int) -> int:
    """The highest order whose design keeps a condition number within RESOLVE."""
    top = 0
    for k in range(1, most + 1):
        if np.linalg.cond(design(x_deg, k)) > RESOLVE:
            break
        top = k
    return top


def report(*args: object) -> tuple[dict, str]:
    r = run(["enc", "report", "--json", *map(str, args)])
    assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout), r.stderr.decode()


# ------------------------------------------------------------------------- harmonics

ARC = np.linspace(0.0, 41.0, 5)      # 5 positions over 41 deg
RISE = np.array([0.0, 14.0, 30.0, 40.0, 48.0])   # 48" p-p: a first harmonic of 107" fits it


def test_no_harmonics_from_five_positions_over_41_deg(tmp_path):
    """Text, JSON, HTML, and the same table as a points stream: one line says why no
    harmonic is given; none is printed (it was n=1 107\" on these 48\" p-p)."""
    table = write_table(tmp_path / "arc.csv", ARC, RISE)
    assert np.linalg.cond(design(ARC, 1)) > RESOLVE        # the premise, independently
    line = "harmonics: none resolvable from 5 positions over 41 deg"
    r = run(f"enc report {table} --html {tmp_path}/r.html --pdf {tmp_path}/r.pdf")
    assert r.returncode == 0, r.stderr.decode()
    text = r.stdout.decode()
    assert "largest harmonics" not in text
    assert sum(line in ln for ln in text.splitlines()) == 1
    html = (tmp_path / "r.html").read_text()
    assert line in html and "Largest harmonics" not in html
    assert (tmp_path / "r.pdf").stat().st_size > 0
    r = run(f"enc points {table} -q -o {tmp_path}/p.parquet")
    assert r.returncode == 0, r.stderr.decode()
    for source in (table, tmp_path / "p.parquet"):
        curve = report(source)[0]["sections"][0]["curves"][0]
        assert curve["harmonics"] == [] and curve["harmonics_limit_n"] == 0
        assert curve["harmonics_note"].startswith(line)
        assert curve["harmonics_positions"] == 5
        assert curve["harmonics_arc_deg"] == pytest.approx(41.0)
    r = run(f"enc report {table} --max-harmonic 1:10")   # n=1 is not resolved: not checked
    assert r.returncode == 0, r.stderr.decode()


def test_a_step_run_over_41_deg_prints_no_harmonics(tmp_path):
    """The positioning deviation of a step run over 41 deg (sjtu-dual, read on encoder I):
    the same rule, the same line."""
    raw = tmp_path / "arc.arrows"
    r = run(f"enc acquire --rig sjtu-dual --mode steps --positions 0,10.25,20.5,30.75,41 "
            f"--runs 2 --bidirectional --readings 1 --seed 3 -q -o {raw}")
    assert r.returncode == 0, r.stderr.decode()
    curve = report(raw)[0]["sections"][0]["curves"][0]
    assert curve["harmonics"] == []
    assert curve["harmonics_note"].startswith(
        "harmonics: none resolvable from 5 positions over 41 deg")
    text = run(f"enc report {raw}").stdout.decode()
    assert "largest harmonics" not in text


@pytest.mark.parametrize("jitter_deg", [0.0, 3.0])
def test_a_full_turn_of_24_positions_keeps_its_harmonics(tmp_path, jitter_deg):
    """24 positions over the turn, even (the FFT) or jittered by up to 3 deg (least
    squares): all 11 orders printed, equal to numpy's least squares of order 11."""
    rng = np.random.default_rng(5)
    x = np.arange(24) * 15.0 + rng.uniform(-jitter_deg, jitter_deg, 24)
    y = (2.5 * np.cos(x * DEG + 0.2) + 0.9 * np.cos(2 * x * DEG - 1.0)
         + 0.4 * np.sin(5 * x * DEG) + rng.normal(0.0, 0.05, 24))
    assert resolved_order(x, 11) == 11
    want = lstsq_harmonics(x, y, 11)
    curve = report(write_table(tmp_path / "t.csv", x, y), "--top", 11)[0][
        "sections"][0]["curves"][0]
    got = {h["n"]: (h["amplitude_arcsec"], h["phase_rad"]) for h in curve["harmonics"]}
    assert sorted(got) == list(range(1, 12))
    for n, (amplitude, phase) in want.items():
        assert got[n][0] == pytest.approx(amplitude, abs=1e-9), n
        assert np.cos(got[n][1] - phase) == pytest.approx(1.0, abs=1e-9), n
    assert "harmonics_note" not in curve
    if jitter_deg:      # least squares: what the positions cover is stated
        assert curve["harmonics_limit_n"] == 11 and curve["harmonics_left_out"] == []
        assert curve["harmonics_positions"] == 24
        assert curve["harmonics_arc_deg"] == pytest.approx(360.0 - np.max(np.diff(
            np.r_[np.sort(np.mod(x, 360)), np.sort(np.mod(x, 360))[0] + 360])))


def test_half_a_turn_resolves_only_the_orders_its_design_conditions(tmp_path):
    """13 positions over 180 deg: the orders up to the last whose design keeps a condition
    number of 10 are printed, equal to numpy's least squares of that order; the others
    are named on one line."""
    x = np.arange(13) * 15.0
    y = 3.0 * np.cos(x * DEG - 0.4) + 0.5 * np.cos(3 * x * DEG)
    top = resolved_order(x, 6)
    assert top == 1                   # cond 4.0 at n=1, 16 at n=2: the premise
    curve = report(write_table(tmp_path / "half.csv", x, y))[0]["sections"][0]["curves"][0]
    assert curve["harmonics_limit_n"] == top
    assert curve["harmonics_left_out"] == list(range(top + 1, 7))
    (amplitude, phase), = lstsq_harmonics(x, y, top).values()
    assert [h["n"] for h in curve["harmonics"]] == [1]
    assert curve["harmonics"][0]["amplitude_arcsec"] == pytest.approx(amplitude, abs=1e-9)
    assert np.cos(curve["harmonics"][0]["phase_rad"] - phase) == pytest.approx(1.0, abs=1e-9)
    assert curve["harmonics_note"].startswith(
        "harmonics n=2..6 not resolvable from 13 positions over 180 deg")


# ---------------------------------------------------------------- feedback encoder

STEPS = "--mode steps --count 8 --runs 2 --bidirectional --readings 1 --seed 11 -q"


@pytest.fixture(scope="module")
def step_runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Bidirectional 8-target step runs, 2 runs: ciomp-23bit (its one encoder A is the
    feedback), sjtu-dual (feedback II, encoder I recorded too) and sjtu-dual with
    feedback I."""
    d = tmp_path_factory.mktemp("feedback")
    rig = (ROOT / "enctools" / "rigs" / "sjtu-dual.toml").read_text()
    assert 'feedback = "II"' in rig
    (d / "sjtu-fb-I.toml").write_text(rig.replace('feedback = "II"', 'feedback = "I"', 1))
    for name, rig_arg in (("ciomp", "ciomp-23bit"), ("sjtu", "sjtu-dual"),
                          ("sjtu-fb-I", str(d / "sjtu-fb-I.toml"))):
        r = run(f"enc acquire --rig {rig_arg} {STEPS} -o {d}/{name}.arrows")
        assert r.returncode == 0, r.stderr.decode()
    return d


def _truth(path: Path):
    from enctools.data.streams import open_input
    from enctools.data.truth import Truth
    with open_input(str(path)) as s:
        return Truth.from_dict(s.meta["truth"])


def _head_mean(truth, encoder: str, heads_deg: tuple[float, ...], x: np.ndarray) -> np.ndarray:
    """The graduation error [arcsec] of the mean of heads at ``heads_deg`` at angles x [rad]."""
    eps = truth.graduation[encoder]
    return np.mean([eps(x + a * DEG) for a in heads_deg], axis=0)


def test_a_run_read_on_the_feedback_encoder_gets_no_figures(step_runs):
    """ciomp-23bit: encoder A is the feedback, so A - target is the servo loop. No ISO
    230-2 (nor VDI/DGQ 3441) figures, a note and one warning line naming why; the
    polygon of the same run gives the axis' figures, which follow the truth."""
    path = step_runs / "ciomp.arrows"
    for standard, key in (("iso230-2", "iso230_2"), ("vdi3441", "vdi3441")):
        doc, err = report(path, "--standard", standard)
        sec = doc["sections"][0]
        assert key not in sec
        name = "ISO 230-2" if key == "iso230_2" else "VDI/DGQ 3441"
        why = [n for n in sec["notes"] if n.startswith(f"no {name} figures: encoder A is "
                                                       "the axis' feedback")]
        assert len(why) == 1 and "servo loop" in why[0] and "enc points" in why[0]
        warnings = [ln for ln in err.splitlines() if "WARNING" in ln]
        assert len(warnings) == 1 and "feedback" in warnings[0] and str(path) in warnings[0]
        assert "the axis' feedback (the servo loop)" in sec["info"]["positioning read on"]
    text = run(f"enc report {path}").stdout.decode()
    assert "ISO 230-2 (R = 4s" not in text and "no ISO 230-2 figures: encoder A is" in text
    # what the guard keeps out: the loop's E is a fraction of the axis' E
    loop = report(path, "--servo-loop")[0]["sections"][0]
    assert any(n.startswith("ISO 230-2 figures of the servo loop") for n in loop["notes"])
    r = run(f"enc points {path} -q | enc report --json")
    assert r.returncode == 0, r.stderr.decode()
    axis = json.loads(r.stdout)["sections"][0]["iso230_2"]
    x = np.radians([p["position_deg"] for p in axis["positions"]])
    truth_pp = np.ptp(_head_mean(_truth(path), "A", (0.0, 180.0), x))
    assert axis["axis"]["M"] == pytest.approx(truth_pp, abs=0.3)
    assert loop["iso230_2"]["axis"]["E"] < 0.1 * axis["axis"]["E"]


@pytest.mark.parametrize("run_name, measured, feedback", [
    ("sjtu", "I", "II"), ("sjtu-fb-I", "II", "I")])
def test_a_run_read_on_another_encoder_gets_the_axis_figures(step_runs, run_name, measured,
                                                             feedback):
    """sjtu-dual: the positioning deviation is read on the encoder the axis does not
    position on (I when the feedback is II, II when it is I), without a warning; its
    mean per target is that encoder's error less the feedback's, as the truth gives it."""
    path = step_runs / f"{run_name}.arrows"
    doc, err = report(path)
    sec = doc["sections"][0]
    assert "WARNING" not in err
    assert sec["curves"][0]["name"] == f"encoder {measured} - target"
    assert sec["info"]["positioning read on"] == (
        f"encoder {measured}, independent of the axis' feedback {feedback}")
    iso = sec["iso230_2"]
    assert not any("feedback" in n for n in sec["notes"])
    x = np.radians([p["position_deg"] for p in iso["positions"]])
    heads = {"I": (0.0, 180.0), "II": (0.0, 90.0, 180.0, 270.0)}   # the measuring heads
    truth = _truth(path)
    want = (_head_mean(truth, measured, heads[measured], x)
            - _head_mean(truth, feedback, heads[feedback], x))
    got = np.array([p["mean"] for p in iso["positions"]])
    resid = (got - got.mean()) - (want - want.mean())
    assert np.sqrt(np.mean(resid ** 2)) < 0.03 and np.max(np.abs(resid)) < 0.05
    assert np.ptp(want) > 0.2               # the comparison has something to find
