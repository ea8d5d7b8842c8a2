"""Tables as instruments and papers print them, read by every command that takes a table.

Each fixture is written here line by line in the layout of its source (an oscilloscope's
CSV export, a quadrature capture's two columns, a paper's table with its primes and
minus signs, an interferometer's ISO 230-2 log with a column per run), never through
enctools' writers; the expected values are computed here from the numbers written.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import one_error_line, run

from enctools.data.streams import read_table

#: the faults of the quadrature captures: offsets [V], amplitudes [V], phase error [deg]
COS_OFFSET, SIN_OFFSET, COS_AMP, SIN_AMP, PHASE_DEG = 0.02, -0.01, 0.50, 0.48, 2.0


def _quadrature(n: int = 2000) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time [s], cosine and sine [V] of a head passing 5 signal periods with the faults above."""
    phase = 2 * np.pi * 5.065 * np.arange(n) / n
    c = COS_OFFSET + COS_AMP * np.cos(phase)
    s = SIN_OFFSET + SIN_AMP * np.sin(phase + math.radians(PHASE_DEG))
    return np.arange(n) * 1e-5, c, s


def _scope_export(path: Path) -> None:
    """An oscilloscope's CSV export: a preamble of comments, titles with units, volts."""
    t, c, s = _quadrature()
    lines = ["# Model,DSOX1204G", "# Channels,CH1 cos,CH2 sin", "# Points,2000",
             "Time [s],CH1 [V],CH2 [V]"]
    lines += [f"{a:.6e},{b:.6f},{d:.6f}" for a, b, d in zip(t, c, s, strict=True)]
    path.write_text("\r\n".join(lines) + "\r\n")


def _fit_of(path: Path) -> dict:
    header, _ = read_table(str(path), "deviations")
    return header.meta["signals"]["H1"]["signals"]


def _check_fit(fit: dict) -> None:
    assert fit["offset_cos_v"] == pytest.approx(COS_OFFSET, abs=1e-5)
    assert fit["offset_sin_v"] == pytest.approx(SIN_OFFSET, abs=1e-5)
    assert fit["ratio"] == pytest.approx(SIN_AMP / COS_AMP, abs=1e-5)
    assert abs(fit["phase_rad"]) == pytest.approx(math.radians(PHASE_DEG), abs=1e-5)


