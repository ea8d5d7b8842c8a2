"""enc points: calibration points from a polygon step run or a CSV table (seed 001 sec. 5.3)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import DATA, run

from enctools.data import streams
from enctools.data.columns import column
from enctools.data.statistics import curve_figures
from enctools.data.streams import read_table
from enctools.data.truth import Truth, interpolation_error
from enctools.data.usertables import read
from enctools.methods.points import distinct, from_table
from enctools.units import DEG


def test_seed001_table1_as_points(tmp_path):
    out = tmp_path / "t1.parquet"
    r = run(f"enc points {DATA}/seed001_table1.csv -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    header, table = streams.read_table(str(out), "points")
    assert table.num_rows == 25  # the 360 deg row repeats 0 deg
    pts = from_table(table)
    x, y, closure = distinct(pts)
    assert x.size == 24 and closure == 0.0
    fig = curve_figures(y)
    assert fig.pp == pytest.approx(5.46, abs=1e-9)  # seed 001: 5.46"
    # Bessel s (seed 001 eq. 8) of the 24 distinct positions; the paper prints 1.30"
    assert fig.std == pytest.approx(1.2674, abs=1e-4)
    assert header.meta["figures"]["peak_to_peak_arcsec"] == pytest.approx(5.46)
    assert "enc points" in header.history[-1]


def test_steps_run_gives_the_head_average_error(ciomp_steps, tmp_path):
    out = tmp_path / "p.parquet"
    r = run(f"enc points {ciomp_steps} -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    header, table = streams.read_table(str(out), "points")
    truth = Truth.from_dict(header.meta["truth"])
    pos = column(table, "position", "deg")  # the stream holds rad
    dev = table.column("deviation").to_numpy()
    assert table.column_names[0] == "position"
    assert table.schema.field("position").metadata[b"unit"] == b"rad"
    assert table.num_rows == 24
    assert np.allclose(np.diff(pos), 15.0, atol=0.01)
    th = pos * DEG
    eps = truth.graduation["A"]
    psi = sum(interpolation_error(truth.signals[h], th + a, 4096) for h, a in (("F1", 0.0),
                                                                             ("F2", np.pi))) / 2
    e = (eps(th) + eps(th + np.pi)) / 2 + psi
    j = np.round(pos / 15).astype(int) % 24
    face = truth.polygon[j]
    want = (e - e[0]) + (face - face[0])  # the true angle of face j: j 15 deg + its error
    # noise: heads 0.05"/sqrt(10), autocollimator 0.03"/sqrt(5), positioning
    assert np.abs(dev - want).max() < 0.1
    assert dev[0] == 0.0


def test_csv_with_direction_and_run(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("# two runs\nposition_deg,deviation_arcsec,direction,run\n"
                 "0,0,1,0\n90,1.5,1,0\n180,-1,-1,1\n270,0.5,-1,1\n")
    r = run(f"enc points {f} | enc info")
    assert r.returncode == 0, r.stderr.decode()
    assert b"4 rows" in r.stdout


@pytest.mark.parametrize("content, what", [
    ("# nothing but comments\n", "no points"),
    ("", "empty file"),
    ("position_deg,deviation_arcsec\n", "no points after the header"),
    ("foo,bar\n0,1\n", "columns found: 'foo', 'bar'"),
    ("position_deg,deviation_arcsec\n0,nan\n", "line 2, column 'deviation_arcsec': NaN"),
    ("position_deg,deviation_arcsec\n0,abc\n", "'abc' is not a number"),
])
def test_bad_csv_is_refused(tmp_path, content, what):
    f = tmp_path / "bad.csv"
    f.write_text(content)
    out = tmp_path / "p.parquet"
    r = run(f"enc points {f} -o {out}")
    assert r.returncode == 2
    err = r.stderr.decode()
    assert err.startswith("enc points: error:") and err.count("\n") == 1, err
    assert what in err
    assert not out.exists()


@pytest.mark.parametrize("opts", ["--faces 3", "--heads F1", "--autocollimator AC"])
def test_steps_run_options_on_a_csv_table_are_refused(tmp_path, opts):
    out = tmp_path / "p.parquet"
    r = run(f"enc points {DATA}/seed001_table1.csv {opts} -o {out}")
    err = r.stderr.decode()
    assert r.returncode == 2 and err.startswith("enc points: error:") and err.count("\n") == 1
    assert opts.split()[0] in err and "is a table" in err
    assert not out.exists()


@pytest.mark.slow
def test_continuous_run_is_not_a_polygon_run(tmp_path):
    out = tmp_path / "p.parquet"
    r = run("enc acquire --rig ciomp-23bit --mode continuous --revolutions 0.01 -q "
            f"| enc points -o {out}")
    assert r.returncode == 2
    assert b"steps" in r.stderr and r.stderr.count(b"\n") == 1
    assert not out.exists()


def test_points_need_a_readings_stream(ciomp_steps, tmp_path):
    r = run(f"enc points {DATA}/seed001_table1.csv | enc points -o {tmp_path}/x.parquet")
    assert r.returncode == 2
    assert b"is a points stream" in r.stderr


MAGALPHA = Path(__file__).resolve().parents[4] / "shared" / "data" / "magalpha"


@pytest.mark.skipif(not MAGALPHA.is_dir(), reason="../shared/data/magalpha is not beside the clone")
@pytest.mark.parametrize("name", ["calibration_data_input_example.csv",
                                  "calibration_data_input_example_add_75.csv",
                                  "calibration_data_input_example_add_260.csv"])
@pytest.mark.slow
def test_real_comparator_table_magalpha(tmp_path, name):
    """Real data: a magnetic angle sensor against a precision stage (reference and
    measured angle in degrees, wrapping at 360). The deviation is dominated by its first
    four harmonics (../shared/data/README.md) and does not depend on the sensor's zero."""
    out = tmp_path / "p.parquet"
    r = run(f"enc points {MAGALPHA / name} -o {out} && enc report --json {out}")
    assert r.returncode == 0, r.stderr.decode()
    _, table = read_table(str(out), "points")
    pos = column(table, "position", "deg")
    dev = table.column("deviation").to_numpy()
    assert table.num_rows == 200 and np.all((pos >= 0) & (pos < 360))
    assert abs(dev.mean()) < 1.0 and np.ptp(dev) < 20 * 3600  # offset removed, no wraps
    # harmonics by least squares on the (non-uniform) reference angles
    x = np.radians(pos)
    cols = [np.ones_like(x)] + [f(n * x) for n in range(1, 11) for f in (np.cos, np.sin)]
    coef, *_ = np.linalg.lstsq(np.column_stack(cols), dev, rcond=None)
    amp = np.hypot(coef[1::2], coef[2::2])
    assert set(np.argsort(-amp)[:4] + 1) == {1, 2, 3, 4}


