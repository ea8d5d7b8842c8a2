"""The ``serial`` backend: line-oriented ASCII instruments on a serial line through pyserial
(:mod:`enctools.hw.serialline`), a line transport of the instrument dialogues."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from enctools.hw.backends import Backend, register

if TYPE_CHECKING:
    from enctools.data.rig import Rig
    from enctools.hw.retry import Policy, Port


def open_port(name: str, cfg: dict[str, Any], rig: Rig, policy: Policy) -> Port:
    """``[backend.instrument.NAME]`` as a serial line."""
    from enctools.hw import serialline

    return serialline.open_port(name, cfg, rig, policy)


BACKEND = register(Backend(
    "serial", "line instruments on a serial line (pyserial)", port=open_port,
    keys=frozenset({"port", "baudrate", "bytesize", "parity", "stopbits", "rtscts", "xonxoff",
                    "read_termination", "write_termination", "encoding"}),
    package="pyserial", extra="serial", rank=2))
