"""Faults that lose nothing: signals and dead devices mid-run, real processes, real signals.

An acquisition streams batch by batch. The test reads the stream from the process's
stdout as it arrives, sends the signal once it has seen some batches, then reads on to
the end: the stream must end cleanly (a valid Arrow stream), hold every batch seen
before the signal and be a gap-free prefix of the run; the --tee copy on disk must
hold the same rows; the exit status is 130 (SIGINT) or 143 (SIGTERM).

Missing drivers and packages are played by shadow packages on PYTHONPATH.
"""

from __future__ import annotations

import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import ROOT, enc_exe, run

VISA_RIG = ROOT / "tests" / "rigs" / "visa-sim.toml"


def interrupt(args: list[str], sig: int, after_batches: int,
              tee: Path) -> tuple[int, pa.Table, str]:
    """Run enc with args streaming to a pipe; signal it after some batches; read to the end."""
    proc = subprocess.Popen([enc_exe(), *args, "--tee", str(tee)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    try:
        reader = pa.ipc.open_stream(proc.stdout)
        batches = [reader.read_next_batch() for _ in range(after_batches)]
        proc.send_signal(sig)
        batches += list(reader)  # raises if the stream does not end cleanly
        code = proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    err = proc.stderr.read().decode()
    return code, pa.Table.from_batches(batches, schema=reader.schema), err


def gap_free_prefix(t: np.ndarray, interval: float) -> None:
    assert np.allclose(t - t[0], np.arange(len(t)) * interval, atol=1e-9)


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
@pytest.mark.slow
def test_signal_mid_run_keeps_every_batch(tmp_path: Path, sig: int, code: int) -> None:
    tee = tmp_path / "tee.parquet"
    # 20 revolutions at 1 r/min would take 20 minutes in real time: it is interrupted.
    got_code, table, err = interrupt(["acquire", "--rig", "sjtu-dual", "--interval", "0.003",
                                      "--realtime"], sig, 3, tee)
    assert got_code == code, err
    assert err.strip().splitlines()[-1] == ("enc acquire: error: interrupted" if code == 130
                                            else "enc acquire: error: terminated")
    assert table.num_rows >= 3 * 67  # 3 blocks of 0.2 s at 3 ms seen before the signal
    gap_free_prefix(table.column("t").to_numpy(), 0.003)
    disk = pq.read_table(tee)
    assert disk.num_rows == table.num_rows
    assert disk.column("H1").equals(table.column("H1"))
    r = run(f"enc info {tee}")
    assert r.returncode == 0, r.stderr.decode()


@pytest.mark.slow
def test_sigint_to_file_output_leaves_a_valid_file(tmp_path: Path) -> None:
    out = tmp_path / "run.parquet"
    proc = subprocess.Popen([enc_exe(), "acquire", "--rig", "ciomp-23bit", "--realtime",
                             "--mode", "continuous", "-o", str(out)], stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60  # a loaded machine may take seconds to start it
    while time.monotonic() < deadline and not list(tmp_path.glob(".run.parquet.*")):
        time.sleep(0.05)
    time.sleep(1.5)
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=30) == 130
    t = pq.read_table(out)
    assert t.num_rows > 0
    gap_free_prefix(t.column("t").to_numpy(), 0.001)
    assert not list(tmp_path.glob(".run.parquet.*"))  # no temporary file left


@pytest.mark.slow
def test_sigint_during_instrument_steps(tmp_path: Path) -> None:
    """SIGINT between positions of a pyvisa-sim steps run: whole positions, exit 130."""
    tee = tmp_path / "tee.arrows"
    code, table, err = interrupt(["acquire", "--rig", str(VISA_RIG), "--settle", "0.15"],
                                 signal.SIGINT, 2, tee)
    assert code == 130, err
    steps = table.column("step").to_pylist()
    assert len(steps) < 48
    assert steps == [k for k in range(len(steps) // 2) for _ in range(2)]
    r = run(f"enc info {tee}")
    assert r.returncode == 0 and f"{len(steps)} rows".encode() in r.stdout


def dead_rig(tmp_path: Path) -> Path:
    shutil.copy(VISA_RIG.parent / "rotary-table.yaml", tmp_path)
    text = VISA_RIG.read_text()
    text = text.replace("192.168.0.21", "192.168.0.22")  # the controller that goes silent
    p = tmp_path / "dead.toml"
    p.write_text(text)
    return p


@pytest.mark.slow
def test_device_silent_mid_run_exit_3_keeps_stream(tmp_path: Path) -> None:
    """Silent beyond ~90 deg: positions 0..6 (0..90 deg) kept, exit 3, errors reported."""
    out = tmp_path / "run.parquet"
    tee = tmp_path / "tee.arrows"
    r = run(f"enc acquire --rig {dead_rig(tmp_path)} --tee {tee} | enc info > {tmp_path}/info.txt;"
            f" exit ${{PIPESTATUS[0]}}")
    err = r.stderr.decode()
    assert r.returncode == 3, err
    assert err.count("(attempt ") == 3  # the first try and 2 retries, each logged
    last = err.strip().splitlines()[-1]
    assert last.startswith("enc acquire: error: instrument table")
    assert "no answer to 'MOVE 2" in last and "after 3 attempts of 0.2 s" in last
    assert '-222,"Data out of range"' in last  # the error queue, read and reported
    info = (tmp_path / "info.txt").read_text()
    assert "14 rows" in info  # the stream on the pipe ended cleanly with 7 positions
    r2 = run(f"enc info {tee}")
    assert r2.returncode == 0 and b"14 rows" in r2.stdout
    # The same with a file output and options overriding the rig's patience.
    r3 = run(f"enc acquire --rig {dead_rig(tmp_path)} --retries 0 --timeout 0.1 -o {out}")
    assert r3.returncode == 3
    assert "after 1 attempt of 0.1 s" in r3.stderr.decode()
    steps = pq.read_table(out).column("step").to_pylist()
    assert steps == [k for k in range(7) for _ in range(2)]


def shadow(tmp_path: Path, name: str, files: dict[str, str]) -> dict[str, str]:
    """A PYTHONPATH with a stand-in package ``name`` made of ``files``."""
    d = tmp_path / "shadow" / name
    d.mkdir(parents=True)
    for fname, text in files.items():
        (d / fname).write_text(text)
    return {"PYTHONPATH": str(tmp_path / "shadow")}


NIDAQ_RIG = (ROOT / "tests" / "rigs" / "nidaq-bench.toml").read_text()


def test_nidaq_without_package_is_exit_2(tmp_path: Path) -> None:
    rig = tmp_path / "nidaq.toml"
    rig.write_text(NIDAQ_RIG)
    env = shadow(tmp_path, "nidaqmx", {"__init__.py": "raise ImportError('no nidaqmx')\n"})
    r = run(f"enc acquire --rig {rig} --mode steps --count 2 -o {tmp_path / 'x.parquet'}",
            env=env)
    err = r.stderr.decode().strip()
    assert r.returncode == 2, err
    assert err == ("enc acquire: error: the nidaq backend needs the Python package nidaqmx: "
                   "pip install 'enctools[nidaq]' (and the NI-DAQmx driver from ni.com)")


def test_nidaq_without_driver_is_exit_3(tmp_path: Path) -> None:
    rig = tmp_path / "nidaq.toml"
    rig.write_text(NIDAQ_RIG)
    env = shadow(tmp_path, "nidaqmx", {
        "__init__.py": ("from . import constants, errors\n"
                        "class Task:\n"
                        "    def __init__(self, *a, **k):\n"
                        "        raise errors.DaqNotFoundError('Could not find an installation "
                        "of NI-DAQmx.')\n"),
        "errors.py": "class DaqError(Exception): pass\nclass DaqNotFoundError(Exception): pass\n",
        "constants.py": "",
    })
    r = run(f"enc acquire --rig {rig} --mode steps --count 2 -o {tmp_path / 'x.parquet'}",
            env=env)
    err = r.stderr.decode().strip()
    assert r.returncode == 3, err
    assert err.startswith("enc acquire: error: NI-DAQmx driver not found") and "\n" not in err


def test_nidaq_decoding_must_match_interpolation(tmp_path: Path) -> None:
    rig = tmp_path / "nidaq.toml"
    rig.write_text(NIDAQ_RIG.replace("interpolation = 4", "interpolation = 2048"))
    env = shadow(tmp_path, "nidaqmx", {"__init__.py": "from . import constants, errors\n",
                                       "errors.py": "", "constants.py": ""})
    r = run(f"enc acquire --rig {rig} --mode steps -o {tmp_path / 'x.parquet'}", env=env)
    assert r.returncode == 2
    assert "X4 decoding gives 4 counts per line, but interpolation = 2048" in r.stderr.decode()


def test_visa_without_pyvisa_is_exit_2(tmp_path: Path) -> None:
    env = shadow(tmp_path, "pyvisa", {"__init__.py": "raise ImportError('no pyvisa')\n"})
    r = run(f"enc acquire --rig {VISA_RIG} -o {tmp_path / 'x.parquet'}", env=env)
    assert r.returncode == 2
    assert "needs the Python package pyvisa" in r.stderr.decode()
