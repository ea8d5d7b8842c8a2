"""The ``serial`` backend: line-oriented ASCII instruments on a serial line (pyserial).

Autocollimators, probe controllers and simple motion or counter boxes that answer a
query with one line of text (or send a line by themselves at their own rate). An
instrument is a table ``[backend.instrument.NAME]`` with ``kind = "serial"``, a ``port``
and the line settings; the roles and their dialogue are described in
:mod:`enctools.hw.dialogue` and enc-rig(5).

Example: an autocollimator answering ``R`` with ``+12.34,-0.56`` (X, Y in arcsec)::

    [backend.instrument.ac]
    kind = "serial"
    port = "/dev/ttyUSB0"      # or /dev/serial/by-id/... (stable across reboots)
    baudrate = 9600
    bytesize = 8
    parity = "N"               # N, E, O, M, S
    stopbits = 1
    write_termination = "\\r"
    read_termination = "\\r\\n"
    timeout_s = 0.5

    [autocollimator.backend]
    instrument = "ac"
    read = "R"
    field = 0                  # X

Bytes that are not ASCII (the usual sign of a wrong baud rate or framing) are
reported with the raw bytes and the port's settings. pyserial not installed is exit 2
(install ``enctools[serial]``); a missing or busy port is exit 3.
"""

from __future__ import annotations

import logging
import os
from typing import Any

from enctools.data.rig import Rig
from enctools.errors import DataError, DeviceError
from enctools.hw import retry

log = logging.getLogger("enctools.hw")

PARITIES = ("N", "E", "O", "M", "S")


def _pyserial() -> Any:
    try:
        import serial
    except ImportError:
        from enctools.hw.backends import get

        raise get("serial").missing() from None
    return serial


def _unescape(s: str) -> str:
    return s.replace("\\r", "\r").replace("\\n", "\n")


class SerialPort:
    """A serial line as a line port (ASCII, one reply line per query)."""

    def __init__(self, name: str, ser: Any, address: str, timeout_s: float, write_term: str,
                 read_term: str, encoding: str, settings: str) -> None:
        self.name = name
        self.ser = ser
        self.address = address
        self.timeout_s = timeout_s
        self.write_term = write_term
        self.read_term = read_term.encode(encoding)
        self.encoding = encoding
        self.settings = settings
        self._exc = _pyserial().SerialException

    def write(self, text: str) -> None:
        log.debug("%s <- %r", self.name, text)
        try:
            self.ser.write((text + self.write_term).encode(self.encoding))
            self.ser.flush()
        except Exception as exc:  # noqa: BLE001 - SerialException, OSError, an unencodable text
            msg = f"{retry.where(self)}: cannot send {text!r}: {retry_text(exc)} (unplugged?)"
            raise DeviceError(msg) from None

    def read_line(self) -> str:
        try:
            raw = self.ser.read_until(self.read_term)
        except Exception as exc:  # noqa: BLE001 - SerialException, OSError, a closed port
            msg = f"{retry.where(self)}: read failed: {retry_text(exc)} (unplugged?)"
            raise DeviceError(msg) from None
        if not raw.endswith(self.read_term):
            raise retry.Timeout(raw)
        log.debug("%s -> %r", self.name, raw)
        try:
            text = raw[: -len(self.read_term)].decode(self.encoding).rstrip("\r\n")
        except UnicodeDecodeError:
            text = ""
            bad = True
        else:
            bad = any(ord(c) < 32 and c not in "\t" for c in text)
        if bad:
            msg = (f"{retry.where(self)}: garbled reply {raw[:40]!r}: not {self.encoding} "
                   f"text (wrong baud rate or framing? the port is set to {self.settings})")
            raise DeviceError(msg)
        return text

    def clear(self) -> None:
        try:
            self.ser.reset_input_buffer()
        except (self._exc, OSError) as exc:
            log.debug("%s: clear: %s", self.name, exc)

    def close(self) -> None:
        try:
            self.ser.close()
        except (self._exc, OSError) as exc:
            log.debug("%s: close: %s", self.name, exc)

    def hint(self) -> str:
        return f"is it on and connected, is the line set right ({self.settings})?"


def retry_text(exc: BaseException) -> str:
    """An exception as a short clause: its text, with its type when the text is bare."""
    text = " ".join(str(exc).split())[:200]
    if not text:
        return type(exc).__name__
    known = isinstance(exc, (_pyserial().SerialException, OSError))
    return text if known else f"{type(exc).__name__}: {text}"


def open_port(name: str, cfg: dict[str, Any], rig: Rig, policy: retry.Policy) -> SerialPort:
    """Open ``[backend.instrument.NAME]`` as a serial line."""
    where = f"backend.instrument.{name}"
    serial = _pyserial()
    address = cfg.get("port")
    if not isinstance(address, str) or not address:
        msg = f"rig file {rig.source}: [{where}] needs the key 'port' (e.g. /dev/ttyUSB0)"
        raise DataError(msg)
    baud = cfg.get("baudrate", 9600)
    bytesize = cfg.get("bytesize", 8)
    parity = str(cfg.get("parity", "N")).upper()[:1]
    stopbits = cfg.get("stopbits", 1)
    if not isinstance(baud, int) or baud <= 0:
        msg = f"rig file {rig.source}: {where}.baudrate must be a positive integer, not {baud!r}"
        raise DataError(msg)
    if bytesize not in (5, 6, 7, 8) or parity not in PARITIES or stopbits not in (1, 1.5, 2):
        msg = (f"rig file {rig.source}: [{where}] bytesize must be 5..8, parity one of "
               f"{'/'.join(PARITIES)}, stopbits 1, 1.5 or 2")
        raise DataError(msg)
    settings = f"{baud} {bytesize}{parity}{stopbits:g}"
    encoding = str(cfg.get("encoding", "ascii"))
    try:
        ser = serial.Serial(address, baudrate=baud, bytesize=bytesize, parity=parity,
                            stopbits=stopbits, timeout=policy.timeout_s,
                            write_timeout=policy.timeout_s, rtscts=bool(cfg.get("rtscts", False)),
                            xonxoff=bool(cfg.get("xonxoff", False)))
    except (serial.SerialException, OSError, ValueError) as exc:
        errno_ = getattr(exc, "errno", None)
        why = os.strerror(errno_) if isinstance(errno_, int) else retry_text(exc)
        msg = (f"instrument {name}: cannot open serial port {address}: {why} "
               "(unplugged, busy, or a wrong port name?)")
        raise DeviceError(msg) from None
    port = SerialPort(name, ser, address, policy.timeout_s,
                      _unescape(str(cfg.get("write_termination", "\r\n"))),
                      _unescape(str(cfg.get("read_termination", "\r\n"))), encoding, settings)
    port.clear()
    return port
