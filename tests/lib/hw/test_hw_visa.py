"""The visa backend against pyvisa-sim instruments (tests/rigs/rotary-table.yaml).

The scripted table goes exactly where it is told and its counter inputs read the
commanded counts; the autocollimator reads a constant 0.120". So every number of the
stream is known: the head counts at step j are round(j * 2^23 / 24) (plus the
overshoot moves' absence), the autocollimator 0.12, and `enc points` finds deviations
no larger than the count quantisation.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from conftest import ROOT, one_error_line, run, skip_without

skip_without("pyvisa_sim")

RIG = ROOT / "tests" / "rigs" / "visa-sim.toml"
CPR = 1 << 23
QUANT = 360 * 3600 / CPR  # one count [arcsec]


def rig_variant(tmp_path: Path, **subs: str) -> Path:
    """A copy of visa-sim.toml and its simulation file with text substitutions (old=new)."""
    shutil.copy(RIG.parent / "rotary-table.yaml", tmp_path)
    text = RIG.read_text()
    for old, new in subs.items():
        assert old in text, old
        text = text.replace(old, new)
    p = tmp_path / "rig.toml"
    p.write_text(text)
    return p


@pytest.fixture(scope="module")
def visa_steps(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("visa") / "steps.parquet"
    r = run(f"enc acquire --rig {RIG} --mode steps -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    return out


@pytest.mark.slow
def test_steps_stream_is_the_same_kind_as_the_simulators(visa_steps: Path,
                                                         ciomp_steps: Path) -> None:
    v = pq.read_table(visa_steps)
    s = pq.read_table(ciomp_steps)
    assert v.schema.metadata[b"kind"] == s.schema.metadata[b"kind"] == b"readings"
    assert v.schema.names == s.schema.names
    for fv, fs in zip(v.schema, s.schema):
        assert fv.type == fs.type, fv.name
        mv = {k: x for k, x in (fv.metadata or {}).items()}
        ms = {k: x for k, x in (fs.metadata or {}).items()}
        assert mv == ms, fv.name  # same units, roles and head geometry
    assert v.num_rows == 48  # 24 positions x 2 readings (the rig's [acquire.steps])
    step = v.column("step").to_numpy()
    expected = np.rint(step * CPR / 24).astype(np.int64)
    assert np.array_equal(v.column("F1").to_numpy(), expected)
    assert np.array_equal(v.column("F2").to_numpy(), expected)
    assert np.allclose(v.column("AC").to_numpy(), 0.12)
    assert np.allclose(v.column("target").to_numpy(), step * 2 * np.pi / 24)
    t = v.column("t").to_numpy()
    assert np.all(np.diff(t) >= 0)
    r = run(f"enc info {visa_steps}")
    assert r.returncode == 0 and b"backend" not in r.stderr


@pytest.mark.slow
def test_settings_name_the_backend_and_instruments(visa_steps: Path) -> None:
    import json

    meta = json.loads(pq.read_schema(visa_steps).metadata[b"enctools"])
    be = meta["settings"]["backend"]
    assert be["backend"] == "visa" and be["retries"] == 2 and be["timeout_s"] == 0.2
    assert be["instruments"] == {  # where each instrument was, and what it said it is
        "table": {"address": "TCPIP0::192.168.0.21::inst0::INSTR",
                  "idn": "enctools,ROTSIM-1,0001,1.0"},
        "ac": {"address": "GPIB0::7::INSTR"}}
    assert "truth" not in meta  # real instruments know no truth


@pytest.mark.slow
def test_pipeline_points_fit_report(visa_steps: Path, tmp_path: Path) -> None:
    pts = tmp_path / "points.parquet"
    r = run(f"enc points {visa_steps} -o {pts} && enc fit-rbf {pts} | enc report")
    assert r.returncode == 0, r.stderr.decode()
    dev = pq.read_table(pts).column("deviation").to_numpy()
    assert len(dev) == 24
    # The scripted table is perfect: only the rounding of 15 deg to counts remains.
    assert np.ptp(dev) <= QUANT + 1e-9
    r2 = run(f"enc report {pts}")
    assert r2.returncode == 0 and b"points" in r2.stdout, r2.stderr.decode()


@pytest.mark.slow
def test_continuous_polls_the_counter(tmp_path: Path) -> None:
    out = tmp_path / "c.parquet"
    r = run(f"enc acquire --rig {RIG} --mode continuous --speed 60 --revolutions 0.25 "
            f"--interval 0.01 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    t = pq.read_table(out)
    assert t.num_rows == 25
    assert np.all(np.diff(t.column("t").to_numpy()) > 0)


def test_malformed_reply_quotes_raw_text(tmp_path: Path) -> None:
    rig = rig_variant(tmp_path, **{'[backend.counter]\ninstrument = "table"':
                                   '[backend.counter]\ninstrument = "box"',
                                   "[backend.instrument.ac]":
                                   '[backend.instrument.box]\nresource = "GPIB0::9::INSTR"\n\n'
                                   "[backend.instrument.ac]"})
    r = run(f"enc acquire --rig {rig} -o {tmp_path / 'x.parquet'}")
    line = one_error_line(r, 3)
    assert "malformed reply '12#4,x9' to 'COUN?'" in line, line


def test_nonexistent_resource_is_one_line_exit_3(tmp_path: Path) -> None:
    rig = rig_variant(tmp_path, **{"GPIB0::7::INSTR": "GPIB0::27::INSTR"})
    out = tmp_path / "x.parquet"
    r = run(f"enc acquire --rig {rig} -o {out}")
    line = one_error_line(r, 3)
    assert "GPIB0::27::INSTR" in line and "instrument ac" in line, line
    assert not out.exists()


def test_missing_simulation_file_is_exit_2(tmp_path: Path) -> None:
    rig = rig_variant(tmp_path, **{"rotary-table.yaml": "nosuch.yaml"})
    r = run(f"enc acquire --rig {rig} -o {tmp_path / 'x.parquet'}")
    line = one_error_line(r, 2)
    assert "nosuch.yaml" in line


@pytest.mark.parametrize("old,new,needle", [
    ('read = "COUN?"', 'read = "COUN?"\nrate = 5', "unknown key 'rate' in [backend.counter]"),
    ('move = "MOVE {counts:d}"', 'move = "MOVE {count:d}"', "template 'MOVE {count:d}'"),
    ('heads = ["F1", "F2"]', 'heads = ["F1"]', "lacks head 'F2'"),
    ('instrument = "ac"', 'instrument = "acx"', "no instrument 'acx'"),
])
def test_rig_backend_tables_are_checked(tmp_path: Path, old: str, new: str,
                                        needle: str) -> None:
    rig = rig_variant(tmp_path, **{old: new})
    r = run(f"enc acquire --rig {rig} -o {tmp_path / 'x.parquet'}")
    line = one_error_line(r, 2)
    assert needle in line, line


def test_signals_option_is_refused(tmp_path: Path) -> None:
    r = run(f"enc acquire --rig {RIG} --signals -o {tmp_path / 'x.parquet'}")
    assert "--signals" in one_error_line(r, 2)
