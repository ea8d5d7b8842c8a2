"""The ``visa`` backend: SCPI instruments through PyVISA (GPIB, USB-TMC, LAN, VISA serial).

An instrument is a table ``[backend.instrument.NAME]`` with a VISA ``resource``; the
roles (head counters, probes, autocollimator, motion) and what to say to each are
described in :mod:`enctools.hw.dialogue` and enc-rig(5). ``[backend] visa_library``
chooses the PyVISA backend: empty or ``"@ivi"`` for the system VISA (NI-VISA, Keysight),
``"@py"`` for pyvisa-py, ``"@sim"`` or ``"FILE.yaml@sim"`` for pyvisa-sim (the file
relative to the rig file and inside its folder). Nothing else: never a library path.

Example: a counter/interpolation box reading both heads in one query and a motion
controller, on the LAN::

    [backend]
    kind = "visa"
    timeout_s = 0.5          # per attempt
    retries = 2              # after the first attempt

    [backend.instrument.box]
    resource = "TCPIP0::192.168.0.21::inst0::INSTR"
    init = ["*CLS", "CONF:COUN F1,F2"]
    error_query = "SYST:ERR?"
    idn = "*IDN?"

    [backend.instrument.table]
    resource = "TCPIP0::192.168.0.22::5025::SOCKET"
    read_termination = "\\n"
    ack = "OK"

    [backend.counter]
    instrument = "box"
    read = "FETC:COUN? F1,F2"
    heads = ["F1", "F2"]

    [motion.backend]
    instrument = "table"
    move = "MOVE:ABS {deg:.6f}"
    in_position = "MOVE:DONE?"
    in_position_reply = "1"
    rotate = "JOG {rpm:.4f}"
    stop = "STOP"

Missing pieces give one line: PyVISA not installed is exit 2 (install
``enctools[visa]``); no VISA library, an unknown or unplugged resource is exit 3.
"""

from __future__ import annotations

import logging
import warnings
from pathlib import Path
from typing import Any

from enctools.data.rig import Rig
from enctools.errors import DataError, DeviceError
from enctools.hw import retry

log = logging.getLogger("enctools.hw")

_MANAGERS: dict[str, Any] = {}


def _pyvisa() -> Any:
    try:
        import pyvisa
    except ImportError:
        from enctools.hw.backends import get

        raise get("visa").missing() from None
    return pyvisa


# The PyVISA backends a rig file may name; anything else could be a shared library path.
LIBRARIES = ("", "@ivi", "@py", "@sim")
SIM_SUFFIXES = (".yaml", ".yml")


def library_spec(rig: Rig) -> str:
    """The PyVISA library string of a rig, with a pyvisa-sim file made absolute.

    Only PyVISA's own backends are allowed (:data:`LIBRARIES`, or ``FILE.yaml@sim``
    with the file inside the rig file's folder): a rig file never names a shared
    library to load. Checked without importing pyvisa; DataError with one line.
    """
    spec = rig.backend.get("visa_library", "")
    if spec in LIBRARIES:
        return str(spec)
    rule = ('allowed: "" (the system VISA), "@ivi", "@py" (pyvisa-py), "@sim" or '
            '"FILE.yaml@sim" (a pyvisa-sim file in the rig file\'s folder), never a '
            "library path")
    head = f"rig file {rig.source}: backend.visa_library = {spec!r}"
    if not isinstance(spec, str) or not spec.endswith("@sim"):
        msg = f"{head}: not a PyVISA backend; {rule}"
        raise DataError(msg)
    return f"{_sim_file(spec[:-4], rig, head, rule)}@sim"


def _sim_file(name: str, rig: Rig, head: str, rule: str) -> Path:
    """The pyvisa-sim file ``name``: inside the rig file's folder, .yaml/.yml, a file."""
    from enctools.hw.config import rig_dir
    base = rig_dir(rig).resolve()
    path = (base / name).resolve()
    if not path.is_relative_to(base):
        msg = f"{head}: the simulation file is outside the rig file's folder {base}; {rule}"
        raise DataError(msg)
    if path.suffix.lower() not in SIM_SUFFIXES:
        msg = f"{head}: the simulation file must end in .yaml or .yml; {rule}"
        raise DataError(msg)
    if not path.is_file():
        msg = f"{head}: no such file {path}"
        raise DataError(msg)
    return path


def resource_manager(rig: Rig) -> Any:
    """One PyVISA ResourceManager per library string (cached for the process)."""
    spec = library_spec(rig)  # checked before pyvisa is imported
    pyvisa = _pyvisa()
    if spec not in _MANAGERS:
        try:
            _MANAGERS[spec] = pyvisa.ResourceManager(spec) if spec else pyvisa.ResourceManager()
        except (OSError, ValueError, pyvisa.errors.Error) as exc:
            what = spec or "the system VISA library"
            msg = (f"cannot load {what}: {retry_text(exc)} (install NI-VISA or pyvisa-py, "
                   "or set [backend] visa_library)")
            raise DeviceError(msg) from None
        except Exception as exc:  # noqa: BLE001 - pyvisa-sim raises plain exceptions on bad yaml
            msg = f"cannot load the VISA library {spec!r}: {type(exc).__name__}: {retry_text(exc)}"
            raise DeviceError(msg) from None
    return _MANAGERS[spec]


