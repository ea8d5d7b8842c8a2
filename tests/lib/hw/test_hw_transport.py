"""Transport and library failures mid-run are device faults that keep every sample read.

The pyvisa-sim rig (tests/rigs/visa-sim.toml) with its table controller's VISA resource
wrapped so that the Nth reply to the counter query fails as a real link can: a reset
TCP connection, a VISA session that went away, a reply whose integer does not fit in
64 bits. Each is exit 3 with one line naming the instrument, and the output holds every
position (steps) or every sample (continuous, the block in progress included) read
before it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
from conftest import ROOT, one_error_line, run_in_process, skip_without

from enctools.data import streams

skip_without("pyvisa_sim")

RIG = ROOT / "tests" / "rigs" / "visa-sim.toml"
TABLE = "instrument table (TCPIP0::192.168.0.21::inst0::INSTR)"


class Faulty:
    """A VISA resource whose ``at``-th reply to ``COUN?`` is ``fault`` (raised, or a reply)."""

    def __init__(self, resource: Any, at: int, fault: Any) -> None:
        self._resource = resource
        self._at = at
        self._fault = fault
        self._last = ""

    def write(self, text: str) -> Any:
        self._last = text
        return self._resource.write(text)

    def read(self) -> str:
        reply = self._resource.read()
        if self._last == "COUN?":
            self._at -= 1
            if self._at == 0:
                if isinstance(self._fault, str):
                    return self._fault
                raise self._fault
        return reply

    def __getattr__(self, name: str) -> Any:
        return getattr(self._resource, name)


def inject(monkeypatch: pytest.MonkeyPatch, at: int, fault: Any) -> None:
    from enctools.hw import visa

    init = visa.VisaPort.__init__

    def wrapped(self: Any, name: str, resource: Any, address: str, timeout_s: float) -> None:
        init(self, name, Faulty(resource, at, fault) if name == "table" else resource,
             address, timeout_s)

    monkeypatch.setattr(visa.VisaPort, "__init__", wrapped)


def faults() -> list[Any]:
    import pyvisa.errors

    return [pytest.param(ConnectionResetError(104, "Connection reset by peer"),
                         "read failed: ConnectionResetError: [Errno 104] Connection reset by peer",
                         id="reset"),
            pytest.param(pyvisa.errors.InvalidSession(), "read failed: InvalidSession",
                         id="invalid-session"),
            pytest.param("99999999999999999999999999,1",
                         "malformed reply '99999999999999999999999999,1' to 'COUN?'",
                         id="overflow")]


@pytest.mark.parametrize("fault,words", faults())
def test_transport_fault_in_steps_is_exit_3_and_keeps_positions(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fault: Any, words: str) -> None:
    out = tmp_path / "run.parquet"
    tee = tmp_path / "tee.arrows"
    inject(monkeypatch, 7, fault)  # 2 readings a position: positions 0..2 complete
    r = run_in_process(f"enc acquire --rig {RIG} --tee {tee} -o {out}")
    line = one_error_line(r, 3)
    assert line.startswith(f"enc acquire: error: {TABLE}: "), line
    assert words in line, line
    assert "internal error" not in line
    for path in (out, tee):
        steps = streams.read_table(path, "readings")[1].column("step").to_pylist()
        assert steps == [0, 0, 1, 1, 2, 2], path
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")] == []


@pytest.mark.parametrize("fault,words", faults())
def test_transport_fault_in_continuous_keeps_the_block_in_progress(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fault: Any, words: str) -> None:
    """Blocks of 0.25 s (25 polls at 10 ms): the fault at the 38th poll, in the second
    block, keeps the 37 samples read before it."""
    out = tmp_path / "run.parquet"
    inject(monkeypatch, 38, fault)
    r = run_in_process(f"enc acquire --rig {RIG} --mode continuous --speed 60 "
                       f"--revolutions 1 --interval 0.01 -o {out}")
    line = one_error_line(r, 3)
    assert words in line, line
    t = pq.read_table(out).column("t").to_numpy()
    assert len(t) == 37
    assert np.all(np.diff(t) > 0)


def test_signal_inside_a_realtime_block_keeps_the_samples_whose_time_came(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The simulator at wall-clock pace reads blocks of 0.2 s (67 samples at 3 ms, the
    interval given): a SIGINT halfway through the third wait keeps the two blocks and
    about half the third."""
    import time

    from enctools.hw import sim

    waits = []

    def pace(self: Any) -> None:  # the third wait is interrupted as SIGINT's handler would
        waits.append(self.t)
        if len(waits) == 3:  # 0.1 s before its end, however loaded the machine is
            self.start = time.monotonic() - (self.t - 0.1)
            raise KeyboardInterrupt
        time.sleep(max(0.0, self.start + self.t - time.monotonic()))

    monkeypatch.setattr(sim.RealtimeClock, "pace", pace)
    out = tmp_path / "run.parquet"
    r = run_in_process(f"enc acquire --rig sjtu-dual --interval 0.003 --realtime -o {out}")
    assert one_error_line(r, 130).endswith("error: interrupted")
    t = pq.read_table(out).column("t").to_numpy()
    assert 134 + 20 <= len(t) <= 134 + 47, len(t)  # 0.1 s of the third block, give or take
    assert np.allclose(np.diff(t), 0.003)


