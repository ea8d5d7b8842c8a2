"""Tables as users have them (enc-points(1), TABLES): real comparator runs no one here wrote,
and tables written by pandas, pyarrow and h5py, read by enc points, fit-rbf and report.

The expected values are computed here from the files with the csv module and math, never
through enctools' own readers.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import DATA, one_error_line, run
from test_adversarial import CASES, base, run_case  # noqa: F401  (base: a fixture)

from enctools.data.streams import read_table

MAGALPHA = Path(__file__).resolve().parents[4] / "shared" / "data" / "magalpha"
FILES = ["calibration_data_input_example.csv", "calibration_data_input_example_add_75.csv",
         "calibration_data_input_example_add_260.csv"]
#: the documented options for these files (README, "Your own table")
OPTS = "--reference-column 'Reference Angle [degree]' --measured 'Measured Angle [degree]'"
needs_magalpha = pytest.mark.skipif(not MAGALPHA.is_dir(),
                                    reason="../shared/data/magalpha is not beside the clone")


def _columns(path: Path) -> tuple[list[float], list[float]]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))[1:]
    return [float(r[0]) for r in rows], [float(r[1]) for r in rows]


def _circular_mean_deg(angles_deg: list[float]) -> float:
    s = sum(math.sin(math.radians(a)) for a in angles_deg)
    c = sum(math.cos(math.radians(a)) for a in angles_deg)
    return math.degrees(math.atan2(s, c))


def _points(path: Path) -> tuple[dict, dict[str, np.ndarray]]:
    header, table = read_table(str(path), "points")
    cols = {n: table.column(n).to_numpy() for n in table.column_names}
    return header.meta, cols


@needs_magalpha
@pytest.mark.parametrize("name", FILES)
def test_magalpha_positions_are_the_measured_angle_and_the_offset_is_reported(tmp_path, name):
    out = tmp_path / "p.parquet"
    r = run(f"enc points {MAGALPHA / name} {OPTS} --json -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    summary = json.loads(r.stdout)
    ref, meas = _columns(MAGALPHA / name)
    offset = _circular_mean_deg([m - f for f, m in zip(ref, meas)])
    meta, cols = _points(out)
    assert meta["schema_version"] == 4 and meta["zero_offset_removed"] is True
    assert meta["zero_offset_arcsec"] == pytest.approx(offset * 3600, abs=1e-6)
    assert summary["zero_offset_arcsec"] == pytest.approx(offset * 3600, abs=1e-6)
    assert cols["position"] == pytest.approx([math.radians(m % 360) for m in meas], abs=1e-12)
    assert cols["reference"] == pytest.approx([math.radians(f) for f in ref], abs=1e-12)
    wrapped = [((m - f - offset + 180) % 360 - 180) * 3600 for f, m in zip(ref, meas)]
    assert cols["deviation"] == pytest.approx(wrapped, abs=1e-6)


@needs_magalpha
def test_magalpha_zero_offset_is_about_103_deg_and_can_be_kept(tmp_path):
    src = MAGALPHA / FILES[0]
    r = run(f"enc points {src} --zero-offset keep -o {tmp_path}/keep.parquet && "
            f"enc points {src} -o {tmp_path}/auto.parquet")
    assert r.returncode == 0, r.stderr.decode()
    assert "zero offset" in r.stderr.decode()
    meta, keep = _points(tmp_path / "keep.parquet")
    _, auto = _points(tmp_path / "auto.parquet")
    offset = meta["zero_offset_arcsec"]
    assert offset / 3600 == pytest.approx(102.6, abs=0.1) and not meta["zero_offset_removed"]
    assert keep["deviation"] - auto["deviation"] == pytest.approx(np.full(200, offset), abs=1e-6)
    assert np.array_equal(keep["position"], auto["position"])  # found by title alike


@needs_magalpha
def test_the_three_magalpha_files_give_one_deviation_curve(tmp_path):
    """One run with the sensor's zero moved: the deviation against the measured angle is
    the same curve, shifted along the angle."""
    curves = []
    for k, name in enumerate(FILES):
        r = run(f"enc points {MAGALPHA / name} {OPTS} -o {tmp_path}/{k}.parquet")
        assert r.returncode == 0, r.stderr.decode()
        _, cols = _points(tmp_path / f"{k}.parquet")
        curves.append(np.sort(cols["deviation"]))
    assert curves[1] == pytest.approx(curves[0], abs=0.1) and curves[2] == pytest.approx(
        curves[0], abs=0.1)


# ---------------------------------------------------------- tables written by others

POS_DEG = np.arange(0.0, 360.0, 15.0)
DEV_ARCSEC = 2.0 * np.sin(np.radians(POS_DEG) + 0.3) - 0.7 * np.cos(2 * np.radians(POS_DEG))


def _written(tmp_path: Path, fmt: str) -> tuple[Path, str]:
    """The same 24 points in a table of ``fmt``, in other units, and the options that
    map it (empty: found by its titles)."""
    import pandas as pd

    rad, urad = np.radians(POS_DEG), DEV_ARCSEC * math.pi / 648000 * 1e6
    if fmt == "csv":
        p = tmp_path / "t.csv"
        text = "".join(f"{float(a)!r},{float(e)!r}\n" for a, e in zip(rad, urad))
        p.write_text("# exported by hand\n\nAngle (rad),Error [urad]\n" + text)
        return p, ""
    if fmt == "tsv":
        p = tmp_path / "t.tsv"
        pd.DataFrame({"pos": POS_DEG * 1000 * math.pi / 180, "err": DEV_ARCSEC,
                      "dir": 1, "r": 0}).to_csv(p, sep="\t", index=False)
        return p, ("--position pos --position-unit mrad --deviation err --direction dir "
                   "--run r")
    if fmt == "blank":
        p = tmp_path / "t.dat"
        counts = POS_DEG / 360 * 8192
        p.write_text("# counts  arcsec\n" + "".join(f"  {float(c)!r}   {float(e)!r}\n"
                                                  for c, e in zip(counts, DEV_ARCSEC)))
        return p, "--position 1 --position-unit counts --counts-per-rev 8192 --deviation 2"
    if fmt == "parquet":
        p = tmp_path / "t.parquet"
        pd.DataFrame({"stage": POS_DEG, "encoder": POS_DEG + DEV_ARCSEC / 3600 + 40.0}
                     ).to_parquet(p)
        return p, "--reference-column stage --measured encoder"
    if fmt == "arrow":
        import pyarrow as pa
        import pyarrow.feather as feather

        p = tmp_path / "t.arrow"
        feather.write_feather(pa.table({"position_deg": POS_DEG, "deviation_arcsec": DEV_ARCSEC}),
                              str(p), compression="uncompressed")
        return p, ""
    import h5py

    p = tmp_path / "t.h5"
    with h5py.File(p, "w") as h5:
        if fmt == "hdf5":
            h5["angle"], h5["error"] = POS_DEG, urad
            return p, "--deviation-unit urad"
        rec = np.zeros(POS_DEG.size, dtype=[("ref", "f8"), ("dev", "f8")])
        rec["ref"], rec["dev"] = POS_DEG - DEV_ARCSEC / 3600, DEV_ARCSEC
        h5["points"] = rec
    return p, "--reference-column ref --deviation dev"


@pytest.mark.parametrize("fmt", ["csv", "tsv", "blank", "parquet", "arrow", "hdf5",
                                 "hdf5-compound"])
def test_a_table_written_by_another_program_gives_the_points(tmp_path, fmt):
    path, opts = _written(tmp_path, fmt)
    out = tmp_path / "p.parquet"
    r = run(f"enc points {path} {opts} -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    meta, cols = _points(out)
    if fmt == "parquet":  # reference + measured: positions at the measured angle mod 360
        measured = POS_DEG + DEV_ARCSEC / 3600 + 40.0
        assert cols["position"] == pytest.approx(np.radians(measured % 360), abs=1e-9)
        assert cols["deviation"] + meta["zero_offset_arcsec"] == pytest.approx(
            DEV_ARCSEC + 40 * 3600, abs=1e-6)
        assert meta["zero_offset_removed"] is True
        return
    assert cols["position"] == pytest.approx(np.radians(POS_DEG), abs=1e-9)
    assert cols["deviation"] == pytest.approx(DEV_ARCSEC, abs=1e-6)
    # deviations as given: the offset, their mean, is reported and kept
    assert meta["zero_offset_arcsec"] == pytest.approx(DEV_ARCSEC.mean(), abs=1e-9)
    assert meta["zero_offset_removed"] is False


def test_fit_rbf_and_report_map_a_table_as_points_does(tmp_path):
    path, opts = _written(tmp_path, "tsv")
    r = run(f"enc points {path} {opts} -o p.parquet && "
            f"enc fit-rbf p.parquet --kernel fourier --band 3 -q -o a.parquet && "
            f"enc fit-rbf {path} {opts} --kernel fourier --band 3 --holdout {path} --json "
            "-o b.parquet > fit.json && "
            f"enc report {path} {opts} --json > r1.json && enc report p.parquet --json > r2.json",
            cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    _, a = read_table(str(tmp_path / "a.parquet"))
    _, b = read_table(str(tmp_path / "b.parquet"))
    assert a.equals(b)
    fit = json.loads((tmp_path / "fit.json").read_text())
    assert fit["holdout"]["n_points"] == POS_DEG.size  # the hold-out table mapped alike
    one, two = (json.loads((tmp_path / f).read_text()) for f in ("r1.json", "r2.json"))
    assert one["sections"][0]["curves"] == two["sections"][0]["curves"]


def test_a_table_that_does_not_map_names_its_columns_and_the_options(tmp_path):
    f = tmp_path / "t.csv"
    f.write_text("when,temp,angle\n1,20,0\n2,21,15\n")
    for cmd in ("points", "fit-rbf"):
        r = run(f"enc {cmd} {f} -o {tmp_path}/out.parquet")
        line = one_error_line(r, 2, f"enc {cmd}")
        assert "columns found: 'when', 'temp', 'angle'" in line
        assert "--position COL --deviation COL" in line and "--reference-column COL" in line
        assert not (tmp_path / "out.parquet").exists()


def test_column_options_on_a_stream_are_refused(tmp_path):
    r = run(f"enc points {DATA}/seed001_table1.csv -o {tmp_path}/p.parquet && "
            f"enc fit-rbf {tmp_path}/p.parquet --deviation-unit urad -o {tmp_path}/m.parquet")
    line = one_error_line(r, 2, "enc fit-rbf")
    assert "--deviation-unit: for a table" in line and not (tmp_path / "m.parquet").exists()


def test_an_older_points_stream_without_reference_fits_the_same(tmp_path):
    """A v2 points stream (no reference column) reads as position - deviation."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    r = run(f"enc points {DATA}/seed001_table1.csv -o {tmp_path}/v3.parquet")
    assert r.returncode == 0, r.stderr.decode()
    t = pq.read_table(tmp_path / "v3.parquet")
    meta = json.loads(t.schema.metadata[b"enctools"]) | {"schema_version": 2}
    v2 = t.drop_columns(["reference"]).replace_schema_metadata(
        {b"enctools": json.dumps(meta).encode()})
    pq.write_table(v2, tmp_path / "v2.parquet")
    r = run("enc fit-rbf v2.parquet --kernel fourier -q -o m2.parquet && "
            "enc fit-rbf v3.parquet --kernel fourier -q -o m3.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    assert read_table(str(tmp_path / "m2.parquet"))[1].equals(
        read_table(str(tmp_path / "m3.parquet"))[1])
    assert pa.types.is_floating(t.schema.field("reference").type)


