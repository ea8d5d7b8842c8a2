"""enc report on a long deviations stream: read a block at a time, never held, and the same
report as a held stream gives (figures, harmonics, results, U, budgets) to rounding."""

from __future__ import annotations

import json
import tracemalloc
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from conftest import DATA, run
from test_report import make_deviations, make_interp

from enctools.data.schemas import make_field
from enctools.data.streams import Header, write_table
from enctools.errors import DataError
from enctools.report import longcurves
from enctools.report.jsonout import to_json
from enctools.report.sections import Options
from enctools.report.summary import build_report
from enctools.units import TWO_PI


def _json(paths: list[Path], hold: int, monkeypatch: pytest.MonkeyPatch) -> dict:
    monkeypatch.setattr(longcurves, "HOLD_ROWS", hold)
    return json.loads(to_json(build_report([str(p) for p in paths], Options(),
                                           lambda done: None), None))


def _same(held: object, long: object, rtol: float, where: str = "") -> None:
    """Every key, string and count alike; every float within ``rtol`` (1e-12 absolute)."""
    if isinstance(held, dict):
        assert isinstance(long, dict) and set(held) == set(long), where
        for k in held:
            _same(held[k], long[k], rtol, f"{where}/{k}")
    elif isinstance(held, list):
        assert isinstance(long, list) and len(held) == len(long), where
        for i, (a, b) in enumerate(zip(held, long, strict=True)):
            _same(a, b, rtol, f"{where}[{i}]")
    elif isinstance(held, float):
        assert long == pytest.approx(held, rel=rtol, abs=1e-12), where
    else:
        assert held == long, where


@pytest.mark.heavy
def test_a_long_stream_reports_what_the_held_one_does(tmp_path, monkeypatch):
    # a grid of 20,000 points, an interpolation error within a period and a comparison
    # (u and the rig's budget): held whole, then read in blocks of 20,000 / 3 rows
    paths = [make_deviations(tmp_path / "dev.parquet", grid=20_000),
             make_interp(tmp_path / "interp.parquet", grid=4_096)]
    held = _json(paths, 1 << 30, monkeypatch)
    long = _json(paths, 1_000, monkeypatch)
    _same(held, long, 1e-9)
    assert long["sections"][0]["results"][0]["listed_every_deg"] == 10.0


