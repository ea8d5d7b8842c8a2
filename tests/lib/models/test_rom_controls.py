"""enc make-rom for motion controls: tables from a simulated step run with known
deviations and reversal, read back by each control's own reader within half the
control's resolution, each control's sign convention, and its refusals."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import DATA, one_error_line, run, run_in_process

from enctools.models import romformats as rf
from enctools.models.romformats.points import PointTable

ARCSEC = np.pi / 648000.0
TARGETS = 24  # every 15 deg
#: each control, its options, its resolution [arcsec], bidirectional or not
CASES = {
    "linuxcnc-0": ("linuxcnc", "--comp-type 0 --bidirectional", 0.0036, True),
    "linuxcnc-1": ("linuxcnc", "--comp-type 1 --bidirectional", 0.0036, True),
    "linuxcnc-uni": ("linuxcnc", "--comp-type 0", 0.0036, False),
    "twincat": ("twincat", "--bidirectional --axis 3", 0.36, True),
    "twincat-uni": ("twincat", "", 0.36, False),
    "fanuc": ("fanuc", "--sign error --axis 4", 3.6, False),
    "fanuc-param": ("fanuc-param", "--sign error --axis 4 --home-point 300", 3.6, False),
    "heidenhain": ("heidenhain", "--sign correction --axis C --tnc 620", 0.36, False),
    "twincat-nc": ("twincat-nc", "--sign error", 0.0036, False),
}


def known_deviation(deg: np.ndarray) -> np.ndarray:
    """The deviation added to the simulated step run [arcsec]."""
    t = np.radians(deg)
    return 40.0 * np.sin(t) + 12.0 * np.cos(3 * t + 0.4)


def known_reversal(deg: np.ndarray) -> np.ndarray:
    """The reversal value added (up - down) [arcsec]."""
    return 6.0 + 2.0 * np.cos(np.radians(deg))


@pytest.fixture(scope="module")
def step_run(tmp_path_factory):
    """A simulated bidirectional step run (2 runs, 24 targets) as a points stream, with
    the known deviation and reversal added; and the intended corrections per target
    [arcsec]: minus the mean per direction, computed here independently."""
    d = tmp_path_factory.mktemp("steps")
    r = run(f"enc acquire --rig ciomp-23bit --mode steps --count {TARGETS} --runs 2 "
            f"--bidirectional --readings 2 -q | enc points -q -o {d}/sim.parquet")
    assert r.returncode == 0, r.stderr.decode()
    table = pq.read_table(d / "sim.parquet")
    deg = np.degrees(table.column("position").to_numpy())
    direction = table.column("direction").to_numpy()
    dev = (table.column("deviation").to_numpy() + known_deviation(deg)
           + direction * known_reversal(deg) / 2.0)
    i = table.schema.get_field_index("deviation")
    table = table.set_column(i, table.schema.field(i), pa.array(dev))
    pq.write_table(table, d / "points.parquet")
    target = np.rint(np.mod(deg, 360.0) / 15.0).astype(int) % TARGETS
    intended = {s: -np.array([dev[(target == k) & (direction == s)].mean()
                              for k in range(TARGETS)]) for s in (1, -1)}
    return d / "points.parquet", intended


@pytest.mark.parametrize("case", list(CASES))
def test_step_run_read_back_within_half_resolution(step_run, tmp_path, case):
    points, intended = step_run
    target, opts, resolution, bidirectional = CASES[case]
    out = tmp_path / f"{case}.txt"
    r = run(f"enc make-rom {points} --target {target} {opts} --verify --json -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    summary = json.loads(r.stdout)
    assert summary["points"] == TARGETS + 1 and summary["spacing_deg"] == 15.0
    assert summary["resolution_arcsec"] == pytest.approx(resolution)
    # ISO 230-2's B_mean: x = actual - target = -deviation, so -(deviation up - down)
    assert summary["reversal_mean_arcsec"] == pytest.approx(-np.mean(known_reversal(
        np.arange(TARGETS) * 15.0)), abs=0.05)
    comp_type = 1 if "--comp-type 1" in opts else 0
    sign = "error" if "--sign error" in opts else "correction"
    table = rf.read_control_table(str(out), target, sign, comp_type,
                                  "C" if target == "heidenhain" else None)
    grid = np.radians(np.arange(TARGETS + 1) * 15.0)
    if bidirectional:
        wanted = {1: intended[1], -1: intended[-1]}
    else:
        mean = (intended[1] + intended[-1]) / 2.0
        wanted = {1: mean, -1: mean}
    for s, corr in wanted.items():
        want = np.r_[corr, corr[0]]
        if target.startswith("fanuc"):  # the compensation is 0 at the reference position
            want = want - want[0]
        got = table.correction(grid, s) / ARCSEC
        assert np.max(np.abs(got - want)) <= resolution / 2 * (1 + 1e-6), (s, got - want)


@pytest.mark.parametrize("target, opts", [("siemens", ""), ("acs", "--sign error --axis 2")])
def test_siemens_acs_from_step_run(step_run, tmp_path, target, opts):
    """SINUMERIK and ACS tables of 2^3 points (45 deg, on the targets) at 0.0001 deg, read
    back as point tables: the mean of both directions within half the resolution."""
    points, intended = step_run
    out = tmp_path / f"t.{target}"
    r = run(f"enc make-rom {points} --target {target} --bits 23 --address-bits 3 "
            f"--resolution 0.0001 {opts} --verify --json -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    # 45 deg between the table's points, 15 deg between the targets: the cost is reported
    assert json.loads(r.stdout)["corrections"]["interpolation_error_arcsec"] > 1.0
    table = rf.read_control_table(str(out), target, "error" if "error" in opts else None)
    assert table.positions_rad.size == 9
    want = ((intended[1] + intended[-1]) / 2.0)[::3]
    got = table.correction(np.radians(np.arange(8) * 45.0)) / ARCSEC
    assert np.max(np.abs(got - want)) <= 0.18 * (1 + 1e-6), got - want
    # the file's own sign at 90 deg: SINUMERIK stores the correction; ACS as --sign says
    corr90 = want[2] / 3600.0
    line = r"^\$AA_ENC_COMP\[0,2,AX1\]=(\S+)" if target == "siemens" else r"^ENC_COMP\(2\)=(\S+)"
    assert _row(out, line) == pytest.approx(corr90 if target == "siemens" else -corr90,
                                            abs=5e-5)


def _row(path, pattern: str) -> float:
    """The number the first line matching ``pattern`` (group 1) holds."""
    m = re.search(pattern, path.read_text(), re.MULTILINE)
    assert m, pattern
    return float(m.group(1))


def test_sign_conventions(step_run, tmp_path):
    """At 90 deg the deviation is about +28 arcsec (correction -28): each file stores
    it in its control's sign."""
    points, intended = step_run
    corr90 = (intended[1][6] + intended[-1][6]) / 2.0 / 3600.0  # [deg]
    assert corr90 < -0.005
    files = {}
    for name, target, opts in (("l0", "linuxcnc", "--comp-type 0"),
                               ("l1", "linuxcnc", "--comp-type 1"),
                               ("tc", "twincat", ""),
                               ("hc", "heidenhain", "--sign correction --tnc 620"),
                               ("he", "heidenhain", "--sign error --tnc 620")):
        files[name] = tmp_path / f"{name}.txt"
        r = run_in_process(f"enc make-rom {points} --target {target} {opts} -q "
                           f"-o {files[name]}")
        assert r.returncode == 0, r.stderr.decode()
    # LinuxCNC type 0: the position reached when 90 is commanded = 90 + correction
    assert _row(files["l0"], r"^90\.000000 (\S+)") == pytest.approx(90 + corr90, abs=1e-6)
    # type 1: the trim added to the command = minus the correction
    assert _row(files["l1"], r"^90\.000000 (\S+)") == pytest.approx(-corr90, abs=1e-6)
    # TwinCAT: actual - programmed = the correction, in 0.0001 deg
    assert _row(files["tc"], r"^kw\.ssfk\.table\[6\]\.pos\s+(\S+)") == round(corr90 * 1e4)
    assert _row(files["hc"], r"^6\s+\S+\s+(\S+)") == pytest.approx(corr90, abs=5e-5)
    assert _row(files["he"], r"^6\s+\S+\s+(\S+)") == pytest.approx(-corr90, abs=5e-5)


