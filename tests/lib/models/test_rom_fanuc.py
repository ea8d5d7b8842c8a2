"""Fanuc's own parameter transfer file (fanuc-param) and the backlash written where a
control keeps it apart from its table: the file parsed here as the CNC reads it (a
reader of the test's own), the backlash value against the step run's known reversal,
enc correct closing the gap between the directions, and the refusals, one line each."""

from __future__ import annotations

import json
import re

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import one_error_line, run, run_in_process
from test_rom_controls import TARGETS, known_reversal, step_run  # noqa: F401 (fixture)

from enctools.errors import DataError
from enctools.models import romformats as rf

IS_C = 1e-4  # deg, the detection unit of IS-C
IS_C_ARCSEC = IS_C * 3600.0


def control_reads(text: str, axis: str) -> tuple[dict[int, str], dict[int, int]]:
    """The record as the CNC reads it: the blocks between the % leader and the next %, one
    a line; Q1 blocks give the axis's parameters (A<axis>P<value>), Q0 blocks the pitch
    error data by point (N - 10000)."""
    lines = [ln.strip() for ln in text.split("\n")]
    start = lines.index("%") + 1
    params, pitch = {}, {}
    for block in lines[start:lines.index("%", start)]:
        number, kind, rest = re.fullmatch(r"N(\d{5})Q([01])(.*)", block).groups()
        if kind == "0":
            pitch[int(number) - 10000] = int(re.fullmatch(r"P([-+]?\d+)", rest).group(1))
        else:
            values = dict(re.findall(r"A(\d+)P([-+]?[\d.]+)", rest))
            params[int(number)] = values[axis]
    return params, pitch


