"""Exceptions that carry the exit status of the ``enc`` commands.

Every error a user can cause or meet is one of these; the command layer prints
``enc CMD: error: <message>`` on one line and exits with :attr:`EncError.exit_code`.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Callable, Iterator
from typing import Any

#: a setting named in a message: a field of a settings object between backticks,
#: ``band`` or ``target.lsb`` (dotted: a field of a field)
_FIELD = re.compile(r"`([A-Za-z_][A-Za-z0-9_.]*)`")


class EncError(Exception):
    """Base class: a one-line message and an exit status.

    A message names a setting by the field that holds it, between backticks: ``str()``
    shows the field (``band must be >= 0``), which a caller of the library sets; the
    command line shows, in its place, the option that sets it (by the table of
    ``enctools.cli.usage``), so the library never speaks of options.
    """

    exit_code = 2

    def __init__(self, message: str = "") -> None:
        super().__init__(message)
        self.template = message

    @property
    def fields(self) -> tuple[str, ...]:
        """The settings the message names, in order of appearance."""
        return tuple(dict.fromkeys(_FIELD.findall(self.template)))

    def render(self, name: Callable[[str], str]) -> str:
        """The message with each field named by ``name(field)``."""
        return _FIELD.sub(lambda m: name(m.group(1)), self.template)

    def __str__(self) -> str:
        return self.render(lambda field: field)


class CheckFailed(EncError):
    """A tolerance given by the user was exceeded (the cron contract): exit 1."""

    exit_code = 1


class SettingsError(EncError):
    """Settings that are out of range or do not go together: exit 2.

    The message names each setting as the field that holds it, between backticks
    (see :class:`EncError`): ``SettingsError(f"`band` must be >= 0, not {band}")``.
    """

    exit_code = 2


class OutputError(EncError):
    """An output that cannot be written (disk full, folder gone, read-only): exit 2.

    ``path`` names the output (None: stdout), so that a command writing several outputs
    can tell which one failed and keep the others.
    """

    def __init__(self, message: str, path: str | None = None) -> None:
        super().__init__(message)
        self.path = path


class DataError(EncError):
    """Input data that cannot be read or does not fit its kind: exit 2."""

    exit_code = 2


class DeviceError(EncError):
    """A hardware or device fault (timeout, no answer, malformed reply): exit 3."""

    exit_code = 3


#: the signals whose default action ends the process (signal(7): Term or Core) that reach
#: it from outside (SIGINT aside, which Python makes a KeyboardInterrupt): each is turned
#: into :class:`Interrupted`, so that a command's outputs end as on any other ending
#: (whole, or not at all) and its exit status is the shell's 128 + the signal's number;
#: so are the real-time signals (:func:`ending_signal_numbers`). Python ignores SIGPIPE and
#: SIGXFSZ (EPIPE, EFBIG instead). Not caught: SIGKILL, which cannot be, and the faults of
#: the process itself (SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT, SIGSYS, SIGTRAP), after
#: which its state cannot be trusted to finish anything
ENDING_SIGNALS = ("SIGTERM", "SIGHUP", "SIGQUIT", "SIGUSR1", "SIGUSR2", "SIGALRM", "SIGXCPU",
                  "SIGVTALRM", "SIGPROF", "SIGIO", "SIGPWR", "SIGSTKFLT")


def ending_signal_numbers(sigint: bool = True) -> tuple[int, ...]:
    """The numbers of SIGINT (unless ``sigint`` is false), of :data:`ENDING_SIGNALS` this
    platform has and of its real-time signals (SIGRTMIN to SIGRTMAX), whatever their
    disposition now."""
    import signal

    names = ("SIGINT", *ENDING_SIGNALS) if sigint else ENDING_SIGNALS
    numbers = [int(getattr(signal, name)) for name in names if hasattr(signal, name)]
    if hasattr(signal, "SIGRTMIN") and hasattr(signal, "SIGRTMAX"):
        numbers += range(int(signal.SIGRTMIN), int(signal.SIGRTMAX) + 1)
    return tuple(numbers)


def ending_signals(sigint: bool = True) -> tuple[int, ...]:
    """The numbers of :func:`ending_signal_numbers` that this process does not ignore: the
    ones a command may catch.

    A signal ignored when a command starts stays ignored, as POSIX has it for a shell's
    background jobs (started with SIGINT and SIGQUIT ignored) and nohup(1) (SIGHUP):
    catching it would let a terminal's Ctrl-C or hang-up end a job started not to end on
    them. (Python itself leaves an ignored SIGINT ignored.)
    """
    import signal

    return tuple(sig for sig in ending_signal_numbers(sigint)
                 if signal.getsignal(sig) != signal.SIG_IGN)


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Hold SIGINT and the signals that end a command (:func:`ending_signals`: not the
    ignored ones) while the block runs, then deliver the first that came through the
    handler it had (a default one ends the process): a rename of outputs, a history row or
    an import is never cut short where a signal lands. Outside the main thread, where
    Python's handlers cannot be changed, the block runs as it is; a handler set from C is
    left alone."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    came: list[int] = []

    def hold(signum: int, frame: Any) -> None:
        came.append(signum)

    kept = {sig: signal.getsignal(sig) for sig in ending_signals()}
    kept = {sig: handler for sig, handler in kept.items() if handler is not None}
    for sig in kept:
        signal.signal(sig, hold)
    try:
        yield
    finally:
        for sig, handler in kept.items():
            signal.signal(sig, handler)
        if came:
            signal.raise_signal(came[0])


def signal_name(signum: int) -> str:
    """``signum``'s name: SIGHUP, ..., a real-time one as SIGRTMIN+3."""
    import signal

    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"SIGRTMIN+{signum - int(signal.SIGRTMIN)}"


class Interrupted(EncError):
    """Stopped by a signal: SIGINT (exit 130), SIGTERM (exit 143), or another of
    :data:`ENDING_SIGNALS` (exit 128 + its number)."""

    exit_code = 130

    def __init__(self, message: str = "interrupted", exit_code: int = 130) -> None:
        super().__init__(message)
        self.exit_code = exit_code

    @classmethod
    def by_signal(cls, signum: int) -> Interrupted:
        """The ending of signal ``signum``: "terminated" for SIGTERM (exit 143), "stopped
        by SIGHUP" and the like for the others (exit 128 + the number)."""
        name = signal_name(signum)
        return cls("terminated" if name == "SIGTERM" else f"stopped by {name}", 128 + signum)
