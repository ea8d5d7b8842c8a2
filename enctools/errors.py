"""Exceptions that carry the exit status of the ``enc`` commands.

Every error a user can cause or meet is one of these; the command layer prints
``enc CMD: error: <message>`` on one line and exits with :attr:`EncError.exit_code`.
"""

from __future__ import annotations


class EncError(Exception):
    """Base class: a one-line message and an exit status."""

    exit_code = 2


class CheckFailed(EncError):
    """A tolerance given by the user was exceeded (the cron contract): exit 1."""

    exit_code = 1


class UsageError(EncError):
    """Bad options or option values: exit 2."""

    exit_code = 2


class OutputError(UsageError):
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


class Interrupted(EncError):
    """Stopped by SIGINT (exit 130) or SIGTERM (exit 143)."""

    exit_code = 130

    def __init__(self, message: str = "interrupted", exit_code: int = 130) -> None:
        super().__init__(message)
        self.exit_code = exit_code