def test_a_long_comparison_gets_the_held_ones_budget(tmp_path, monkeypatch):
    # enc compare against the reference encoder the rig declares: its budget takes the
    # rms of u over every row, its U per point sqrt(u_A^2 + u_ref^2) with the budget's k
    # (8192 points: more than the envelope's 2 a column, whose u alone would give another)
    r = run("enc acquire --rig sjtu-dual --revolutions 2 --heads H1,P1 -q -o r.parquet && "
            "enc compare r.parquet --device H1 --reference P1 --points 8192 -q "
            "-o cmp.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    held = _json([tmp_path / "cmp.parquet"], 1 << 30, monkeypatch)
    long = _json([tmp_path / "cmp.parquet"], 100, monkeypatch)
    assert held["sections"][0]["budget"] is not None
    _same(held, long, 1e-9)


def _stream(path: Path, theta: np.ndarray, y: np.ndarray) -> Path:
    schema = pa.schema([make_field("theta", pa.float64(), "rad"),
                        make_field("e", pa.float64(), "arcsec", "deviation", encoder="II")])
    write_table(str(path), Header("deviations", schema, {"history": []}),
                pa.table([theta, y], schema=schema), force=True)
    return path


@pytest.mark.slow  # 10 s
def test_a_long_curve_off_a_uniform_grid_gets_its_harmonics_from_arc_means(
        tmp_path, monkeypatch):
    # random angles in no order: the figures as held, the harmonics from the means of
    # 4096 arcs (order n attenuated by sinc(n pi / 4096): 0.1 % at n = 100)
    rng = np.random.default_rng(7)
    theta = rng.uniform(0, TWO_PI, 60_000)
    y = 1.5 * np.cos(theta - 0.3) + 0.4 * np.cos(7 * theta + 1.0) + 0.2 * np.cos(90 * theta)
    path = _stream(tmp_path / "scatter.parquet", theta, y)
    held = _json([path], 1 << 30, monkeypatch)["sections"][0]["curves"][0]
    long = _json([path], 1_000, monkeypatch)["sections"][0]["curves"][0]
    _same({k: v for k, v in held.items() if not k.startswith("harmonics")},
          {k: v for k, v in long.items() if not k.startswith("harmonics")}, 1e-9)
    truth = {1: 1.5, 7: 0.4, 90: 0.2}
    found = {h["n"]: h["amplitude_arcsec"] for h in long["harmonics"]}
    for n, amplitude in truth.items():
        assert found[n] == pytest.approx(amplitude, rel=2e-3), n


@pytest.mark.heavy
def test_a_long_stream_is_not_held(tmp_path):
    # 1,000,000 grid points (two curves: 24 MB of columns): the report's own arrays
    # stay within a few blocks, whatever the rows (before: every curve held, 100 MB)
    n = 1_000_000
    theta = np.arange(n) * (TWO_PI / n)
    path = _stream(tmp_path / "long.parquet", theta, np.sin(3 * theta))
    tracemalloc.start()
    try:
        report = build_report([str(path)], Options(), lambda done: None)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    curve = report.sections[0].curves[0]
    assert curve.figures.n == n and curve.values.size <= 2 * longcurves.COLUMNS
    assert curve.harmonics is not None
    assert curve.harmonics.amplitude_of(3) == pytest.approx(1.0, rel=1e-12)
    assert peak < 40e6, f"{peak / 1e6:.0f} MB"


#: enc make-rom's options for seed 001's 23-bit code in 16-bit words
ROM = "--bits 23 --allow-no-gain --width 16 -q"


@pytest.fixture(scope="module")
def model(tmp_path_factory) -> Path:
    """An RBF model of seed 001's table 1 (enc fit-rbf; its tables are written with
    --allow-no-gain: its 24 published points do not pass make-rom's gain guard)."""
    d = tmp_path_factory.mktemp("rom")
    r = run(f"enc fit-rbf {DATA / 'seed001_table1.csv'} -q -o model.parquet", cwd=d)
    assert r.returncode == 0, r.stderr
    return d / "model.parquet"


def test_a_long_correction_table_reports_what_the_held_one_does(model, tmp_path, monkeypatch):
    # 2^16 words read in blocks of 1,000: its figures and harmonics as held (the sums over
    # the table's uniform grid of addresses are its FFT to rounding)
    r = run(f"enc make-rom {model} {ROM} --address-bits 16 -o rom.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    held = _json([tmp_path / "rom.parquet"], 1 << 30, monkeypatch)
    long = _json([tmp_path / "rom.parquet"], 1_000, monkeypatch)
    _same(held, long, 1e-9)
    curve = long["sections"][0]["curves"][0]
    assert curve["n_points"] == 1 << 16 and curve["unit"] == "count"


@pytest.mark.slow  # 6 s of CPU: the whole 2^23-word table, twice written and once read
def test_a_23_bit_table_is_reported_without_holding_it(model, tmp_path):
    # seed 001's ROM: 2^23 words, over the 5,000,000 rows a command holds (before: refused
    # with "this command holds at most 5000000 rows"); the report's arrays stay within a few
    # blocks (the table's two columns as float64 would be 134 MB)
    r = run(f"enc make-rom {model} {ROM} -o rom.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    tracemalloc.start()
    try:
        report = build_report([str(tmp_path / "rom.parquet")], Options(), lambda done: None)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    curve = report.sections[0].curves[0]
    words = np.fromfile(_image(model, tmp_path), dtype="<i2").astype(np.float64)
    assert curve.figures.n == words.size == 1 << 23
    assert curve.figures.mean == pytest.approx(words.mean(), rel=1e-12)
    assert curve.figures.pp == words.max() - words.min()
    assert curve.harmonics is not None
    fft = np.abs(np.fft.rfft(words)[1:6]) * 2 / words.size
    assert [curve.harmonics.amplitude_of(n) for n in range(1, 6)] == pytest.approx(fft,
                                                                                  rel=1e-9)
    assert peak < 60e6, f"{peak / 1e6:.0f} MB"


def _image(model: Path, folder: Path) -> Path:
    """The same table as a raw little-endian image (enc make-rom, .bin)."""
    r = run(f"enc make-rom {model} {ROM} -o rom.bin", cwd=folder)
    assert r.returncode == 0, r.stderr
    return folder / "rom.bin"


def test_a_long_correction_table_without_its_size_is_one_line(tmp_path, monkeypatch):
    schema = pa.schema([make_field("address", pa.int64(), ""),
                        make_field("correction", pa.int64(), "count", "correction")])
    n = 5_000
    header = Header("rom", schema, {"history": [], "rom": {"width_bits": 16}})
    table = pa.table([np.arange(n), np.zeros(n, np.int64)], schema=schema)
    write_table(str(tmp_path / "rom.parquet"), header, table, force=True)
    monkeypatch.setattr(longcurves, "HOLD_ROWS", 1_000)
    with pytest.raises(DataError, match=r"rom.parquet: a correction table of over 1000 "
                                        r"addresses must state its size \(rom.entries\)$"):
        build_report([str(tmp_path / "rom.parquet")], Options(), lambda done: None)
