"""The serial backend through real pseudo-terminal pairs, the instruments played by an emulator.

The emulator (a thread in the test process) holds the master side of two ptys: a motion
controller that also reads the encoder's two heads (``MA <deg>`` / ``MS?`` / ``CNT?`` /
``ERR?``) and an autocollimator that sends ``X,Y`` [arcsec] lines by itself. The table
closes its loop on the heads' average, so the encoder's graduation error shows up in
the autocollimator: ``enc acquire | enc points`` must recover it (the truth below).
``enc acquire`` runs as a real subprocess opening the pty slaves by name.

Line faults are played on purpose: the host at the wrong baud rate (the emulator reads
the line settings the host set on the pty and answers with framing garbage), an
instrument replying with text that is not a number, one that falls silent, a port that
does not exist.
"""

from __future__ import annotations

import math
import os
import select
import termios
import threading
import time
import tty
from pathlib import Path

import numpy as np
import pytest
from conftest import one_error_line, run

pytest.importorskip("serial")

CPR = 4096 * 2048  # counts per revolution of the emulated encoder
BITS = 23
ARCSEC = math.pi / 648000.0
FACES = 24
STEP = 2 * math.pi / FACES
HEADS = (0.0, math.pi)  # head angles [rad]


def graduation(phi: np.ndarray | float) -> np.ndarray | float:
    """The emulated scale's graduation error [arcsec] at scale angle phi [rad]."""
    return 1.5 * np.sin(2 * phi + 0.3) + 0.8 * np.sin(3 * phi - 1.0) + 0.4 * np.cos(5 * phi)


def head_mean_error(theta: float) -> float:
    """Error [arcsec] of the two-head average at table angle theta: odd harmonics cancel."""
    return float(np.mean([graduation(theta + a) for a in HEADS]))


class Emulator:
    """A table controller with counter inputs and a streaming autocollimator, on two ptys."""

    def __init__(self, ctl_baud: int = 115200, ac_baud: int = 9600, ac_period: float = 0.01,
                 ac_silent_after_moves: int | None = None, ctl_garbage: bool = False,
                 ctl_silent_after_counts: int | None = None) -> None:
        self.ctl_m, self.ctl_s = os.openpty()
        self.ac_m, self.ac_s = os.openpty()
        for fd in (self.ctl_s, self.ac_s):
            tty.setraw(fd)
        self.ctl_path = os.ttyname(self.ctl_s)
        self.ac_path = os.ttyname(self.ac_s)
        self.bauds = {self.ctl_m: getattr(termios, f"B{ctl_baud}"),
                      self.ac_m: getattr(termios, f"B{ac_baud}")}
        self.ac_period = ac_period
        self.ac_silent_after_moves = ac_silent_after_moves
        self.moves = 0
        self.ctl_silent_after_counts = ctl_silent_after_counts
        self.counts_read = 0
        self.ctl_garbage = ctl_garbage
        self.theta = 0.0  # true table angle [rad]
        self.moving = 0
        self.ac_lines = 0
        self.commands: list[str] = []
        self._buf = b""
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)

    def __enter__(self) -> Emulator:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(2)
        for fd in (self.ctl_m, self.ctl_s, self.ac_m, self.ac_s):
            os.close(fd)

    def _baud_ok(self, master: int) -> bool:
        attrs = termios.tcgetattr(master)  # a pty master reports the slave's settings
        return attrs[5] == self.bauds[master]

    def _send(self, master: int, text: str) -> None:
        if not self._baud_ok(master):
            os.write(master, bytes([0xE6, 0x80, 0x9F, 0xF8, 0x00, 0xFE]))  # framing garbage
            return
        os.write(master, (text + "\r\n").encode())

    def _counts(self) -> str:
        vals = []
        for a in HEADS:
            reading = self.theta + graduation(self.theta + a) * ARCSEC
            vals.append(round(reading * CPR / (2 * math.pi)) % (1 << BITS))
        return " ".join(str(v) for v in vals)

    def _answer(self, line: str) -> None:
        self.commands.append(line)
        if (self.ctl_silent_after_counts is not None
                and self.counts_read >= self.ctl_silent_after_counts):
            return  # the controller has hung: no reply to anything
        if self.ctl_garbage and line == "CNT?":
            self._send(self.ctl_m, "E-07 OVERFLOW")
            return
        if line.startswith("MA "):
            target = float(line[3:]) * math.pi / 180.0
            theta = target
            for _ in range(4):  # the loop closes on the heads' average
                theta = target - head_mean_error(theta) * ARCSEC
            self.theta = theta
            self.moving = 2  # MS? answers 1 twice, then 0
            self.moves += 1
            self._send(self.ctl_m, "OK")
        elif line == "MS?":
            self._send(self.ctl_m, "1" if self.moving else "0")
            self.moving = max(0, self.moving - 1)
        elif line == "CNT?":
            self.counts_read += 1
            self._send(self.ctl_m, self._counts())
        elif line == "ERR?":
            self._send(self.ctl_m, "0")
        elif line == "ST" or line.startswith("JOG "):
            self._send(self.ctl_m, "OK")
        else:
            self._send(self.ctl_m, "?")

    def _ac_line(self) -> str:
        j = round(self.theta / STEP)
        x = (self.theta - j * STEP) / ARCSEC
        return f"{x:+09.3f},{-0.25:+09.3f}"

    def _serve(self) -> None:
        next_ac = time.monotonic()
        while not self._stop.is_set():
            r, _, _ = select.select([self.ctl_m], [], [], 0.002)
            if r:
                try:
                    self._buf += os.read(self.ctl_m, 4096)
                except OSError:
                    return
                while True:
                    parts = self._buf.replace(b"\n", b"\r").split(b"\r", 1)
                    if len(parts) < 2:
                        break
                    line, self._buf = parts[0].decode(errors="replace").strip(), parts[1]
                    if line:
                        self._answer(line)
            now = time.monotonic()
            if now >= next_ac:
                next_ac = now + self.ac_period
                silent = (self.ac_silent_after_moves is not None
                          and self.moves >= self.ac_silent_after_moves)
                if not silent:
                    try:
                        self._send(self.ac_m, self._ac_line())
                    except OSError:
                        pass
                    self.ac_lines += 1


