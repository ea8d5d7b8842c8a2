"""Hardware I/O: one small device interface (:mod:`enctools.hw.base`) and its backends.

- ``sim``: the virtual rig (:mod:`enctools.hw.sim`), deterministic by seed;
- ``replay``: re-stream a recorded readings file (:mod:`enctools.hw.replay`).

:func:`open_session` picks the backend named in the rig (``[backend] kind``).
"""

from __future__ import annotations

from ..errors import UsageError
from ..rig import Rig
from .base import Session

BACKENDS = ("sim",)


def open_session(rig: Rig, seed: int | None = None, signals: bool = False) -> Session:
    """Open the devices of a rig with the backend its ``[backend]`` table names."""
    kind = rig.backend.get("kind", "sim")
    if kind == "sim":
        from .sim import VirtualRig

        return VirtualRig(rig, seed=seed, signals=signals)
    msg = (f"rig {rig.name}: backend {kind!r} is not available in this enctools "
           f"(backends: {', '.join(BACKENDS)})")
    raise UsageError(msg)
