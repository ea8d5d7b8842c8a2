"""A correction-table format is one record of the registry (models/romformats/registry.py).

The test registers a format of its own, ``pts`` (text lines ``position<TAB>correction``
in degrees, a control's table over the turn), from here alone: enc make-rom writes it and
reads it back (--verify), enc correct applies it to a continuous run's readings as a
controller interpolates it, both commands list it while it is registered and refuse it
once it is not. Nothing in enctools names it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import IO, Any

import numpy as np
import pytest
from conftest import DATA, one_error_line, run_in_process

from enctools.models.romformats import registry
from enctools.models.romformats.controls import ControlTable
from enctools.models.romformats.points import PointTable
from enctools.models.romformats.record import CONTROL, Control, PointOptions, TableFormat

#: the toy control's resolution [deg]: seven decimals
RESOLUTION_DEG = 1e-7


def write_pts(f: IO[bytes], t: ControlTable, comment: list[str]) -> None:
    """``position<TAB>correction`` a line [deg], after ``#`` comment lines."""
    lines = [f"# {c}\n" for c in comment]
    for position, steps in zip(t.grid_deg.tolist(), t.forward.tolist(), strict=True):
        lines.append(f"{position:.7f}\t{steps * RESOLUTION_DEG:.7f}\n")
    f.write("".join(lines).encode("ascii"))


def read_pts(data: bytes, src: str, options: PointOptions) -> PointTable:
    """The lines back as the toy control reads them: a table over the turn."""
    rows = [line.split("\t") for line in data.decode("ascii").splitlines()
            if line and not line.startswith("#")]
    position, correction = (np.array([float(r[i]) for r in rows]) for i in (0, 1))
    return PointTable(np.radians(position), np.radians(correction), modulo_rad=2 * math.pi)


PTS = TableFormat("pts", "position<TAB>correction text [deg]", CONTROL, (".pts",),
                  write_table=write_pts, read_points=read_pts,
                  control=Control(RESOLUTION_DEG, 3601, False), sign="correction")


@pytest.fixture(scope="module")
def run_and_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Seed 001 table 1's model and a short continuous run of the 23-bit rig."""
    d = tmp_path_factory.mktemp("registry")
    for args in (f"enc fit-rbf {DATA}/seed001_table1.csv -q -o {d}/m.parquet",
                 "enc acquire --rig ciomp-23bit --mode continuous --revolutions 0.2 "
                 f"--interval 0.005 -q -o {d}/run.parquet"):
        r = run_in_process(args)
        assert r.returncode == 0, r.stderr.decode()
    return d


@pytest.fixture
def pts() -> Any:
    registry.register(PTS)
    yield PTS
    registry.unregister("pts")


def summary(r: Any) -> dict[str, Any]:
    assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout)


def test_a_format_registered_from_outside_is_written_read_back_and_applied(run_and_model, pts):
    d = run_and_model
    # table 1's 24 points cannot show a gain (enc-make-rom(1), GUARDS): the format is tested
    made = summary(run_in_process(f"enc make-rom {d}/m.parquet -o {d}/t.pts --verify --json "
                                  "--allow-no-gain"))
    assert made["target"] == "pts" and made["verified"] and made["points"] == 3601
    text = (d / "t.pts").read_text()
    assert text.startswith("# enctools make-rom") and "\n0.0000000\t" in text
    assert "\n360.0000000\t" in text

    model = summary(run_in_process(f"enc correct {d}/run.parquet --table {d}/m.parquet --json"))
    table = summary(run_in_process(f"enc correct {d}/run.parquet --table {d}/t.pts --json"))
    assert table["table"]["format"] == "pts" and table["table"]["family"] == "points"
    assert table["before"] == model["before"]
    # the control's interpolation between 0.1 deg points and its 1e-7 deg steps against the
    # model itself: the same correction within a thousandth of an arcsecond
    assert table["after"]["s_bessel_arcsec"] == pytest.approx(
        model["after"]["s_bessel_arcsec"], abs=1e-3)


def test_a_registered_format_is_listed_and_its_options_checked(run_and_model, pts):
    for command in ("make-rom", "correct"):
        r = run_in_process(f"enc {command} --help")
        assert r.returncode == 0 and "|heidenhain|pts" in r.stdout.decode()
    assert registry.by_extension(".PTS") is PTS and "pts" in registry.names(CONTROL)
    r = run_in_process(f"enc make-rom {run_and_model}/m.parquet -o {run_and_model}/x.pts "
                       "--comp-type 1")
    assert "--comp-type applies to linuxcnc, not --target pts" in one_error_line(r, 2,
                                                                                   "enc make-rom")
    with pytest.raises(ValueError, match="registered already"):
        registry.register(TableFormat("pts", "another", CONTROL, write_table=write_pts,
                                      read_points=read_pts, control=PTS.control))


def test_an_unregistered_format_is_refused(run_and_model):
    d = run_and_model
    assert registry.find("pts") is None
    r = run_in_process(f"enc make-rom {d}/m.parquet -o {d}/y.pts --allow-no-gain")
    assert "cannot tell the table format" in one_error_line(r, 2, "enc make-rom")
    r = run_in_process(f"enc make-rom {d}/m.parquet --target pts -o {d}/y.pts")
    assert r.returncode == 2 and "'pts' is not one of" in r.stderr.decode()
    assert not (d / "y.pts").exists()
    assert "pts" not in run_in_process("enc correct --help").stdout.decode()


def test_old_spellings_still_work_for_a_release(run_and_model, tmp_path):
    d = run_and_model
    r = run_in_process(f"enc correct {d}/run.parquet --table {d}/m.parquet --ref truth --json")
    assert r.returncode == 0, r.stderr.decode()
    assert "enc correct: WARNING: --ref is now spelt --reference" in r.stderr.decode()
    r = run_in_process(f"enc correct {d}/run.parquet --table {d}/m.parquet --ref truth "
                       "--reference truth")
    assert "old spelling of --reference" in one_error_line(r, 2, "enc correct")
    r = run_in_process(f"enc make-rom {d}/m.parquet --target fanuc --sign correction "
                       f"--ref-point 3 --points 25 --allow-no-gain --allow-coarse "
                       f"-o {tmp_path}/f.txt")
    assert r.returncode == 0, r.stderr.decode()
    assert "enc make-rom: WARNING: --ref-point is now spelt --home-point" in r.stderr.decode()
    assert "PARAMETER 3620 AXIS 1 VALUE 3 " in (tmp_path / "f.txt").read_text()