@pytest.mark.parametrize("error", [OSError(5, "Input/output error"),
                                   ValueError("I/O operation on closed file"),
                                   OverflowError("cannot convert")])
def test_serial_port_failures_are_device_errors(error: Exception) -> None:
    pytest.importorskip("serial")
    from enctools.errors import DeviceError
    from enctools.hw.serialline import SerialPort

    class Broken:
        def write(self, data: bytes) -> None:
            raise error

        def read_until(self, term: bytes) -> bytes:
            raise error

    port = SerialPort("ac", Broken(), "/dev/ttyUSB0", 0.1, "\r", "\r\n", "ascii", "9600 8N1")
    for call in (lambda: port.write("R"), port.read_line):
        with pytest.raises(DeviceError, match=r"^instrument ac \(/dev/ttyUSB0\): .*") as info:
            call()
        assert str(error) in str(info.value)


NIDAQ_RIG = (ROOT / "tests" / "rigs" / "nidaq-bench.toml").read_text()

# A stand-in for nidaqmx: counter tasks that count up, 1000 samples a read, until the
# device is removed at the fourth block.
FAKE_NIDAQMX = '''
from . import constants, errors
_reads = [0]
class _Any:
    def __getattr__(self, name):
        return lambda *a, **k: None
class _Stream:
    avail_samp_per_chan = 1000
class Task:
    def __init__(self, name=""):
        self.ci_channels = self.co_channels = self.timing = _Any()
        self.in_stream = _Stream()
        self.k = 0
    def start(self):
        pass
    def close(self):
        pass
    def read(self, number_of_samples_per_channel=None, timeout=None):
        _reads[0] += 1
        if _reads[0] > 3:
            raise errors.DaqReadError("Device has been removed from the system.", -88705)
        n = number_of_samples_per_channel
        self.k += n
        return [float(self.k - n + i) for i in range(n)]
'''
FAKE_ERRORS = '''
class DaqError(Exception):
    def __init__(self, message, error_code):
        super().__init__(message)
        self.error_code = error_code
class DaqReadError(DaqError):
    pass
'''
FAKE_CONSTANTS = '''
class _Names:
    def __getattr__(self, name):
        return name
EncoderType = AngleUnits = AcquisitionType = _Names()
'''


def test_nidaq_removed_mid_run_is_exit_3_and_keeps_every_block(tmp_path: Path) -> None:
    from conftest import run

    d = tmp_path / "shadow" / "nidaqmx"
    d.mkdir(parents=True)
    for name, text in (("__init__.py", FAKE_NIDAQMX), ("errors.py", FAKE_ERRORS),
                       ("constants.py", FAKE_CONSTANTS)):
        (d / name).write_text(text)
    rig = tmp_path / "nidaq.toml"
    rig.write_text(NIDAQ_RIG)
    out = tmp_path / "run.parquet"
    r = run(f"enc acquire --rig {rig} --mode continuous -o {out}",
            env={"PYTHONPATH": str(tmp_path / "shadow")})
    line = one_error_line(r, 3)
    assert "NI-DAQmx error -88705 while reading the counters: Device has been removed" in line
    counts = pq.read_table(out).column("H1").to_numpy()
    assert np.array_equal(counts, np.arange(3000))  # three blocks of 1000, as read


def test_signal_while_a_position_is_packed_keeps_it(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A SIGINT after the readings of position 3 are taken, while they become a batch:
    positions 0..3 are kept, whole."""
    from enctools.hw import acquire

    pack = acquire._rows_batch
    calls = []

    def interrupted(rows: Any, schema: Any) -> Any:
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt  # as SIGINT's handler raises it, mid-conversion
        return pack(rows, schema)

    monkeypatch.setattr(acquire, "_rows_batch", interrupted)
    out = tmp_path / "steps.parquet"
    r = run_in_process(f"enc acquire --rig ciomp-23bit --mode steps -o {out}")
    assert one_error_line(r, 130).endswith("error: interrupted")
    steps = pq.read_table(out).column("step").to_pylist()
    k = len(steps) // 4  # the rig's readings per position
    assert k > 0 and steps == [p for p in range(4) for _ in range(k)]