def make(points, out, opts: str) -> dict:
    r = run(f"enc make-rom {points} --target fanuc-param --sign error --axis 4 "
            f"--home-point 300 {opts} --verify --json -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout)


def test_transfer_file_as_the_cnc_reads_it(step_run, tmp_path):  # noqa: F811
    """At IS-C: 3620-3625 of axis 4 (3621 = 3620 + 1, 3624 and 3625 real in deg), the 24
    increments of points 301..324 summing to 0 whose running sum x magnification x
    0.0001 deg is minus the positive direction's correction (--sign error) within half
    the resolution, and 1851 the mean reversal in detection units."""
    points, intended = step_run
    out = tmp_path / "PITCH.TXT"
    s = make(points, out, "--increment-system IS-C --backlash")
    text = out.read_text(encoding="ascii")
    lines = text.splitlines()
    assert lines[0] == lines[-1] == "%"
    assert all(re.fullmatch(r"N0\d{4}Q1A4P-?\d+(\.\d+)?|N1\d{4}Q0P-?\d+", ln)
               for ln in lines[1:-1]), lines
    params, pitch = control_reads(text, "4")
    assert (params[3620], params[3621], params[3622]) == ("300", "301", "324")
    assert (params[3624], params[3625]) == ("15.0", "360.0")
    mag = int(params[3623])
    increments = np.array([pitch[p] for p in range(301, 325)])
    assert increments.sum() == 0 and pitch[300] == pitch[324]
    stored = np.r_[0, np.cumsum(increments)] * mag * IS_C_ARCSEC  # the error [arcsec]
    want = np.r_[intended[1], intended[1][0]] - intended[1][0]
    resolution = mag * IS_C_ARCSEC
    assert s["resolution_arcsec"] == pytest.approx(resolution)
    assert np.max(np.abs(-stored - want)) <= resolution / 2 * (1 + 1e-6)
    reversal = np.mean(known_reversal(np.arange(TARGETS) * 15.0))  # 6 arcsec
    backlash = int(params[1851])
    assert backlash == s["backlash_steps"] == round(-s["reversal_mean_arcsec"] / IS_C_ARCSEC)
    assert backlash * IS_C_ARCSEC == pytest.approx(reversal, abs=IS_C_ARCSEC / 2 + 0.05)


def direction_means(path) -> tuple[np.ndarray, np.ndarray]:
    """The corrected deviation's mean per target (every 15 deg), up and down [arcsec]."""
    t = pq.read_table(path)
    k = np.rint(np.mod(np.degrees(t.column("position").to_numpy()), 360.0) / 15.0)
    k = k.astype(int) % TARGETS
    direction, dev = t.column("direction").to_numpy(), t.column("deviation").to_numpy()
    up, down = (np.array([dev[(k == j) & (direction == d)].mean() for j in range(TARGETS)])
                for d in (1, -1))
    return up, down


def test_enc_correct_closes_the_gap_between_directions(step_run, tmp_path):  # noqa: F811
    """Applied back by enc correct through the library's reader: the positive direction
    within half the resolution of one constant (the table is 0 at the reference point);
    the negative direction gets the backlash, so the mean gap between the directions,
    6 arcsec before, is within half a detection unit of 0 (what is left is the reversal's
    variation about its mean, 2 arcsec, which one backlash value cannot hold)."""
    points, _ = step_run
    out = tmp_path / "p.txt"
    s = make(points, out, "--increment-system IS-C --backlash")
    fixed = tmp_path / "fixed.parquet"
    r = run(f"enc correct {points} --table {out} --target fanuc-param --sign error --axis 4 "
            f"--detection-unit 0.0001 --json -o {fixed}")
    assert r.returncode == 0, r.stderr.decode()
    assert json.loads(r.stdout)["table"]["bidirectional"] is True
    up, down = direction_means(fixed)
    assert np.ptp(up) <= s["resolution_arcsec"] + 0.02
    gap = float(np.mean(up - down))
    assert abs(gap - (-s["reversal_mean_arcsec"] - s["backlash_arcsec"])) < 1e-6
    assert abs(gap) <= IS_C_ARCSEC / 2 + 1e-6
    assert np.max(np.abs(up - down - gap)) <= 2.0 + 0.05
    # named by its content (N.....Q1 / Q0 blocks) when --target is left out
    r = run_in_process(f"enc correct {points} --table {out} --sign error --axis 4 "
                       f"--detection-unit 0.0001 --json")
    assert json.loads(r.stdout)["table"]["format"] == "fanuc-param", r.stderr.decode()


def test_sheet_writes_the_backlash_too(step_run, tmp_path):  # noqa: F811
    points, _ = step_run
    out = tmp_path / "f.txt"
    r = run_in_process(f"enc make-rom {points} --target fanuc --sign error --axis 4 "
                       f"--increment-system IS-C --backlash --verify -q -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    assert "PARAMETER 1851 AXIS 4 VALUE 17  # backlash" in out.read_text()
    table = rf.read_control_table(str(out), "fanuc", "error")
    assert table.backlash_rad == pytest.approx(np.radians(17 * IS_C))


@pytest.mark.parametrize("opts", [
    "--target fanuc-param --sign error",
    "--target siemens --bits 23 --address-bits 3 --resolution 0.0001",  # MD32450 alike
])
def test_backlash_needs_both_directions(tmp_path, opts):
    r = run(f"enc acquire --rig ciomp-23bit --mode steps --count 8 --readings 2 -q | "
            f"enc points -q -o {tmp_path}/one.parquet")
    assert r.returncode == 0, r.stderr.decode()
    out = tmp_path / "p.txt"
    r = run_in_process(f"enc make-rom {tmp_path}/one.parquet {opts} "
                       f"--backlash --allow-coarse -o {out}")
    assert "needs a step run with both directions" in one_error_line(r, 2, "enc make-rom")
    assert not out.exists() and not (tmp_path / "p_tea.ini").exists()


#: a record as a Series 30i punches it (other axes' values, other parameters, trailing
#: blanks; no newline after the closing %): axis 4 turns in 4 sections of 90 deg
SERIES_30I = ("%\nN01005Q1A1P00000010A2P00000010A3P00000010A4P00000010\n"
              "N01851Q1A1P40A2P10A3P20A4P-4 \nN03605Q1A1P00000000A4P00000000\n"
              "N03620Q1A1P40A2P140A3P240A4P300\nN03621Q1A1P1A2P101A3P201A4P301 \n"
              "N03622Q1A1P41A2P141A3P241A4P304\nN03623Q1A1P10A2P10A3P10A4P2\n"
              "N03624Q1A1P40.0A2P27.5A3P27.5A4P90.0 \nN03625Q1A1P0.0A2P0.0A3P0.0A4P360.0\n"
              "N10299Q0P5\nN10300Q0P0\nN10301Q0P3 \nN10302Q0P-1\nN10303Q0P-4 \nN10304Q0P2\n%")


def test_reader_takes_a_series_30i_record(tmp_path):
    f = tmp_path / "CNC-PARA.TXT"
    f.write_text(SERIES_30I)
    t = rf.read_control_table(str(f), "fanuc-param", "correction", axis="4")
    assert np.degrees(t.positions_rad).tolist() == pytest.approx([0, 90, 180, 270, 360])
    # running sums 0, 3, 2, -2, 0 x magnification 2 x 0.001 deg
    assert np.degrees(t.forward_rad).tolist() == pytest.approx([0, 6e-3, 4e-3, -4e-3, 0])
    assert np.degrees(t.backlash_rad) == pytest.approx(-4e-3)
    assert t.modulo_rad == pytest.approx(2 * np.pi)
    assert rf.registry.get("fanuc-param").signature.search(f.read_bytes()[:4096])


@pytest.mark.parametrize("change, says", [
    (("N10304Q0P2", "N10304Q0P3"), "sum to 1, not 0"),
    (("N10303Q0P-4 \n", ""), "no pitch error data for points [303]"),
    (("%\nN01005", "N01005"), "no record between a % leader"),
    (("A4P360.0", "A4P350.0"), "(3622 - 3620) x 3624 = 3625"),
    (("N03623Q1A1P10A2P10A3P10A4P2\n", ""), "lacks parameters [3623]"),
    (("N10302Q0P-1", "N10302Q0P-1.5"), "N<10000 + point>Q0P<integer>"),
])
def test_reader_refuses_what_the_cnc_would(tmp_path, change, says):
    f = tmp_path / "p.txt"
    f.write_text(SERIES_30I.replace(*change))
    with pytest.raises(DataError, match=re.escape(says)) as err:
        rf.read_control_table(str(f), "fanuc-param", "correction", axis="4")
    assert "\n" not in str(err.value)


def test_backlash_beyond_1851s_range_is_one_line(step_run, tmp_path):  # noqa: F811
    """A reversal of 4000 arcsec at IS-C is 11111 detection units: beyond 1851's 9999."""
    points, _ = step_run
    t = pq.read_table(points)
    i = t.schema.get_field_index("deviation")
    dev = t.column("deviation").to_numpy() + t.column("direction").to_numpy() * 2000.0
    pq.write_table(t.set_column(i, t.schema.field(i), pa.array(dev)), tmp_path / "lash.parquet")
    out = tmp_path / "p.txt"
    r = run_in_process(f"enc make-rom {tmp_path}/lash.parquet --target fanuc-param --sign error "
                       f"--increment-system IS-C --backlash -o {out}")
    assert "beyond the control's range -9999..9999" in one_error_line(r, 2, "enc make-rom")
    assert not out.exists()