def test_interp_check_reads_a_plain_sin_cos_table_by_title(tmp_path):
    _, c, s = _quadrature()
    table = tmp_path / "capture.tsv"  # sine first, as the capture wrote it
    table.write_text("sin\tcos\n" + "".join(f"{b:.7f}\t{a:.7f}\n" for a, b in zip(c, s)))
    out = tmp_path / "err.parquet"
    r = run(f"enc interp-check --signals {table} --periods-per-rev 18000 --json -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    _check_fit(_fit_of(out))
    curve = json.loads(r.stdout)["curves"][0]
    assert curve["name"] == "H1" and curve["period_arcsec"] == pytest.approx(72.0)


def test_interp_check_reads_an_oscilloscope_export_by_option(tmp_path):
    table = tmp_path / "scope.csv"
    _scope_export(table)
    out = tmp_path / "err.parquet"
    r = run(f"enc interp-check --signals {table} --cos 'CH1 [V]' --sin 3 --heads P1 "
            f"--periods-per-rev 18000 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    header, rows = read_table(str(out), "deviations")
    assert "P1" in rows.column_names
    fit = header.meta["signals"]["P1"]["signals"]
    _check_fit(fit)


@pytest.mark.parametrize(("args", "words"), [
    ("--signals", "--periods-per-rev"),
    ("--signals --periods-per-rev 100", "no cos column found by its title; columns found: "
     "'Time [s]', 'CH1 [V]', 'CH2 [V]'; name them with --cos COL --sin COL"),
    ("", "is a table: a table of sin/cos signals is read with --signals"),
    ("--signals --periods-per-rev 100 --cos 2 --sin 3 --corrected c.parquet",
     "--corrected: "),
])
def test_a_signal_table_that_does_not_map_is_refused_in_one_line(tmp_path, args, words):
    table = tmp_path / "scope.csv"
    _scope_export(table)
    r = run(f"enc interp-check {table} {args} -o {tmp_path}/o.parquet")
    assert words in one_error_line(r, 2, "enc interp-check")
    assert not (tmp_path / "o.parquet").exists()


#: a step run's table as a controller's log gives it: target and mean deviation
STEP_TABLE = ("position_deg,deviation_arcsec\n0,0.0\n45,1.2\n90,2.1\n135,1.5\n180,0.3\n"
              "225,-0.9\n270,-1.8\n315,-1.1\n")


def test_make_rom_takes_a_table_as_enc_points_maps_it(tmp_path):
    (tmp_path / "run.csv").write_text(STEP_TABLE)
    r = run("enc points run.csv -o p.parquet && "
            "enc make-rom p.parquet --target linuxcnc -o a.comp && "
            "enc make-rom run.csv --target linuxcnc --verify -o b.comp", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    a, b = ([ln for ln in (tmp_path / f).read_text().splitlines() if not ln.startswith("#")]
            for f in ("a.comp", "b.comp"))
    assert a == b
    # LinuxCNC's comp file: nominal, and the position to command in each direction
    first = (tmp_path / "b.comp").read_text().split("\n")[1].split()
    assert float(first[0]) == 45.0 and float(first[1]) == pytest.approx(45 - 1.2 / 3600, abs=1e-6)


def test_make_rom_refuses_a_table_for_a_memory_and_mapping_options_for_a_stream(tmp_path):
    (tmp_path / "run.csv").write_text(STEP_TABLE)
    r = run("enc make-rom run.csv --target mif --bits 16 -o t.mif", cwd=tmp_path)
    assert "a table gives points, and here a model or deviations stream is read" in \
        one_error_line(r, 2, "enc make-rom")
    r = run("enc points run.csv -o p.parquet && "
            "enc make-rom p.parquet --position 1 --target linuxcnc -o t.comp", cwd=tmp_path)
    assert "--position: for a table; p.parquet is a stream" in one_error_line(
        r, 2, "enc make-rom")
    assert not (tmp_path / "t.comp").exists() and not (tmp_path / "t.mif").exists()


#: seed 001's table 1 as it comes out of the paper's PDF: degree signs, double primes
#: (typographic quotes for some), Unicode minus signs, a no-break space before a unit
PAPER = """\
# Table 1 Positioning errors of the 23-bit encoder before correction
Angle\tError
0°\t0.00″
15°\t−1.27″
30°\t\u22120.54\u00a0″
45°\t0.83”
60°\t1.96''
75°\t2.41″
90°00′00″\t−1.12″
"""
PAPER_DEG = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0]
PAPER_ARCSEC = [0.0, -1.27, -0.54, 0.83, 1.96, 2.41, -1.12]


def _deviations(path: Path) -> tuple[dict, np.ndarray, np.ndarray]:
    header, rows = read_table(str(path), "points")
    return (header.meta, np.degrees(rows.column("position").to_numpy()),
            rows.column("deviation").to_numpy())


def test_a_table_pasted_from_a_paper_reads_its_primes_and_minus_signs(tmp_path):
    (tmp_path / "paper.txt").write_text(PAPER, encoding="utf-8")
    r = run("enc points paper.txt -o p.parquet && enc fit-rbf paper.txt --kernel fourier "
            "--band 2 -q -o m.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    meta, pos, dev = _deviations(tmp_path / "p.parquet")
    assert pos == pytest.approx(PAPER_DEG, abs=1e-12)
    # the last row's angle in degrees, minutes and seconds
    assert dev == pytest.approx(PAPER_ARCSEC, abs=1e-9)
    assert meta["table"]["units"] == {"position": "deg", "deviation": "arcsec"}


#: an instrument's export with a decimal comma and semicolons (a German locale's CSV)
GERMAN = """\
Sollposition [°];Abweichung vorwärts [µrad];Abweichung rückwärts [µrad]
0;0,0;0,8
90;-5,25;-4,1
180;3,5;4,75
270;-1,0;0,25
"""


def test_a_decimal_comma_table_reads_with_the_option_and_is_named_without(tmp_path):
    (tmp_path / "de.csv").write_text(GERMAN, encoding="utf-8")
    r = run("enc points de.csv --position 1 --deviation 2 -o p.parquet", cwd=tmp_path)
    line = one_error_line(r, 2, "enc points")
    assert "'0,0' is not a number (a decimal comma: give --decimal-comma)" in line
    r = run("enc points de.csv --position 1 --deviation 2 --decimal-comma -o p.parquet",
            cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    _, pos, dev = _deviations(tmp_path / "p.parquet")
    urad_arcsec = 180 / math.pi * 3600 * 1e-6
    assert pos == pytest.approx([0, 90, 180, 270], abs=1e-12)
    assert dev == pytest.approx(np.array([0.0, -5.25, 3.5, -1.0]) * urad_arcsec, abs=1e-9)


#: a laser interferometer's ISO 230-2 log of a rotary axis: a target column, then a
#: column per run and direction (arrows as its software prints them), in arcsec
ISO_LOG = """\
# Rotary axis C, ISO 230-2 bidirectional, 2 runs, 2026-11-30
Target (deg)\tRun 1 ↑\tRun 1 ↓\tRun 2 ↑\tRun 2 ↓
0\t0.0\t0.6\t0.1\t0.5
90\t1.2\t1.9\t1.4\t2.0
180\t−0.8\t−0.1\t−0.6\t0.0
270\t0.4\t1.1\t0.3\t1.2
"""


def _iso_columns() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    rows = [ln.replace("−", "-").split("\t") for ln in ISO_LOG.splitlines()[2:]]
    target = np.array([float(r[0]) for r in rows])
    cols = {name: np.array([float(r[k]) for r in rows])
            for k, name in enumerate(("up1", "down1", "up2", "down2"), start=1)}
    return target, cols


def test_a_wide_iso_log_gives_a_point_per_run_and_direction(tmp_path):
    (tmp_path / "log.txt").write_text(ISO_LOG, encoding="utf-8")
    wide = "--forward 'Run 1 ↑' --forward 'Run 2 ↑' --reverse 'Run 1 ↓,Run 2 ↓'"
    r = run(f"enc points log.txt {wide} -o p.parquet && enc report log.txt {wide} --json > "
            "r.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    header, rows = read_table(str(tmp_path / "p.parquet"), "points")
    target, cols = _iso_columns()
    got = {(int(d), int(k)): (np.degrees(rows.column("reference").to_numpy()[sel]),
                              rows.column("deviation").to_numpy()[sel])
           for d in (1, -1) for k in (0, 1)
           for sel in [(rows.column("direction").to_numpy() == d) &
                       (rows.column("run").to_numpy() == k)]}
    for (d, k), name in {(1, 0): "up1", (-1, 0): "down1", (1, 1): "up2",
                         (-1, 1): "down2"}.items():
        assert got[d, k][0] == pytest.approx(target, abs=1e-9)
        assert got[d, k][1] == pytest.approx(cols[name], abs=1e-9)
    table = header.meta["table"]["columns"]
    assert table["forward"] == "Run 1 ↑, Run 2 ↑" and table["reverse"] == "Run 1 ↓, Run 2 ↓"
    # ISO 230-2's reversal value at each target: mean x up minus mean x down, its
    # x = actual - target = -deviation (read as deviations: indicated - true)
    iso = json.loads((tmp_path / "r.json").read_text())["sections"][0]["iso230_2"]
    b_i = (cols["down1"] + cols["down2"]) / 2 - (cols["up1"] + cols["up2"]) / 2
    assert [p["B"] for p in iso["positions"]] == pytest.approx(b_i, abs=1e-9)
    assert iso["axis"]["B"] == pytest.approx(np.abs(b_i).max(), abs=1e-9)


def test_a_forward_reverse_pair_with_decimal_commas_in_urad(tmp_path):
    (tmp_path / "de.csv").write_text(GERMAN, encoding="utf-8")
    r = run("enc points de.csv --position 1 --forward 2 --reverse 3 --decimal-comma "
            "-o p.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    header, rows = read_table(str(tmp_path / "p.parquet"), "points")
    urad_arcsec = 180 / math.pi * 3600 * 1e-6
    fwd = np.array([0.0, -5.25, 3.5, -1.0]) * urad_arcsec
    rev = np.array([0.8, -4.1, 4.75, 0.25]) * urad_arcsec
    assert rows.column("deviation").to_numpy() == pytest.approx(np.r_[fwd, rev], abs=1e-9)
    assert list(rows.column("direction").to_numpy()) == [1] * 4 + [-1] * 4
    assert header.meta["table"]["units"]["deviation"] == "urad"


def test_a_column_per_run_fits_as_the_runs_mean(tmp_path):
    text = "angle_deg run_a run_b run_c\n" + "".join(
        f"{a} {e:.3f} {e + 0.2:.3f} {e - 0.2:.3f}\n"
        for a, e in zip(range(0, 360, 30), np.sin(np.radians(range(0, 360, 30)))))
    (tmp_path / "runs.txt").write_text(text)
    (tmp_path / "mean.txt").write_text("angle_deg error_arcsec\n" + "".join(
        f"{ln.split()[0]} {ln.split()[1]}\n" for ln in text.splitlines()[1:]))
    r = run("enc fit-rbf runs.txt --forward run_a,run_b,run_c --kernel fourier --band 2 --json "
            "-o a.parquet > a.json && enc fit-rbf mean.txt --kernel fourier --band 2 -q "
            "-o b.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    _, a = read_table(str(tmp_path / "a.parquet"))
    _, b = read_table(str(tmp_path / "b.parquet"))
    for name in a.column_names:  # the mean of the three runs is run_a's column
        assert a.column(name).to_numpy() == pytest.approx(b.column(name).to_numpy(), abs=1e-9)
    assert json.loads((tmp_path / "a.json").read_text())["targets"]["n_visits"] == 36


@pytest.mark.parametrize(("args", "words"), [
    ("--forward 2 --deviation 3", "--forward and --reverse give the deviation, direction and "
     "run of a wide table: not with --deviation"),
    ("--forward 2 --reverse 9", "--reverse '9': no such column"),
    ("--forward 2,3 --reverse 3", "--forward and --reverse name a column twice"),
])
def test_a_wide_table_mapped_wrongly_is_refused_in_one_line(tmp_path, args, words):
    (tmp_path / "de.csv").write_text(GERMAN, encoding="utf-8")
    r = run(f"enc points de.csv --position 1 --decimal-comma {args} -o p.parquet", cwd=tmp_path)
    assert words in one_error_line(r, 2, "enc points")


def test_enc_info_labels_a_csv_column_in_the_unit_the_file_holds(tmp_path):
    (tmp_path / "paper.txt").write_text(PAPER, encoding="utf-8")
    r = run("enc points paper.txt -q --unit urad -o p.csv && enc info p.csv > info.txt && "
            "enc info p.csv --json > info.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    assert (tmp_path / "p.csv").read_text().splitlines()[0].split(",")[1] == "deviation_urad"
    text = (tmp_path / "info.txt").read_text()
    assert "deviation    double   [urad in the file as deviation_urad, read in arcsec]" in text
    cols = {c["name"]: c for c in json.loads((tmp_path / "info.json").read_text())["columns"]}
    assert cols["deviation"]["written_unit"] == "urad" and cols["deviation"]["unit"] == "arcsec"
    assert "written_unit" not in cols["position"]


def test_a_linear_axis_log_in_um_is_read_as_lengths_not_as_arcsec(tmp_path):
    (tmp_path / "lin.txt").write_text("Target [mm]\tRun 1 ↑ [µm]\tRun 1 ↓ [µm]\n"
                                      "0\t0.0\t0.4\n100\t1.3\t1.9\n", encoding="utf-8")
    r = run("enc points lin.txt --reference-column 1 --forward 2 --reverse 3 -o p.parquet",
            cwd=tmp_path)       # its targets are the axis's positions, not a reference
    assert "takes its targets as --position" in one_error_line(r, 2, "enc points")
    assert not (tmp_path / "p.parquet").exists()
    r = run("enc points lin.txt --position 1 --forward 2 --reverse 3 -o p.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    header, rows = read_table(str(tmp_path / "p.parquet"), "points")
    assert header.meta["axis"] == "linear"
    assert rows.schema.field("deviation").metadata[b"unit"] == b"um"
    assert sorted(rows.column("deviation").to_pylist()) == [0.0, 0.4, 1.3, 1.9]
    assert sorted(rows.column("position").to_pylist()) == [0.0, 0.0, 100.0, 100.0]


def test_a_signal_capture_with_decimal_commas(tmp_path):
    _, c, s = _quadrature()
    table = tmp_path / "capture.csv"  # a German locale's export: semicolons, decimal commas
    table.write_text("Zeit [s];Kanal A [V];Kanal B [V]\n" + "".join(
        f"{k * 1e-5:.6f};{a:.7f};{b:.7f}\n".replace(".", ",")
        for k, (a, b) in enumerate(zip(c, s))))
    out = tmp_path / "err.parquet"
    r = run(f"enc interp-check --signals {table} --cos 2 --sin 3 --decimal-comma "
            f"--periods-per-rev 18000 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    _check_fit(_fit_of(out))


def test_a_table_beside_another_programs_csvw_sidecar_is_a_table(tmp_path):
    (tmp_path / "run.csv").write_text(STEP_TABLE)
    (tmp_path / "run.csv-metadata.json").write_text(json.dumps({
        "@context": "http://www.w3.org/ns/csvw", "url": "run.csv",
        "tableSchema": {"columns": [{"titles": "position_deg", "datatype": "double"},
                                    {"titles": "deviation_arcsec", "datatype": "double"}]}}))
    r = run("enc make-rom run.csv --target linuxcnc -q -o t.comp && "
            "enc points run.csv -q -o p.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    _, _, dev = _deviations(tmp_path / "p.parquet")
    assert dev == pytest.approx([0.0, 1.2, 2.1, 1.5, 0.3, -0.9, -1.8, -1.1], abs=1e-12)