def rig_text(emu: Emulator, host_ac_baud: int = 9600, ac_read: str | None = None,
             timeout_s: float = 0.3, retries: int = 1) -> str:
    read = f'read = "{ac_read}"\n' if ac_read else ""
    return f"""
format = 1
name = "serial-polygon"
description = "two-head encoder on a table controller, streaming autocollimator (pty emulator)"

[backend]
kind = "serial"
timeout_s = {timeout_s}
retries = {retries}

[backend.instrument.ctl]
port = "{emu.ctl_path}"
baudrate = 115200
write_termination = "\\r"
read_termination = "\\r\\n"
ack = "OK"
error_query = "ERR?"
no_error = "0"

[backend.instrument.ac]
port = "{emu.ac_path}"
baudrate = {host_ac_baud}
read_termination = "\\r\\n"

[backend.counter]
instrument = "ctl"
read = "CNT?"
heads = ["E1", "E2"]

[motion]
feedback = "E"

[motion.backend]
instrument = "ctl"
move = "MA {{deg:.7f}}"
in_position = "MS?"
in_position_reply = "0"
poll_s = 0.005
stop = "ST"
rotate = "JOG {{rpm:.3f}}"

[polygon]
faces = 24

[autocollimator]
name = "AC"

[autocollimator.backend]
instrument = "ac"
{read}field = 0

[acquire]
mode = "steps"

[acquire.steps]
count = 24
settle_s = 0.0
readings = 2
overshoot_deg = 0.5

[[encoder]]
name = "E"
periods_per_rev = 4096
interpolation = 2048
diameter_mm = 200.0
counter_bits = 23

[[encoder.head]]
name = "E1"
angle_deg = 0.0

[[encoder.head]]
name = "E2"
angle_deg = 180.0
"""


