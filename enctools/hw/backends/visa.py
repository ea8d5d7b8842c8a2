"""The ``visa`` backend: SCPI instruments through PyVISA (:mod:`enctools.hw.visa`), a line
transport of the instrument dialogues (:mod:`enctools.hw.dialogue`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from enctools.hw.backends import Backend, register

if TYPE_CHECKING:
    from enctools.data.rig import Rig
    from enctools.hw.retry import Policy, Port


def open_port(name: str, cfg: dict[str, Any], rig: Rig, policy: Policy) -> Port:
    """``[backend.instrument.NAME]`` as a VISA resource."""
    from enctools.hw import visa

    return visa.open_port(name, cfg, rig, policy)


def check(rig: Rig) -> None:
    """``[backend] visa_library``: PyVISA's own backends only, checked before pyvisa is
    imported."""
    from enctools.hw.visa import library_spec

    library_spec(rig)


BACKEND = register(Backend(
    "visa", "SCPI instruments through PyVISA", port=open_port,
    keys=frozenset({"resource", "read_termination", "write_termination", "encoding",
                    "baudrate"}),
    backend_keys=frozenset({"visa_library"}), check=check, package="pyvisa", extra="visa",
    needs=" (and a VISA library, or pyvisa-py)", rank=1))