def test_fanuc_increments_sum_to_zero(step_run, tmp_path):
    points, _ = step_run
    out = tmp_path / "f.txt"
    r = run_in_process(f"enc make-rom {points} --target fanuc --sign correction --home-point 60 "
                       f"--axis 4 -q -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    text = out.read_text()
    pitch = {int(a): int(b) for a, b in re.findall(r"^PITCH (\d+) VALUE ([-+]\d+)", text,
                                                     re.MULTILINE)}
    assert sorted(pitch) == list(range(60, 85))
    assert sum(pitch[p] for p in range(61, 85)) == 0 and pitch[60] == pitch[84]
    assert "PARAMETER 3622 AXIS 4 VALUE 84" in text and "PARAMETER 3624 AXIS 4 VALUE 15000" in text


@pytest.mark.parametrize("system, unit", [("IS-B", 1e-3), ("IS-C", 1e-4)])
def test_fanuc_increment_system(step_run, tmp_path, system, unit):
    """The increment system sets the detection unit: the table's resolution is the
    magnification x that unit, read back and applied by enc correct within half of it
    (IS-C: finer than IS-B's 3.6 arcsec, whose every value is +-1 unit)."""
    points, intended = step_run
    out, fixed = tmp_path / "f.txt", tmp_path / "fixed.parquet"
    r = run(f"enc make-rom {points} --target fanuc --sign error --axis 4 "
            f"--increment-system {system} --verify --json -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    s = json.loads(r.stdout)
    assert s["increment_system"] == system and s["detection_unit_deg"] == unit
    resolution = s["magnification"] * unit * 3600.0
    assert s["resolution_arcsec"] == pytest.approx(resolution)
    assert f"DETECTION_UNIT_DEG {unit!r}  # increment system {system}" in out.read_text()
    if system == "IS-C":
        assert resolution < 3.6
    table = rf.read_control_table(str(out), "fanuc", "error")
    mean = (intended[1] + intended[-1]) / 2.0
    want = np.r_[mean, mean[0]] - mean[0]
    got = table.correction(np.radians(np.arange(TARGETS + 1) * 15.0)) / ARCSEC
    assert np.max(np.abs(got - want)) <= resolution / 2 * (1 + 1e-6)
    r = run(f"enc correct {points} --table {out} --target fanuc --sign error -q -o {fixed}")
    assert r.returncode == 0, r.stderr.decode()
    t = pq.read_table(fixed)
    k = np.rint(np.mod(np.degrees(t.column("position").to_numpy()), 360.0) / 15.0)
    dev = t.column("deviation").to_numpy()
    means = np.array([dev[k.astype(int) % TARGETS == j].mean() for j in range(TARGETS)])
    # the table is 0 at the reference point: every target keeps the deviation there
    assert np.max(np.abs(means + mean[0])) <= resolution / 2 + 0.01


def test_heidenhain_assignment_table(step_run, tmp_path):
    """The .COM is written with its .CMA (both or neither): the .CMA, parsed here as the
    control reads it (fields under their column names, the one line marked * in ACTIVE),
    makes the .COM the axis's active table; an existing .CMA is not replaced without
    --force, and then neither file is written."""
    points, _ = step_run
    com, cma = tmp_path / "B.COM", tmp_path / "B.CMA"
    r = run_in_process(f"enc make-rom {points} --target heidenhain --sign error --tnc 620 "
                       f"--axis B --verify --json -o {com}")
    assert r.returncode == 0, r.stderr.decode()
    assert json.loads(r.stdout)["assignment"] == str(cma)
    lines = cma.read_text(encoding="ascii").splitlines()
    assert lines[0] == "BEGIN B.CMA" and lines[-1] == "[END]"
    header = lines[1]
    cols = {name: header.index(name) for name in header.split()}
    assert cols["NR"] == 0 and set(cols) == {"NR", "B", "ACTIVE"}
    rows = lines[2:-1]
    assert [row[cols["ACTIVE"]:].strip() for row in rows] == ["*"]
    assert rows[0][cols["B"]:cols["ACTIVE"]].strip() == "B.COM"
    assert rf.read_control_table(str(com), "heidenhain", "error", axis="B").positions_rad.size \
        == TARGETS + 1
    com.unlink()
    before = cma.read_bytes()
    r = run_in_process(f"enc make-rom {points} --target heidenhain --sign error --tnc 620 "
                       f"--axis B -o {com}")
    assert "B.CMA" in one_error_line(r, 2, "enc make-rom")
    assert not com.exists() and cma.read_bytes() == before


def test_twincat_nc_plc_declaration(step_run, tmp_path, monkeypatch):
    """The TwinCAT NC PTP table is a PLC declaration MC_TableBasedPositionCompensation's
    inputs take: parsed here on its own (IEC 61131-3: comments dropped, the initialisers
    read by name), it holds the parameter structure and an ARRAY[1..25] whose Position
    runs 0..360 deg by 15 and whose Compensation at 90 deg is the correction in the sign
    given; a hostile output name stays inside one comment."""
    points, intended = step_run
    corr90 = (intended[1][6] + intended[-1][6]) / 2.0 / 3600.0  # [deg]
    out = str(tmp_path / "c*)\nVAR_GLOBAL x : INT := 1; END_VAR(*.st")
    args = ["make-rom", str(points), "--target", "twincat-nc", "--sign", "correction",
            "-o", out, "--verify", "-q"]
    monkeypatch.setattr("sys.argv", ["enc", *args])
    r = run_in_process(args)
    assert r.returncode == 0, r.stderr.decode()
    text = Path(out).read_text(encoding="ascii")
    code = re.sub(r"\(\*.*?\*\)", "", text, flags=re.DOTALL)
    assert "x : INT" not in code and code.count("VAR_GLOBAL") == 1
    assert re.search(r"stEncCompParameter\s*:\s*ST_PositionCompensationTableParameter\s*:=", code)
    fields = dict(re.findall(r"(\w+) := ([\w.]+)", code.split("aEncCompTable")[0]))
    assert fields == {"MinPosition": "0.000000", "MaxPosition": "360.000000",
                      "NoOfTableElements": "25",
                      "Direction": "E_WorkDirection.WorkDirectionBoth", "Modulo": "TRUE"}
    assert "ARRAY[1..25] OF ST_PositionCompensationTableElement" in code
    rows = re.findall(r"\(Position := (\S+), Compensation := (\S+?)\)", code)
    assert [float(p) for p, _ in rows] == [15.0 * i for i in range(25)]
    assert float(rows[6][1]) == pytest.approx(corr90, abs=5e-7)
    assert rows[0][1] == rows[-1][1]


@pytest.mark.parametrize("old, new, says", [
    ("WorkDirectionBoth", "WorkDirectionPositive", "only a table for both directions"),
    ("NoOfTableElements := 3", "NoOfTableElements := 4", "must agree"),
    ("(Position := 180.0,", "(Position := 170.0,", "equidistant"),
])
def test_twincat_nc_reader_refuses_what_the_block_would_not_take(tmp_path, old, new, says):
    """What MC_TableBasedPositionCompensation's documentation excludes (one direction is
    not read here; a count that disagrees; positions not equidistant) is one DataError."""
    from enctools.errors import DataError
    text = ("VAR_GLOBAL\n p : ST_PositionCompensationTableParameter := (MinPosition := 0.0, "
            "MaxPosition := 360.0, NoOfTableElements := 3, Direction := "
            "E_WorkDirection.WorkDirectionBoth, Modulo := TRUE);\n"
            " t : ARRAY[1..3] OF ST_PositionCompensationTableElement := [(Position := 0.0, "
            "Compensation := 0.001), (Position := 180.0, Compensation := -0.002), "
            "(Position := 360.0, Compensation := 0.001)];\nEND_VAR\n")
    f = tmp_path / "t.st"
    f.write_text(text)
    table = rf.read_control_table(str(f), "twincat-nc", "correction")
    assert table.correction(np.radians(540.0)) == pytest.approx(np.radians(-0.002))
    f.write_text(text.replace(old, new))
    with pytest.raises(DataError, match=says):
        rf.read_control_table(str(f), "twincat-nc", "correction")


def test_beyond_range_is_one_line(step_run, tmp_path):
    """Fanuc: an increment beyond +-7 x magnification 100 x 0.001 deg is refused."""
    points, _ = step_run
    table = pq.read_table(points)
    i = table.schema.get_field_index("deviation")
    deg = np.degrees(table.column("position").to_numpy())
    big = table.set_column(i, table.schema.field(i), pa.array(36000.0 * np.sin(np.radians(deg))))
    pq.write_table(big, tmp_path / "big.parquet")
    out = tmp_path / "f.txt"
    r = run_in_process(f"enc make-rom {tmp_path}/big.parquet --target fanuc --sign error "
                       f"-o {out}")
    assert "by more than 7 x 100 x 0.001 deg" in one_error_line(r, 2, "enc make-rom")
    assert not out.exists()


@pytest.mark.parametrize("opts, says", [
    ("--target fanuc", "not confirmed"),
    ("--target heidenhain --sign error --tnc 620 --bidirectional", "bidirectional"),
    ("--target heidenhain --sign error", "name the control's generation with --tnc"),
    ("--target heidenhain --sign error --tnc 407", "power of two"),
    ("--target linuxcnc --tnc 620", "--tnc applies to heidenhain"),
    ("--target fanuc --sign error --bidirectional", "bidirectional"),
    ("--target twincat --points 8", "0.0001 deg"),
    ("--target linuxcnc --points 300", "256"),
    ("--target twincat --sign error", "--sign"),
    ("--target twincat --width 8", "--width"),
    ("--target mif --comp-type 1", "--comp-type"),
    ("--target twincat --comp-type 1", "--comp-type applies to linuxcnc"),
    ("--target linuxcnc --detection-unit 0.0001", "--detection-unit applies to fanuc"),
    ("--target linuxcnc --increment-system IS-C", "--increment-system applies to fanuc"),
    ("--target fanuc --sign error --increment-system IS-C --detection-unit 0.001", "not both"),
    ("--target linuxcnc --axis 2", "names no joint"),
    ("--target siemens --points 9 --bits 23 --address-bits 3 --resolution 0.0001",
     "--points applies to linuxcnc"),
    # --backlash where the control keeps none apart from its table: its reason
    ("--target linuxcnc --backlash", "ignores [JOINT_n]BACKLASH"),
    ("--target twincat --backlash", "P-AXIS-00103"),
    ("--target twincat-nc --sign error --backlash", "takes no backlash"),
    ("--target heidenhain --sign error --tnc 620 --backlash", "not confirmed"),
    ("--target fanuc --sign error --bidirectional --backlash", "not both"),
    ("--target acs --sign error --bits 23 --address-bits 3 --resolution 0.0001 --backlash",
     "--backlash applies to"),
])
def test_refusals_are_one_line(step_run, tmp_path, opts, says):
    points, _ = step_run
    out = tmp_path / "t.txt"
    r = run_in_process(f"enc make-rom {points} {opts} -o {out}")
    assert says in one_error_line(r, 2, "enc make-rom")
    assert not out.exists()


def test_model_source_reports_interpolation_error(tmp_path):
    """From a model the grid is the finest the control allows; what its linear
    interpolation costs is reported."""
    r = run(f"enc fit-rbf {DATA}/seed001_table1.csv -q -o {tmp_path}/m.parquet && "
            f"enc make-rom {tmp_path}/m.parquet --target linuxcnc --verify --json "
            f"--allow-no-gain "
            f"-o {tmp_path}/j.comp")
    assert r.returncode == 0, r.stderr.decode()
    s = json.loads(r.stdout)
    assert s["points"] <= 256 and s["verified"] is True
    assert 0 < s["interpolation_error_arcsec"] < 1.0


def test_point_table_modulo_and_directions():
    t = PointTable(np.radians([0.0, 180.0, 360.0]), np.array([0.0, 2.0, 0.0]),
                   np.array([1.0, 3.0, 1.0]), modulo_rad=2 * np.pi)
    assert t.correction(np.radians(450.0), 1) == pytest.approx(1.0)
    assert t.correction(np.radians(-90.0), -1) == pytest.approx(2.0)
    held = PointTable(np.radians([0.0, 10.0]), np.array([1.0, 2.0]))
    assert held.correction(np.radians([-5.0, 20.0])).tolist() == [1.0, 2.0]


@pytest.mark.parametrize("target, opts", [("linuxcnc", []), ("twincat", []),
                                          ("fanuc", ["--sign", "error"]),
                                          ("heidenhain", ["--sign", "error", "--tnc", "620"])])
def test_hostile_names_stay_in_comments(step_run, tmp_path, monkeypatch, target, opts):
    """The command line (with the output's name) lands only in '# ' comment lines, which
    the control's reader skips; the table reads back the same."""
    points, _ = step_run
    out = str(tmp_path / "o\n1.0 2.0 3.0\nkw.ssfk.unit 0\nPITCH 1 VALUE +7\n[END]\x1b[2J.txt")
    args = ["make-rom", str(points), "--target", target, *opts, "-o", out, "--verify", "-q"]
    monkeypatch.setattr("sys.argv", ["enc", *args])
    r = run_in_process(args)
    if target == "heidenhain":  # the .CMA names the .COM by its file name: refused
        assert "letters, digits" in one_error_line(r, 2, "enc make-rom")
        assert not list(tmp_path.iterdir())
        return
    assert r.returncode == 0, r.stderr.decode()
    text = Path(out).read_text(encoding="ascii")
    assert all(c.isprintable() or c == "\n" for c in text)
    comments = [ln for ln in text.splitlines() if ln.startswith("#")]
    assert all(ln.startswith("# ") for ln in comments)
    assert target == "heidenhain" or any("\\n1.0 2.0 3.0\\n" in ln for ln in comments)
    assert not any(ln.startswith(("1.0 2.0", "kw.ssfk.unit 0", "PITCH 1 VALUE +7"))
                   for ln in text.splitlines())


def test_the_command_knows_the_controls():
    """cli/make_rom.py's targets are the registry's formats and stream, read when asked."""
    from enctools.cli import make_rom
    assert set(make_rom.targets()) == set(rf.FORMATS + rf.CONTROLS + ("stream",))


@pytest.mark.parametrize("target", ["linuxcnc", "twincat", "fanuc", "heidenhain", "siemens",
                                    "acs", "twincat-nc", "fanuc-param"])
@pytest.mark.parametrize("data", [b"", b"\xff\xfe\x00garbage\n", b"1 2 3\n1 2 3\n",
                                  b"DETECTION_UNIT_DEG x\nkw.ssfk.unit 1\n",
                                  b"BEGIN C.COM\nNR AXISPOS C\n0 +1 +x\n1 +0 +0\n[END]\n",
                                  b"kw.ssfk.unit 1\nkw.ssfk.kw_nr_max 99999999999999999999\n",
                                  b"%\nN03620Q1A1P0\nN03620Q1A1P1\n%\n",
                                  b"%\nN03620Q1A1P0A2P1\nN10001Q0P99999999999999999999\n%"])
def test_readers_refuse_malformed_files_in_one_line(tmp_path, target, data):
    """Whatever the file holds, a reader gives a table or one DataError line."""
    from enctools.errors import DataError
    f = tmp_path / "t.txt"
    f.write_bytes(data)
    try:
        table = rf.read_control_table(str(f), target, "correction")
    except DataError as exc:
        assert "\n" not in str(exc)
    else:
        assert isinstance(table, PointTable)


@pytest.mark.parametrize("case", list(CASES))
def test_enc_correct_applies_each_controls_table(step_run, tmp_path, case):
    """A control's table applied back to the step run it was made from by enc correct
    (through the control's own reader): every target's mean corrected deviation, per
    direction where the table has two, is within half the control's resolution of 0
    (Fanuc: of one constant, its table being 0 at the reference point)."""
    points, _ = step_run
    target, opts, resolution, bidirectional = CASES[case]
    out, fixed = tmp_path / f"{case}.txt", tmp_path / "corrected.parquet"
    assert run(f"enc make-rom {points} --target {target} {opts} -q -o {out}").returncode == 0
    read = " ".join(re.findall(r"--(?:sign|comp-type) \S+", opts))
    if target == "fanuc-param":  # the file names its axis; its detection unit, not
        read += " --axis 4 --detection-unit 0.001"
    if target == "heidenhain":
        read += " --axis C"
    r = run(f"enc correct {points} --table {out} --target {target} {read} --json -o {fixed}")
    assert r.returncode == 0, r.stderr.decode()
    assert json.loads(r.stdout)["table"]["bidirectional"] is bidirectional
    t = pq.read_table(fixed)
    deg = np.mod(np.degrees(t.column("position").to_numpy()), 360.0)
    k = np.rint(deg / 15.0).astype(int) % TARGETS
    direction = t.column("direction").to_numpy()
    dev = t.column("deviation").to_numpy()
    groups = [(1,), (-1,)] if bidirectional else [(1, -1)]
    means = np.array([[dev[(k == j) & np.isin(direction, g)].mean() for j in range(TARGETS)]
                      for g in groups])
    if target.startswith("fanuc"):
        means = means - means.mean()
    assert np.max(np.abs(means)) <= resolution / 2 + 0.01, means
