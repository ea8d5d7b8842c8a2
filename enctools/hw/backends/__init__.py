"""The instrument backends, by kind: one :class:`Backend` record each.

A rig names its backend in ``[backend] kind``; a line instrument its transport in
``[backend.instrument.NAME] kind``; the head counters theirs in ``[backend.counter]
kind``. Each kind is one record: how a session, a line port or the counters are opened
from a rig, whether it records raw signals, the rig keys it reads and their check, the
extra to install for it. :func:`enctools.hw.open_session`, the instrument dialogues
(:mod:`enctools.hw.dialogue`) and the command line read the records, never a list of
names.

The records of enctools are the modules of this package, each calling :func:`register`;
they are found and imported on first use and stay light (an instrument library is
imported only when a session opens, so a command's help imports none). A backend of one's own
is one more module here, or one :func:`register` call before the session is opened.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from enctools.errors import DataError, SettingsError
from enctools.registry import Registry

if TYPE_CHECKING:
    from enctools.data.rig import Rig
    from enctools.hw.base import Clock, Counter, Session
    from enctools.hw.retry import Policy, Port

__all__ = ["Backend", "Opening", "default_port", "find", "get", "kinds", "of_rig", "records",
           "register", "unregister", "used_by"]


@dataclass(frozen=True)
class Opening:
    """How a session is opened: the simulator's noise ``seed``, raw ``signals``, wall-clock
    pace (``realtime``); the instruments' reply timeout ``timeout_s`` [s] and ``retries``
    after a timeout (None: the rig's)."""

    seed: int | None = None
    signals: bool = False
    realtime: bool = False
    timeout_s: float | None = None
    retries: int | None = None


#: a whole rig opened as one session (the simulator)
SessionOpener = Callable[["Rig", Opening], "Session"]
#: a line instrument ``[backend.instrument.NAME]`` opened as a port: name, its table, the
#: rig, the retry policy
PortOpener = Callable[[str, dict[str, Any], "Rig", "Policy"], "Port"]
#: the head counters ``[backend.counter]``: the rig, the table, the session's clock, its
#: start time [s]
CounterOpener = Callable[["Rig", dict[str, Any], "Clock", float], "Counter"]


@dataclass(frozen=True)
class Backend:
    """One backend kind and what the library needs to know of it.

    A record opens a whole rig (``session``), or serves a role of a rig of instruments:
    a line transport (``port``: VISA, a serial line) or the head counters (``counter``:
    NI-DAQmx); a rig whose ``[backend] kind`` has no ``session`` is a rig of instruments
    (:class:`enctools.hw.dialogue.InstrumentSession`).
    """

    kind: str
    #: what it drives, in a few words (help texts, enc-rig(5))
    about: str
    session: SessionOpener | None = None
    port: PortOpener | None = None
    counter: CounterOpener | None = None
    #: records each head's raw sin/cos signals besides its counts
    signals: bool = False
    #: simulates its rig: its runs are dated as the outputs are (SOURCE_DATE_EPOCH), a
    #: device's by the time they were measured
    simulated: bool = False
    #: the keys it reads in its instrument's table (a port's) besides the dialogue's
    keys: frozenset[str] = field(default_factory=frozenset)
    #: the keys it adds to ``[backend]``
    backend_keys: frozenset[str] = field(default_factory=frozenset)
    #: checks its rig keys before its library is imported (DataError, one line)
    check: Callable[[Rig], None] | None = None
    #: the Python package it imports (pip's name), the enctools extra that installs it,
    #: and what else it needs, as a clause
    package: str | None = None
    extra: str | None = None
    needs: str = ""
    #: where it is listed among the others (lower first; then by kind)
    rank: int = 100

    def missing(self) -> SettingsError:
        """The error of its package not installed: what to install."""
        what = f"'enctools[{self.extra}]'" if self.extra else self.package
        return SettingsError(f"the {self.kind} backend needs the Python package "
                             f"{self.package}: pip install {what}{self.needs}")


#: the transport of an instrument whose kind is neither given nor the rig's backend's
DEFAULT_PORT = "visa"

#: the backends, registered by the modules of this package
_BACKENDS: Registry[Backend] = Registry("backend kind", lambda b: b.kind, __name__)
#: add a backend (a kind registered twice is an error unless ``replace``); the record
register = _BACKENDS.register
#: remove the record of ``kind`` (a backend registered for a while, as a test does)
unregister = _BACKENDS.unregister


def records() -> list[Backend]:
    """Every registered backend, in the order they are listed."""
    return sorted(_BACKENDS.values(), key=lambda b: (b.rank, b.kind))


def kinds(role: str | None = None) -> tuple[str, ...]:
    """The kinds registered (``role``: only those opening a ``"session"``, a ``"port"``
    or a ``"counter"``; ``"signals"``: those recording raw signals)."""
    return tuple(b.kind for b in records()
                 if role is None or bool(getattr(b, role)))


def find(kind: str) -> Backend | None:
    """The record of ``kind``, or None."""
    return _BACKENDS.find(kind)


def get(kind: str) -> Backend:
    """The record of ``kind`` (KeyError when none is registered)."""
    found = find(kind)
    if found is None:
        raise KeyError(kind)
    return found


def of_rig(rig: Rig) -> Backend:
    """The backend a rig's ``[backend] kind`` names; DataError when no record has it."""
    kind = rig.backend.get("kind", "sim")
    found = find(kind) if isinstance(kind, str) else None
    if found is None:
        msg = (f"rig {rig.name}: backend {kind!r} is not available in this enctools "
               f"(backends: {', '.join(kinds())})")
        raise DataError(msg)
    return found


def default_port(kind: str) -> str:
    """The transport of an instrument naming none: the rig's backend's when it is a
    transport, else :data:`DEFAULT_PORT`."""
    return kind if kind in kinds("port") else DEFAULT_PORT


def used_by(rig: Rig) -> list[Backend]:
    """The backends a rig of instruments uses: its ``[backend] kind``, its instruments'
    and counter's kinds, and any whose ``[backend]`` keys it sets; ``default`` is the
    instruments' kind when they name none."""
    be = rig.backend
    kind = str(be.get("kind", "sim"))
    default = default_port(kind)
    named = {kind}
    instruments = be.get("instrument")
    if isinstance(instruments, dict):
        named |= {str(c.get("kind", default)) for c in instruments.values() if isinstance(c, dict)}
    counter = be.get("counter")
    if isinstance(counter, dict) and isinstance(counter.get("kind"), str):
        named.add(counter["kind"])
    return [b for b in records() if b.kind in named or any(k in be for k in b.backend_keys)]
