"""SINUMERIK's backlash (MD32450 $MA_BACKLASH) written in a machine data file of the
axis beside the $AA_ENC_COMP table, the table then of the positive direction: the file
parsed here as the control reads a machine data file (a reader of the test's own), the
value against the step run's known reversal, enc correct closing the gap between the
directions, and the refusals, one line each."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from conftest import one_error_line, run, run_in_process
from test_rom_controls import TARGETS, known_reversal, step_run  # noqa: F401 (fixture)
from test_rom_fanuc import direction_means

from enctools.models import romformats as rf

RES = 1e-4  # deg, the control's resolution given
RES_ARCSEC = RES * 3600.0


def control_reads(text: str) -> tuple[str, dict[tuple[int, str], float]]:
    """A machine data file as the control reads one in punch tape format: its name from
    the first line (%_N_..._INI), then one assignment a line ($MA_<name>[e,axis]=value,
    an optional N<number> before it), ';' comments, M17 the end."""
    lines = text.split("\n")
    name = re.fullmatch(r"%(_N_\w+_INI)", lines[0]).group(1)
    data = {}
    for line in lines[1:]:
        code = line.split(";", 1)[0].strip()
        if code == "M17":
            break
        if code:
            e, axis, value = re.fullmatch(r"(?:N\d+\s*)?\$MA_BACKLASH\[(\d+),(\w+)\]=(\S+)",
                                          code).groups()
            data[(int(e), axis)] = float(value)
    return name, data


def make(points, out, opts: str = "") -> dict:
    r = run(f"enc make-rom {points} --target siemens --bits 23 --address-bits 3 "
            f"--resolution {RES} --backlash {opts} --verify --json -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout)


def test_machine_data_file_as_the_control_reads_it(step_run, tmp_path):  # noqa: F811
    """Beside the table, _N_AX1_TEA_INI holds $MA_BACKLASH[0,AX1] = the mean reversal in
    deg at the resolution (6 arcsec: 17 x 0.0001 deg, positive: the encoder leads on
    reversal), and the table holds the positive direction's correction, not the mean."""
    points, intended = step_run
    out = tmp_path / "comp.spf"
    s = make(points, out)
    side = tmp_path / "comp_tea.ini"
    assert s["machine_data"] == str(side) and side.exists()
    name, data = control_reads(side.read_text(encoding="ascii"))
    assert name == "_N_AX1_TEA_INI" and list(data) == [(0, "AX1")]
    reversal = float(np.mean(known_reversal(np.arange(TARGETS) * 15.0)))  # 6 arcsec
    assert data[(0, "AX1")] == pytest.approx(s["backlash_steps"] * RES, abs=1e-12)
    assert s["backlash_steps"] == round(-s["reversal_mean_arcsec"] / RES_ARCSEC) == 17
    assert data[(0, "AX1")] * 3600.0 == pytest.approx(reversal, abs=RES_ARCSEC / 2 + 0.05)
    # the table: the positive direction's correction at 0, 45, ... deg (every 3rd target)
    table = rf.read_control_table(str(out), "siemens")
    got = table.correction(np.radians(np.arange(8) * 45.0)) / (np.pi / 648000.0)
    assert np.max(np.abs(got - intended[1][::3])) <= RES_ARCSEC / 2 * (1 + 1e-6)
    assert table.backlash_rad == pytest.approx(np.radians(17 * RES))


def test_measuring_system_and_axis_named(step_run, tmp_path):  # noqa: F811
    points, _ = step_run
    out = tmp_path / "T.SPF"
    make(points, out, "--axis AX4 --zone 1")
    name, data = control_reads((tmp_path / "T_TEA.INI").read_text(encoding="ascii"))
    assert name == "_N_AX4_TEA_INI" and list(data) == [(1, "AX4")]


def test_enc_correct_closes_the_gap_between_directions(step_run, tmp_path):  # noqa: F811
    """enc correct reads the machine data file beside the table and adds the backlash in
    the negative direction: the mean gap between the directions, 6 arcsec before, is
    within half the resolution of 0; the table's points (0, 45, ... deg) hold the positive
    direction within half the resolution."""
    points, _ = step_run
    out = tmp_path / "comp.spf"
    s = make(points, out)
    fixed = tmp_path / "fixed.parquet"
    r = run(f"enc correct {points} --table {out} --json -o {fixed}")
    assert r.returncode == 0, r.stderr.decode()
    described = json.loads(r.stdout)["table"]
    assert described["bidirectional"] is True
    assert described["backlash_arcsec"] == pytest.approx(s["backlash_arcsec"])
    up, down = direction_means(fixed)
    assert np.max(np.abs(up[::3])) <= RES_ARCSEC / 2 * (1 + 1e-6) + 0.02
    gap = float(np.mean(up - down))
    assert abs(gap - (-s["reversal_mean_arcsec"] - s["backlash_arcsec"])) < 1e-6
    assert abs(gap) <= RES_ARCSEC / 2 + 1e-6