def write_rig(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "serial-polygon.toml"
    p.write_text(text)
    return p


@pytest.mark.slow
def test_polygon_run_gives_points_of_the_graduation_error(tmp_path: Path) -> None:
    """24-position polygon run through ptys -> enc points recovers the head-average error."""
    with Emulator() as emu:
        rig = write_rig(tmp_path, rig_text(emu))
        raw = tmp_path / "steps.parquet"
        pts = tmp_path / "points.parquet"
        r = run(f"enc acquire --rig {rig} -o {raw} && enc points {raw} -o {pts}")
        assert r.returncode == 0, r.stderr.decode()
        assert any(c.startswith("MA ") for c in emu.commands)
    import pyarrow.parquet as pq

    t = pq.read_table(raw)
    assert t.num_rows == 48  # 24 positions x 2 readings
    assert set(t.column("step").to_pylist()) == set(range(24))
    assert not np.isnan(t.column("AC").to_numpy()).any()
    p = pq.read_table(pts)
    assert p.schema.metadata[b"kind"] == b"points"
    assert p.schema.field("position").metadata[b"unit"] == b"rad"
    pos = np.degrees(p.column("position").to_numpy())
    dev = p.column("deviation").to_numpy()
    assert len(pos) == 24
    truth = np.array([head_mean_error(np.deg2rad(x)) for x in pos])
    # Deviations are relative to the first position; compare without the mean.
    err = (dev - dev.mean()) - (truth - truth.mean())
    # Tolerance: 23-bit counts are 0.155" apart; rounding of two heads and of the
    # AC's 3 decimals stays within 0.12"; the truth spans +/-1.9".
    assert np.ptp(truth) > 2.5
    assert np.max(np.abs(err)) < 0.12, err


@pytest.mark.slow
def test_query_autocollimator_and_tee_to_pipe(tmp_path: Path) -> None:
    """--tee keeps a Parquet copy while the stream goes down a pipe."""
    with Emulator() as emu:
        text = rig_text(emu).replace("count = 24", "count = 6")
        rig = write_rig(tmp_path, text)
        tee = tmp_path / "tee.parquet"
        r = run(f"enc acquire --rig {rig} --tee {tee} | enc info")
        assert r.returncode == 0, r.stderr.decode()
        assert b"12 rows" in r.stdout
    r2 = run(f"enc info {tee}")
    assert r2.returncode == 0 and b"12 rows" in r2.stdout, r2.stderr.decode()


@pytest.mark.slow
def test_wrong_baud_is_one_line_exit_3(tmp_path: Path) -> None:
    with Emulator(ac_baud=19200) as emu:  # the instrument is at 19200, the rig says 9600
        rig = write_rig(tmp_path, rig_text(emu, host_ac_baud=9600))
        out = tmp_path / "x.parquet"
        r = run(f"enc acquire --rig {rig} -o {out}")
    line = one_error_line(r, 3)
    assert "instrument ac" in line and "9600 8N1" in line, line
    assert "\\x" in line  # the raw bytes are quoted
    # The file holds what was read before the fault: nothing here (first position),
    # but it is a valid, empty stream.
    r2 = run(f"enc info {out}")
    assert r2.returncode == 0, r2.stderr.decode()


def test_garbage_reply_quotes_the_raw_text(tmp_path: Path) -> None:
    with Emulator(ctl_garbage=True) as emu:
        rig = write_rig(tmp_path, rig_text(emu))
        r = run(f"enc acquire --rig {rig} -o {tmp_path / 'x.parquet'}")
    line = one_error_line(r, 3)
    assert "malformed reply 'E-07 OVERFLOW' to 'CNT?'" in line, line


@pytest.mark.slow
def test_silent_instrument_mid_run_keeps_batches(tmp_path: Path) -> None:
    """The autocollimator stops sending at position 10: exit 3, the file keeps 0..9."""
    with Emulator(ac_silent_after_moves=21) as emu:  # 2 moves per position (overshoot)
        rig = write_rig(tmp_path, rig_text(emu, timeout_s=0.15, retries=2))
        out = tmp_path / "x.parquet"
        r = run(f"enc acquire --rig {rig} -o {out}")
    line = one_error_line(r, 3)
    assert "instrument ac" in line and "after 3 attempts" in line, line
    assert r.stderr.decode().count("attempt") >= 3  # each attempt logged
    import pyarrow.parquet as pq

    t = pq.read_table(out)
    assert t.column("step").to_pylist() == [k for k in range(10) for _ in range(2)]


def test_nonexistent_port_is_one_line_exit_3(tmp_path: Path) -> None:
    with Emulator() as emu:
        text = rig_text(emu).replace(emu.ac_path, "/dev/ttyNOSUCH7")
        rig = write_rig(tmp_path, text)
        out = tmp_path / "x.parquet"
        r = run(f"enc acquire --rig {rig} -o {out}")
    line = one_error_line(r, 3)
    assert "/dev/ttyNOSUCH7" in line and "cannot open serial port" in line, line
    assert not out.exists()


def test_unknown_key_in_instrument_table_is_exit_2(tmp_path: Path) -> None:
    with Emulator() as emu:
        text = rig_text(emu).replace("baudrate = 115200", "baud = 115200")
        rig = write_rig(tmp_path, text)
        r = run(f"enc acquire --rig {rig} -o {tmp_path / 'x.parquet'}")
    line = one_error_line(r, 2)
    assert "unknown key 'baud'" in line and "baudrate" in line, line


@pytest.mark.slow
def test_counter_hangs_in_continuous_run(tmp_path: Path) -> None:
    """The controller stops answering after 40 samples of a 100-sample run: exit 3,
    the error names the counter query (not the failed stop that follows), the file
    keeps every sample read before, those of the block in progress included."""
    with Emulator(ctl_silent_after_counts=40) as emu:
        rig = write_rig(tmp_path, rig_text(emu, timeout_s=0.1, retries=1))
        out = tmp_path / "c.parquet"
        r = run(f"enc acquire --rig {rig} --mode continuous --speed 60 --revolutions 1 "
                f"--interval 0.01 -o {out}")
    line = one_error_line(r, 3)
    # the counter query is named; on a loaded machine a 0.1 s write to the pseudo-terminal
    # can itself time out first ("cannot send 'CNT?'"), which is the same fault
    assert "no answer to 'CNT?' after 2 attempts" in line or "cannot send 'CNT?'" in line, line
    assert "could not stop the table" in r.stderr.decode()
    import pyarrow.parquet as pq

    t = pq.read_table(out)
    # Every answer received, the block in progress included (a late answer on a loaded
    # machine is a timeout, retried: then fewer than the 40 the emulator sent).
    assert 0 < t.num_rows <= 40
    ts = t.column("t").to_numpy()
    assert np.all(np.diff(ts) > 0)