@needs_magalpha
@pytest.mark.slow
def test_a_table_indexed_by_the_measured_angle_corrects_the_sensor(tmp_path):
    """points -> Fourier model -> 16-bit table, then the table added at each measured
    angle's code as a controller would (computed here): 10.55 deg p-p falls to about
    2.5 deg. Positioned at the reference angle, the same table made it worse (16-19 deg)."""
    src = MAGALPHA / FILES[0]
    r = run(f"enc points {src} {OPTS} -q | enc fit-rbf --kernel fourier --band 8 -q | "
            "enc make-rom --bits 16 -q -o rom.csv", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    with open(tmp_path / "rom.csv", newline="") as f:
        rom = [int(row[1]) for row in list(csv.reader(f))[1:]]
    ref, meas = _columns(src)

    def pp(indicated: list[float]) -> float:
        d = [(i - f + 180) % 360 - 180 for f, i in zip(ref, indicated)]
        mean = _circular_mean_deg(d)
        d = [(x - mean + 180) % 360 - 180 for x in d]
        return max(d) - min(d)

    lsb_deg = 360 / 2**16
    corrected = [m + rom[int(m % 360 / lsb_deg) % 2**16] * lsb_deg for m in meas]
    before, after = pp(meas), pp(corrected)
    assert before == pytest.approx(10.55, abs=0.01)
    assert after < 2.6 and after < before / 4


# ------------------------------------------- a bad table, refused alike by every reader

#: the catalogue's bad tables (tests/adversarial/cases/tables.toml), each written for one
#: command; here each is given to every command that reads points
BAD_TABLES = ["table-unknown-column", "table-mixed-units-title-and-option",
              "table-mixed-units-cells", "table-nan-row", "table-1e308-row",
              "table-duplicate-positions", "table-reference-jumps-backwards"]
#: what each command needs besides the table (enc correct: a table to apply)
READERS = {"points": [], "fit-rbf": [], "correct": ["--table", "rom.parquet"]}


@pytest.mark.slow
@pytest.mark.parametrize("command", list(READERS))
@pytest.mark.parametrize("case_id", BAD_TABLES)
def test_a_bad_table_is_refused_alike_by_points_fit_rbf_and_correct(
        base, tmp_path, record_property, case_id, command):  # noqa: F811
    """The same one line naming the row or column, exit 2, no output file."""
    case = next(c for c in CASES if c.id == case_id)
    table, options = case.argv[2], case.argv[3:-2]   # the case's output option left out
    assert case.stderr and ("line " in case.stderr or "column" in case.stderr)
    argv = ["enc", command, table, *options, *READERS[command], "-o", "out.parquet"]
    setup = case.setup + [{"use": "copy", "src": "rom.parquet"}] * (command == "correct")
    run_case(dataclasses.replace(case, id=f"{case_id}-{command}", argv=argv, setup=setup,
                                 absent=["out.parquet"]), base, tmp_path, record_property)