@pytest.mark.parametrize("opts, says", [
    ("--axis C1", "give --axis as AX<n>"),
    ("--target acs --sign error", "--backlash applies to"),
])
def test_refusals_are_one_line(step_run, tmp_path, opts, says):  # noqa: F811
    points, _ = step_run
    out = tmp_path / "t.spf"
    r = run_in_process(f"enc make-rom {points} --target siemens --bits 23 --address-bits 3 "
                       f"--resolution {RES} --backlash {opts} -o {out}")
    assert says in one_error_line(r, 2, "enc make-rom")
    assert not out.exists() and not (tmp_path / "t_tea.ini").exists()


def test_reader_refuses_another_axis(step_run, tmp_path):  # noqa: F811
    points, _ = step_run
    out = tmp_path / "comp.spf"
    make(points, out)
    side = tmp_path / "comp_tea.ini"
    side.write_text(side.read_text().replace("AX1", "AX2"))
    r = run_in_process(f"enc correct {points} --table {out}")
    assert "holds the machine data of AX2" in one_error_line(r, 2, "enc correct")


def test_no_summary_figure_is_minus_zero():
    """A correction of exactly 0 at the home position (a model of 10 sin theta) negated is
    -0.0: the summary's offset_removed_arcsec, and every other figure, is +0.0 instead."""
    import math

    from enctools.models.romformats import controls

    source = controls.Source(lambda a: 10.0 * np.sin(np.radians(a)))
    settings = controls.ControlSettings("fanuc", sign="error", points=25)
    summary = controls.build(settings, source).summary
    assert summary["offset_removed_arcsec"] == 0.0
    assert all(math.copysign(1.0, v) == 1.0 or v < 0
               for v in summary.values() if isinstance(v, float))
    assert "-0" not in json.dumps(summary)


def test_correct_refuses_what_a_format_does_not_read():
    """Every reader option (sign, array_name, comp_type, axis, detection_unit_deg) walked
    through every registered format: refused, one line naming the formats that take it,
    exactly where the format's reader is not told it; a memory's layout refused for
    every controller's and control's file; endian for all but the binary images."""
    from enctools.errors import SettingsError
    from enctools.models import correction
    from enctools.models.romformats import registry

    readers = {"sign": {"acs", "twincat-nc", "fanuc", "fanuc-param", "heidenhain"},
               "array_name": {"acs"}, "comp_type": {"linuxcnc"},
               "axis": {"heidenhain", "fanuc-param"},
               "detection_unit_deg": {"fanuc-param"}}
    for fmt in [*registry.names(), correction.STREAM]:
        for name, takes in readers.items():
            settings = correction.TableSettings(options_given=frozenset({name}))
            if fmt in takes:
                correction.check_applies(settings, fmt, "t")
                continue
            with pytest.raises(SettingsError, match=f"{name} applies to .*, not the .*t$"):
                correction.check_applies(settings, fmt, "t")
        record = registry.find(fmt)
        layout = correction.TableSettings(width=8)
        if record is not None and record.points:
            with pytest.raises(SettingsError, match="describes a memory's table"):
                correction.check_applies(layout, fmt, "t")
        else:
            correction.check_applies(layout, fmt, "t")
        endian = correction.TableSettings(endian="big")
        if fmt in ("bin", "ihex"):
            correction.check_applies(endian, fmt, "t")
        elif record is None or not record.points:
            with pytest.raises(SettingsError, match="endian applies to bin and ihex"):
                correction.check_applies(endian, fmt, "t")


def test_make_rom_takes_each_option_where_a_format_uses_it():
    """The options of the addressed tables walked through the records: lsb the memories'
    (a controller's steps at its resolution), endian the binary images', zone and
    array_name only where the program names them, backlash SINUMERIK's of the
    controllers'."""
    from enctools.models.romformats import registry

    takers = {name: {r.name for r in registry.records() if name in r.accepts}
              for name in ("lsb", "endian", "zone", "array_name", "backlash")}
    assert takers["lsb"] == set(registry.names(registry.MEMORY))
    assert takers["endian"] == {"bin", "ihex"}
    assert takers["zone"] == {"acs", "siemens"}
    assert takers["array_name"] == {"acs"}
    assert takers["backlash"] == {"siemens", *registry.names(registry.CONTROL)}
