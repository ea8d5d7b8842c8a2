"""enc fit-rbf: the periodic RBF network of seed 001 (eqs. 5-7) and the Fourier fit."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DATA, ROOT, run

from enctools.data import streams
from enctools.data.readings import head_angle, head_info
from enctools.data.truth import Motion
from enctools.data.usertables import read
from enctools.methods.points import distinct, points_from_table
from enctools.models.curve_model import from_stream
from enctools.models.fourier import fit_fourier
from enctools.models.rbf import design_matrix, fit_rbf
from enctools.units import ARCSEC, DEG


@pytest.fixture(scope="module")
def table1():
    return distinct(points_from_table(read(str(DATA / "seed001_table1.csv")))[0])[:2]


def test_gaussian_unit_is_one_half_at_the_spread():
    # seed 001 eq. (6): exp(-0.8326^2 d^2 / c^2) = 1/2 at d = c (0.8326 ~ sqrt(ln 2))
    r = design_matrix(np.array([20.0 * DEG]), np.array([0.0]), 20.0)
    assert r[0, 0] == pytest.approx(0.5, abs=1e-4)


def test_rbf_reproduces_table1_with_24_units(table1):
    x, y = table1
    m = fit_rbf(x, y, 15.0, goal=1e-4)
    assert m.centres_deg.size == 24  # the paper's 24 hidden nodes
    assert np.abs(y - m(x)).max() < 1e-6


def test_rbf_is_periodic(table1):
    x, y = table1
    m = fit_rbf(x, y, 15.0)
    assert m(np.array([0.0]))[0] == pytest.approx(m(np.array([360.0]))[0], abs=1e-12)
    a, b = m(np.array([359.9999, 0.0001]))
    assert abs(a - b) < 1e-3  # continuous across 0/360 deg (chord distance)


def test_fourier_12_harmonics_reproduces_table1(table1):
    x, y = table1
    f = fit_fourier(x, y, 12)
    assert np.abs(y - f(x)).max() < 1e-6
    # sin(12 x) vanishes at 24 points every 15 deg: named, set to zero
    assert f.undetermined == ["b12"] and abs(f.b[12]) < 1e-9


@pytest.mark.slow
def test_fit_rbf_command_on_table1(tmp_path):
    for kernel, extra in (("rbf", ""), ("fourier", "--band 12")):
        out = tmp_path / f"{kernel}.parquet"
        r = run(f"enc fit-rbf {DATA}/seed001_table1.csv --kernel {kernel} {extra} -o {out}")
        assert r.returncode == 0, r.stderr.decode()
        err = r.stderr.decode()
        assert 'p-p 5.46"' in err and 'Bessel s 1.2674"' in err
        header, table = streams.read_table(str(out), "model")
        model = from_stream(header, table)
        x, y = distinct(points_from_table(read(str(DATA / "seed001_table1.csv")))[0])[:2]
        assert np.abs(y - model(x)).max() < 1e-6  # evaluated from the stream
        res = header.meta["residuals"]
        assert res["training"]["max_abs_arcsec"] < 1e-6
        if kernel == "rbf":
            assert header.meta["model"]["units"] == 24
            assert res["leave_one_out"]["rms_arcsec"] > 0.1  # a real prediction, not the point
        else:  # 23 terms and a12 fix the 24 points: nothing is left to predict one of them
            assert np.isnan(res["leave_one_out"]["rms_arcsec"])
            assert "no leave-one-out residuals: the 24 points each fix a term" in err
            assert header.meta["model"]["undetermined"] == ["b12"]


@pytest.fixture(scope="module")
def polygon_fit(ciomp_steps, tmp_path_factory):
    """RBF model from the 24 polygon points, hold-out at positions shifted by 5 deg."""
    d = tmp_path_factory.mktemp("rbf")
    rig = (ROOT / "enctools/rigs/ciomp-23bit.toml").read_text()
    # seed 001 table 3: the polygon set 5 deg further on the table
    (d / "shifted.toml").write_text(rig.replace("start_deg = 0.0", "start_deg = 5.0", 1))
    r = run(f"enc acquire --rig {d}/shifted.toml --mode steps --start 5 --seed 7 "
            f"| enc points -o {d}/holdout.parquet")
    assert r.returncode == 0, r.stderr.decode()
    r = run(f"enc points {ciomp_steps} "
            f"| enc fit-rbf --holdout {d}/holdout.parquet -o {d}/m.parquet")
    assert r.returncode == 0, r.stderr.decode()
    return d


@pytest.mark.slow
def test_holdout_residuals_like_table3(polygon_fit):
    header, _ = streams.read_table(str(polygon_fit / "m.parquet"), "model")
    h = header.meta["residuals"]["holdout"]
    assert h["n"] == 24
    # seed 001: 1.30" before, 0.53" at the shifted positions after
    assert h["bessel_std_arcsec"] < 0.6 * h["before_bessel_std_arcsec"]
    assert h["bessel_std_arcsec"] < 0.9


@pytest.mark.slow
def test_correction_of_a_dense_run_against_truth(polygon_fit):
    d = polygon_fit
    r = run("enc acquire --rig ciomp-23bit --mode continuous --revolutions 1 --speed 1 "
            f"--interval 0.002 -o {d}/dense.parquet")
    assert r.returncode == 0, r.stderr.decode()
    header, table = streams.read_table(str(d / "dense.parquet"), "readings")
    mh, mt = streams.read_table(str(d / "m.parquet"), "model")
    model = from_stream(mh, mt)
    lat = header.meta["rig"]["encoders"][0]["latency_s"]
    t = table.column("t").to_numpy()
    theta = Motion.from_dict(header.meta["truth"]["motion"])(t - lat)
    reading = np.mean([head_angle(table.column(h), head_info(header.schema, h))
                       for h in ("F1", "F2")],
                      axis=0)
    before = (reading - theta) / ARCSEC
    after = before - model(np.mod(reading / DEG, 360.0))
    phase = np.mod(theta / DEG, 15.0)
    at = (phase < 0.05) | (phase > 14.95)
    mid = np.abs(phase - 7.5) < 0.05
    factor = before.std() / after.std()
    print(f"std over the turn {before.std():.3f} -> {after.std():.3f} arcsec (x{factor:.2f}); "
          f"at the polygon points {before[at].std():.3f} -> {after[at].std():.3f}; "
          f"half-way between {before[mid].std():.3f} -> {after[mid].std():.3f}")
    assert factor > 2.2  # seed 001: 2.6 (we measure 2.8 with the default, smoothed network)
    # the default does not pass through the polygon points (their noise): it leaves about
    # as much at them as half-way between, a third of the error before
    assert after[at].std() < 0.45 * before[at].std()
    assert after[mid].std() < 0.45 * before[mid].std()


@pytest.mark.slow
def test_fit_rbf_bad_input(tmp_path, ciomp_steps):
    out = tmp_path / "m.parquet"
    r = run(f"enc fit-rbf {ciomp_steps} -o {out}")  # a readings stream
    assert r.returncode == 2 and b"this command reads points" in r.stderr
    empty = tmp_path / "empty.csv"
    empty.write_text("# no points\n")
    r = run(f"enc fit-rbf {empty} -o {out}")
    assert r.returncode == 2 and r.stderr.startswith(b"enc fit-rbf: error:")
    assert r.stderr.count(b"\n") == 1
    one = tmp_path / "one.csv"
    one.write_text("position_deg,deviation_arcsec\n0,1\n360,1\n")
    r = run(f"enc fit-rbf {one} -o {out}")
    assert r.returncode == 2 and b"fewer than 2 targets" in r.stderr
    r = run(f"enc fit-rbf {DATA}/seed001_table1.csv --goal -1 -o {out}")
    assert r.returncode == 2
    assert not out.exists()
    for opts, words in (("--goal nan", "--goal"), ("--band 5", "--band applies"),
                        ("--kernel fourier --spread 10", "--spread applies")):
        r = run(f"enc fit-rbf {DATA}/seed001_table1.csv {opts} -o {out}")
        err = r.stderr.decode()
        assert r.returncode == 2 and err.startswith("enc fit-rbf: error:"), err
        assert err.count("\n") == 1 and words in err, err
        assert not out.exists()


@pytest.mark.slow
def test_check_threshold_exit_1(tmp_path):
    r = run(f"enc fit-rbf {DATA}/seed001_table1.csv --max-std 0.01 -q -o {tmp_path}/m.parquet")
    assert r.returncode == 1 and b"leave_one_out" in r.stderr


@pytest.mark.parametrize("kw, what", [
    ({"goal_arcsec": -1.0}, "--goal must be 0..3600 arcsec, not -1.0"),
    ({"goal_arcsec": float("nan")}, "--goal must be 0..3600 arcsec, not nan"),
    ({"harmonics": 3}, "--band applies to --kernel fourier (the rbf kernel: --spread, --goal)"),
    ({"kernel": "fourier", "spread_deg": 3.0},
     "--spread applies to --kernel rbf (the fourier kernel: --band)"),
    ({"kernel": "spline"}, "--kernel must be one of rbf, fourier, not 'spline'"),
])
def test_fit_settings_refuse(kw, what):
    from enctools.cli import fit_rbf, usage
    from enctools.errors import SettingsError
    from enctools.models.fitting import Settings

    with pytest.raises(SettingsError) as err:
        Settings(**kw)
    assert usage.message(err.value, fit_rbf.command, "fit-rbf") == what  # as the command says it


def test_fit_points_in_process_matches_the_command(table1, tmp_path):
    """fitting.fit_points with its Settings gives the model and residuals enc fit-rbf stores."""
    from enctools.models.fitting import Settings, fit_points

    x, y = table1
    settings = Settings("fourier", harmonics=11)
    assert settings.to_meta() == {"kernel": "fourier", "spread_deg": None, "goal_arcsec": None,
                                  "harmonics": 11, "holdout": None}
    fit = fit_points(x, y, settings)
    out = tmp_path / "f.parquet"
    r = run(f"enc fit-rbf {DATA}/seed001_table1.csv --kernel fourier --band 11 -q -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    header, _ = streams.read_table(str(out), "model")
    assert header.meta["residuals"] == fit.residuals()
    assert header.meta["settings"] == settings.to_meta()
    few = fit_points(x[:2], y[:2], Settings())  # two points: no leave-one-out figures
    assert np.isnan(few.loo["rms_arcsec"]) and few.points["n"] == 2


@pytest.mark.slow
def test_rbf_correction_over_20_seeds(monkeypatch):
    """The README's row over noise seeds 1..20 (make accuracy; test_accuracy.py), the dense
    run sampled every 0.02 s instead of 0.002 s: the lowest factor is held (2.79 here and
    at 0.002 s with fit-rbf's smoothed default)."""
    import sys

    from conftest import run_in_process

    sys.path.insert(0, str(ROOT / "benchmarks"))
    import accuracy

    monkeypatch.setattr(accuracy, "RUN", lambda args, cwd: run_in_process(args, cwd=cwd))
    f = accuracy.over_seeds(accuracy.rbf_dense, range(1, 21), interval=0.02)
    assert f["factor"].min() >= 2.7
