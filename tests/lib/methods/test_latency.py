"""enc latency: seed 001 eqs. 1-4 and the lag measured on simulated runs."""

from __future__ import annotations

import json

import pytest
from conftest import ROOT, run

from enctools.methods import latency as lat


def test_code_skip_speed_is_eq4_exactly():
    v = lat.code_skip_speed_deg_s(23, 10e-6)
    assert v == 360.0 / (2 ** 23 * 10e-6)  # seed 001 eq. (4), bit for bit
    assert lat.resolution_deg(23) * 3600 == pytest.approx(0.1545, abs=1e-4)  # 0.15" (eq. 3)
    # at that speed the lag t_d v (eq. 2) is exactly one code
    assert lat.dynamic_error_deg(10e-6, v) == pytest.approx(lat.resolution_deg(23), rel=1e-15)
    assert lat.readout_delay(6e-6, 4e-6) == pytest.approx(10e-6)


def test_latency_command_analytic():
    r = run("enc latency --bits 23 --delay 10e-6 --speeds 0.5,600 --json")
    assert r.returncode == 0, r.stderr.decode()
    d = json.loads(r.stdout)
    assert d["code_skip_speed_deg_s"] == 360.0 / (2 ** 23 * 10e-6)
    slow, fast = d["speeds"]
    assert not slow["skips_codes"] and fast["skips_codes"]
    assert fast["dynamic_error_arcsec"] == pytest.approx(10e-6 * 3600 * 3600)
    # seed 001: a 23-bit reference that keeps every code at 10 r/s needs t_d < 11.9 ns
    r = run("enc latency --bits 23 --delay 11.9e-9")
    assert b"10.0" in r.stdout and b"r/s" in r.stdout


@pytest.fixture(scope="module")
def slow_rig(tmp_path_factory):
    d = tmp_path_factory.mktemp("lat")
    text = (ROOT / "enctools/rigs/ciomp-23bit.toml").read_text()
    assert "latency_s = 1e-8" in text
    (d / "slow.toml").write_text(text.replace("latency_s = 1e-8", "latency_s = 1e-4", 1))
    for name, rpm in (("fwd", 60), ("rev", -30)):
        r = run(f"enc acquire --rig {d}/slow.toml --mode continuous --speed {rpm} --revolutions 1 "
                f"--interval 2e-4 -o {d}/{name}.parquet")
        assert r.returncode == 0, r.stderr.decode()
    return d


@pytest.mark.slow
def test_measured_lag_one_run(slow_rig):
    r = run(f"enc latency {slow_rig}/fwd.parquet --json")
    assert r.returncode == 0, r.stderr.decode()
    d = json.loads(r.stdout)
    assert d["measured_lag_s"] == pytest.approx(1e-4, rel=0.01)  # truth: 100 us
    assert d["bits"] == 23


@pytest.mark.slow
def test_measured_lag_two_speeds_fits_offset(slow_rig):
    r = run(f"enc latency {slow_rig}/fwd.parquet {slow_rig}/rev.parquet --fit-offset --json")
    assert r.returncode == 0, r.stderr.decode()
    d = json.loads(r.stdout)
    assert d["measured_lag_s"] == pytest.approx(1e-4, rel=0.01)
    assert abs(d["offset_arcsec"]) < 0.5


def test_latency_bad_usage(ciomp_steps):
    r = run("enc latency")
    assert r.returncode == 2 and r.stderr.startswith(b"enc latency: error:")
    r = run(f"enc latency {ciomp_steps}")
    assert r.returncode == 2 and b"continuous run" in r.stderr
    r = run("enc latency --bits 23 --delay -1")
    assert r.returncode == 2


@pytest.mark.slow
def test_latency_bad_data(slow_rig, tmp_path):
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(slow_rig / "fwd.parquet")
    t = table.column("t").to_numpy().copy()
    t[10] = np.nan
    bad = tmp_path / "nan-t.parquet"
    pq.write_table(table.set_column(table.column_names.index("t"), "t", pa.array(t)), bad)
    r = run(f"enc latency {bad}")
    assert r.returncode == 2
    lines = r.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("enc latency: error:") and "'t'" in lines[0]
    r = run("enc latency --bits 23 --delay 1e-5 --speeds 1,nan")
    assert r.returncode == 2 and b"finite" in r.stderr and r.stdout == b""
