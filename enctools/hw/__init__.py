"""Hardware I/O: one small device interface (:mod:`enctools.hw.base`) and its backends.

- ``sim``: the virtual rig (:mod:`enctools.hw.sim`), deterministic by seed;
- ``replay``: re-stream a recorded readings file (:mod:`enctools.hw.replay`);
- ``visa``: SCPI instruments through PyVISA (:mod:`enctools.hw.visa`);
- ``serial``: line-oriented ASCII instruments through pyserial
  (:mod:`enctools.hw.serialline`);
- ``nidaq``: NI-DAQmx angular-encoder counter channels (:mod:`enctools.hw.nidaq`).

The instrument backends share the role dialogues of :mod:`enctools.hw.dialogue` (a rig
may mix them: a VISA counter box, a serial autocollimator, NI counters) and the fault
handling of :mod:`enctools.hw.retry`. :func:`open_session` picks the backend named in
the rig (``[backend] kind``).
"""

from __future__ import annotations

from enctools.data.rig import Rig
from enctools.errors import UsageError
from enctools.hw.base import Session

BACKENDS = ("sim", "visa", "serial", "nidaq")


def open_session(rig: Rig, seed: int | None = None, signals: bool = False,
                 realtime: bool = False, timeout_s: float | None = None,
                 retries: int | None = None) -> Session:
    """Open the devices of a rig with the backend its ``[backend]`` table names.

    ``realtime``: the simulator paces itself to the wall clock (for live pipelines and
    interrupt tests). ``timeout_s``, ``retries``: override the instruments' settings.
    """
    kind = rig.backend.get("kind", "sim")
    if kind == "sim":
        from enctools.hw.sim import VirtualRig

        return VirtualRig(rig, seed=seed, signals=signals,
                          realtime=realtime or bool(rig.backend.get("realtime", False)))
    if kind in ("visa", "serial", "nidaq"):
        if signals:
            msg = f"--signals: the {kind} backend records counter values only, not raw signals"
            raise UsageError(msg)
        from enctools.hw.dialogue import InstrumentSession

        return InstrumentSession(rig, timeout_s=timeout_s, retries=retries)
    msg = (f"rig {rig.name}: backend {kind!r} is not available in this enctools "
           f"(backends: {', '.join(BACKENDS)})")
    raise UsageError(msg)