def test_points_settings_refuse_in_process(tmp_path):
    """The library names fields; the command line shows them as its options."""
    from enctools.cli import points as points_cli
    from enctools.cli.usage import message
    from enctools.errors import SettingsError
    from enctools.methods.points import Settings, make_points

    def shown(err: pytest.ExceptionInfo) -> str:
        return message(err.value, points_cli.command, "points")

    with pytest.raises(SettingsError) as err:
        Settings(faces=0)
    assert re.match(r"^--faces must be > 0, not 0$", shown(err))
    given = Settings(heads=("F1",), faces=3)
    with pytest.raises(SettingsError) as err:
        given.check_table("t.csv")
    assert re.match(r"^--heads, --faces: for a steps run; t.csv is a table", shown(err))
    Settings().check_table("t.csv")
    with pytest.raises(SettingsError) as err:
        make_points(read(str(DATA / "seed001_table1.csv")), Settings(autocollimator="AC"))
    assert "--autocollimator: for a steps run" in shown(err)
    assert given.to_meta() == {"heads": ["F1"], "autocollimator": None, "faces": 3}


def test_make_points_header_carries_settings_and_figures():
    from enctools.methods.points import Settings, make_points

    header, pts = make_points(read(str(DATA / "seed001_table1.csv")), Settings())
    assert len(pts) == 25 and header.meta["settings"] == Settings().to_meta()
    fig = header.meta["figures"]
    assert fig["n"] == 24 and fig["peak_to_peak_arcsec"] == pytest.approx(5.46, abs=1e-9)
    assert fig["max_abs_arcsec"] == pytest.approx(max(abs(pts.deviation)))


def test_figures_or_nan_and_max_abs():
    from enctools.data.statistics import curve_figures, figures_or_nan

    f = curve_figures(np.array([-3.0, 1.0, 2.0]))
    assert f.max_abs == 3.0 and figures_or_nan(np.array([-3.0, 1.0, 2.0])) == f
    for values in (np.array([]), np.array([1.0, np.nan])):
        g = figures_or_nan(values)
        assert g.n == values.size and np.isnan([g.mean, g.std, g.pp, g.rms, g.max_abs]).all()