def retry_text(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text[:200] or type(exc).__name__


def _unescape(s: str) -> str:
    return s.replace("\\r", "\r").replace("\\n", "\n")


class VisaPort:
    """A message-based VISA resource as a line port."""

    def __init__(self, name: str, resource: Any, address: str, timeout_s: float) -> None:
        self.name = name
        self.resource = resource
        self.address = address
        self.timeout_s = timeout_s
        self._errors = _pyvisa().errors

    def write(self, text: str) -> None:
        log.debug("%s <- %r", self.name, text)
        try:
            self.resource.write(text)
        except Exception as exc:  # noqa: BLE001 - VISA, session and transport errors alike
            msg = (f"instrument {self.name} ({self.address}): cannot send {text!r}: "
                   f"{self._why(exc)}")
            raise DeviceError(msg) from None

    def read_line(self) -> str:
        errors = self._errors
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                reply = self.resource.read()
        except errors.VisaIOError as exc:
            if exc.error_code == errors.StatusCode.error_timeout:
                raise retry.Timeout() from None
            msg = f"instrument {self.name} ({self.address}): read failed: {exc.description}"
            raise DeviceError(msg) from None
        except UnicodeDecodeError as exc:
            msg = (f"instrument {self.name} ({self.address}): garbled reply "
                   f"{exc.object[:40]!r}: not text")
            raise DeviceError(msg) from None
        except Exception as exc:  # noqa: BLE001 - a closed session, a reset connection, ...
            msg = f"instrument {self.name} ({self.address}): read failed: {self._why(exc)}"
            raise DeviceError(msg) from None
        if any("termination" in str(w.message) for w in caught):
            # The message ended (END) without the read termination: an incomplete line.
            raise retry.Timeout(reply.encode(errors="replace"))
        log.debug("%s -> %r", self.name, reply)
        return reply

    def _why(self, exc: BaseException) -> str:
        """What a failure says: a VISA status's description, else the exception's type
        and text (a transport's ConnectionResetError, pyvisa's InvalidSession)."""
        if isinstance(exc, self._errors.VisaIOError):
            return str(exc.description)
        return f"{type(exc).__name__}: {retry_text(exc)}"

    def clear(self) -> None:
        try:
            self.resource.clear()
        except Exception as exc:  # noqa: BLE001 - not every interface or simulator clears
            log.debug("%s: clear: %s", self.name, exc)

    def close(self) -> None:
        try:
            self.resource.close()
        except Exception as exc:  # noqa: BLE001 - closing must not hide the first error
            log.debug("%s: close: %s", self.name, exc)

    def hint(self) -> str:
        return "is it on, connected, and does it understand this command?"


def open_port(name: str, cfg: dict[str, Any], rig: Rig, policy: retry.Policy) -> VisaPort:
    """Open ``[backend.instrument.NAME]`` as a VISA resource."""
    where = f"backend.instrument.{name}"
    address = cfg.get("resource")
    if not isinstance(address, str) or not address:
        msg = f"rig file {rig.source}: [{where}] needs the key 'resource' (a VISA resource name)"
        raise DataError(msg)
    rm = resource_manager(rig)
    pyvisa = _pyvisa()
    kw: dict[str, Any] = {"timeout": round(policy.timeout_s * 1000),
                          "read_termination": _unescape(str(cfg.get("read_termination", "\n"))),
                          "write_termination": _unescape(str(cfg.get("write_termination", "\n")))}
    if "encoding" in cfg:
        kw["encoding"] = str(cfg["encoding"])
    if "baudrate" in cfg:
        kw["baud_rate"] = int(cfg["baudrate"])
    if library_spec(rig).endswith("@sim") and address not in rm.list_resources():
        # pyvisa-sim opens any name; a real VISA library refuses unknown ones.
        msg = (f"instrument {name}: cannot open VISA resource {address!r}: not in the "
               "simulation file (unplugged, switched off, or a wrong resource name?)")
        raise DeviceError(msg)
    try:
        res = rm.open_resource(address, **kw)
    except pyvisa.errors.VisaIOError as exc:
        msg = (f"instrument {name}: cannot open VISA resource {address!r}: {exc.description} "
               "(unplugged, switched off, or a wrong resource name?)")
        raise DeviceError(msg) from None
    except (ValueError, AttributeError, TypeError) as exc:
        msg = f"instrument {name}: cannot open VISA resource {address!r}: {retry_text(exc)}"
        raise DeviceError(msg) from None
    return VisaPort(name, res, address, policy.timeout_s)
