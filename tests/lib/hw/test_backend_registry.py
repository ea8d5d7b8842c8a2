"""The instrument backends are records of one registry (enctools.hw.backends).

The worked example of docs/ARCHITECTURE.md ("Worked example: an instrument backend"): a
new line instrument, a rotary table answering in memory (a loopback port), is
registered from this file alone, and ``enc acquire`` runs through it in-process: its
rig file is read, its key checked, its instruments opened, the table moved and read,
the stream written. Nothing in enctools names it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from conftest import ROOT, one_error_line, run_in_process

from enctools.data import streams
from enctools.data.rig import Rig
from enctools.hw import backends
from enctools.hw.config import need
from enctools.hw.retry import Policy

CPR = 4096 * 2048  # counts per revolution of the rig's encoder (visa-sim.toml's)


class LoopbackTable:
    """A rotary table and an autocollimator in memory, as a line port (retry.Port): ``MOVE
    n`` goes to n counts (answers OK), ``COUN?`` reads both heads there, ``MOVE:DONE?``
    says it is in position, ``MEAS?`` is the autocollimator's ``X,Y`` [arcsec], its error
    queue is empty."""

    def __init__(self, name: str, address: str, timeout_s: float, ac_arcsec: float) -> None:
        self.name, self.address, self.timeout_s = name, address, timeout_s
        self.ac_arcsec = ac_arcsec
        self.counts = 0
        self.replies: list[str] = []
        self.sent: list[str] = []

    def write(self, text: str) -> None:
        self.sent.append(text)
        if text.startswith("MOVE "):
            self.counts = int(text.split()[1]) % (1 << 23)
        self.replies.append({"COUN?": f"{self.counts},{self.counts}", "MOVE:DONE?": "1",
                             "MEAS?": f"{self.ac_arcsec},0.0", "SYST:ERR?": '0,"No error"',
                             "*IDN?": "enctools,LOOPBACK"}.get(text, "OK"))

    def read_line(self) -> str:
        return self.replies.pop(0)

    def clear(self) -> None:
        self.replies.clear()

    def close(self) -> None:
        pass

    def hint(self) -> str:
        return "is the loop closed?"


def open_loopback(name: str, cfg: dict[str, Any], rig: Rig, policy: Policy) -> LoopbackTable:
    """``[backend.instrument.NAME]`` of kind loopback: its ``address`` and the reading of
    its autocollimator ``ac_arcsec``."""
    where = f"backend.instrument.{name}"
    return LoopbackTable(name, need(cfg, "address", str, rig, where),
                         policy.timeout_s, float(need(cfg, "ac_arcsec", (int, float), rig, where,
                                                      0.0)))


LOOPBACK = backends.Backend("loopback", "a rotary table in memory", port=open_loopback,
                            keys=frozenset({"address", "ac_arcsec"}))


@pytest.fixture
def loopback() -> Iterator[backends.Backend]:
    """The loopback backend registered for one test."""
    backends.register(LOOPBACK)
    try:
        yield LOOPBACK
    finally:
        backends.unregister("loopback")


def loopback_rig(folder: Path, **subs: str) -> Path:
    """tests/rigs/visa-sim.toml with its instruments on the loopback backend."""
    text = (ROOT / "tests" / "rigs" / "visa-sim.toml").read_text()
    for old, new in {'kind = "visa"': 'kind = "loopback"',
                     'visa_library = "rotary-table.yaml@sim"': "",
                     'resource = "TCPIP0::192.168.0.21::inst0::INSTR"': 'address = "loop://table"',
                     'resource = "GPIB0::7::INSTR"': 'address = "loop://ac"\nac_arcsec = 1.25',
                     **subs}.items():
        assert old in text, old
        text = text.replace(old, new)
    path = folder / "loopback.toml"
    path.write_text(text)
    return path


def test_a_backend_registered_alone_runs_enc_acquire(tmp_path: Path, loopback) -> None:
    out = tmp_path / "run.parquet"
    r = run_in_process(f"enc acquire --rig {loopback_rig(tmp_path)} --mode steps --count 4 "
                       f"-o {out}")
    assert r.returncode == 0, r.stderr.decode()
    header, table = streams.read_table(str(out), "readings")
    assert table.column("step").to_pylist() == [0, 0, 1, 1, 2, 2, 3, 3]
    target = table.column("target").to_numpy()
    assert table.column("F1").to_pylist() == [round(t * CPR / (2 * math.pi)) for t in target]
    assert set(table.column("AC").to_pylist()) == {1.25}
    assert header.meta["settings"]["backend"]["backend"] == "loopback"
    assert header.meta["settings"]["backend"]["instruments"]["table"]["address"] == "loop://table"


def test_nothing_in_enctools_names_it() -> None:
    sources = (ROOT / "enctools").rglob("*.py")
    assert not [p for p in sources if "loopback" in p.read_text(encoding="utf-8")]


def test_its_keys_are_checked_as_every_backend_keys(tmp_path: Path, loopback) -> None:
    rig = loopback_rig(tmp_path, ac_arcsec="ac_arcsecs")
    line = one_error_line(run_in_process(f"enc acquire --rig {rig} -o {tmp_path}/x.parquet"), 2)
    assert line.endswith("unknown key 'ac_arcsecs' in [backend.instrument.ac]; "
                         "did you mean 'ac_arcsec'?"), line


def test_it_is_listed_while_registered_and_refused_after(tmp_path: Path, loopback) -> None:
    assert backends.kinds() == ("sim", "visa", "serial", "nidaq", "loopback")
    assert backends.kinds("port") == ("visa", "serial", "loopback")
    backends.unregister("loopback")
    rig = loopback_rig(tmp_path)
    line = one_error_line(run_in_process(f"enc acquire --rig {rig} -o {tmp_path}/x.parquet"), 2)
    assert line == ("enc acquire: error: rig visa-sim: backend 'loopback' is not available in "
                    "this enctools (backends: sim, visa, serial, nidaq)")


def test_raw_signals_only_where_the_record_says(tmp_path: Path, loopback) -> None:
    rig = loopback_rig(tmp_path)
    line = one_error_line(run_in_process(f"enc acquire --rig {rig} --signals "
                                         f"-o {tmp_path}/x.parquet"), 2)
    assert line == ("enc acquire: error: --signals: the loopback backend records counter "
                    "values only, not raw signals")
    assert backends.kinds("signals") == ("sim",)


def test_the_built_in_records() -> None:
    assert backends.kinds() == ("sim", "visa", "serial", "nidaq")
    assert backends.kinds("session") == ("sim",)
    assert backends.kinds("port") == ("visa", "serial")
    assert backends.kinds("counter") == ("nidaq",)
    assert str(backends.get("visa").missing()) == (
        "the visa backend needs the Python package pyvisa: pip install 'enctools[visa]' "
        "(and a VISA library, or pyvisa-py)")
    assert str(backends.get("serial").missing()) == (
        "the serial backend needs the Python package pyserial: pip install 'enctools[serial]'")
    with pytest.raises(ValueError, match="registered already"):
        backends.register(backends.Backend("sim", "another simulator"))


def test_the_command_line_lists_them_from_the_registry() -> None:
    """The help names the backends registered when the command is first imported (a
    test's loopback among them when the command was first imported during its test)."""
    help_text = " ".join(run_in_process("enc acquire --help").stdout.decode().split())
    assert "raw sin/cos signals [V] (backend sim)" in help_text
    assert "Instruments (visa, serial" in help_text
