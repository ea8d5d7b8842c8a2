"""Hardware I/O: one small device interface (:mod:`enctools.hw.base`) and its backends.

Each backend is one record of :mod:`enctools.hw.backends`, found by the kind a rig names
(``[backend] kind``): ``sim``, the virtual rig (:mod:`enctools.hw.sim`), deterministic by
seed; ``visa``, SCPI instruments through PyVISA (:mod:`enctools.hw.visa`); ``serial``,
line-oriented ASCII instruments through pyserial (:mod:`enctools.hw.serialline`);
``nidaq``, NI-DAQmx angular-encoder counter channels (:mod:`enctools.hw.nidaq`).
A recorded readings file is re-streamed by :mod:`enctools.hw.replay`.

The instrument backends share the role dialogues of :mod:`enctools.hw.dialogue` (a rig
may mix them: a VISA counter box, a serial autocollimator, NI counters) and the fault
handling of :mod:`enctools.hw.retry`. :func:`open_session` opens a rig with the backend
it names.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from enctools.errors import SettingsError

if TYPE_CHECKING:
    from enctools.data.rig import Rig
    from enctools.hw.base import Session


def open_session(rig: Rig, seed: int | None = None, signals: bool = False,
                 realtime: bool = False, timeout_s: float | None = None,
                 retries: int | None = None) -> Session:
    """Open the devices of a rig with the backend its ``[backend]`` table names.

    ``seed``: the simulator's noise seed (None: the rig's); ``signals``: record raw
    signals too (a backend that cannot refuses them); ``realtime``: the simulator paces
    itself to the wall clock (live pipelines, interrupt tests); ``timeout_s`` [s],
    ``retries``: override the instruments' settings. The kind unknown is a DataError.
    """
    from enctools.hw import backends

    backend = backends.of_rig(rig)
    if signals and not backend.signals:
        msg = (f"`signals`: the {backend.kind} backend records counter values only, "
               "not raw signals")
        raise SettingsError(msg)
    opening = backends.Opening(seed, signals, realtime, timeout_s, retries)
    if backend.session is not None:
        return backend.session(rig, opening)
    from enctools.hw.dialogue import InstrumentSession

    return InstrumentSession(rig, timeout_s=timeout_s, retries=retries)
