"""Fault handling shared by the instrument backends: retries, reply parsing, error queues.

- :func:`query` sends a query and reads its one-line reply; a timeout is retried
  ``policy.retries`` more times (each attempt logged as a warning, the port's input
  cleared in between so a late answer is not taken for the next one), then becomes a
  :class:`~enctools.errors.DeviceError` (exit 3) naming the instrument, its address,
  the query and the bytes received, if any.
- :func:`numbers` parses a reply into numbers; a malformed reply is a DeviceError
  quoting the raw text.
- :func:`error_queue` drains an instrument's error queue (SCPI ``SYST:ERR?``) so the
  instrument's own words go into the message.

A port (VISA resource, serial line) implements :class:`Port`; it raises
:class:`Timeout` when no complete line arrives in time and DeviceError for anything
else it cannot do.
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass
from typing import Protocol

from enctools.errors import DeviceError

log = logging.getLogger("enctools.hw")

INT64 = (-(1 << 63), (1 << 63) - 1)  # the range of a counter value in the stream (int64)
MAX_ERRORS = 32  # entries read from an error queue at most (a queue that never empties)


class Timeout(Exception):
    """No complete reply within the port's timeout; ``partial`` holds the bytes received."""

    def __init__(self, partial: bytes = b"") -> None:
        super().__init__("timeout")
        self.partial = partial


class Port(Protocol):
    """A line-oriented connection to one instrument."""

    name: str  # the instrument's name in the rig file
    address: str  # VISA resource or serial device, for messages
    timeout_s: float

    def write(self, text: str) -> None: ...

    def read_line(self) -> str: ...

    def clear(self) -> None: ...

    def close(self) -> None: ...

    def hint(self) -> str:
        """What to check when replies are missing or garbled (one short clause)."""
        ...


@dataclass(frozen=True)
class Policy:
    """How hard to try: timeout per attempt [s] and retries after the first attempt."""

    timeout_s: float = 1.0
    retries: int = 2

    def __post_init__(self) -> None:
        if not (math.isfinite(self.timeout_s) and self.timeout_s > 0):
            msg = f"timeout must be a positive number of seconds, not {self.timeout_s!r}"
            raise DeviceError(msg)
        if self.retries < 0:
            msg = f"retries must be >= 0, not {self.retries!r}"
            raise DeviceError(msg)


def where(port: Port) -> str:
    return f"instrument {port.name} ({port.address})"


def query(port: Port, text: str, policy: Policy) -> str:
    """Send ``text`` and return the reply line, retrying timeouts; DeviceError at the end."""
    attempts = policy.retries + 1
    partial = b""
    for attempt in range(1, attempts + 1):
        port.write(text)
        try:
            return port.read_line()
        except Timeout as exc:
            partial = exc.partial or partial
            got = f"; received {partial[:40]!r} without a line end" if partial else ""
            log.warning("%s: no answer to %r within %g s (attempt %d of %d)%s", where(port),
                        text, port.timeout_s, attempt, attempts, got)
            port.clear()
    got = (f"; received only {partial[:40]!r}, no line end" if partial else "")
    msg = (f"{where(port)}: no answer to {text!r} after {attempts} attempt"
           f"{'s' if attempts > 1 else ''} of {port.timeout_s:g} s{got} ({port.hint()})")
    raise DeviceError(msg)


def read_line(port: Port, policy: Policy, what: str) -> str:
    """Read one line an instrument sends by itself (a streaming instrument), with retries."""
    attempts = policy.retries + 1
    partial = b""
    for attempt in range(1, attempts + 1):
        try:
            return port.read_line()
        except Timeout as exc:
            partial = exc.partial or partial
            log.warning("%s: no %s within %g s (attempt %d of %d)", where(port), what,
                        port.timeout_s, attempt, attempts)
    got = (f"; received only {partial[:40]!r}, no line end" if partial else "")
    msg = (f"{where(port)}: no {what} after {attempts} attempt{'s' if attempts > 1 else ''} "
           f"of {port.timeout_s:g} s{got} ({port.hint()})")
    raise DeviceError(msg)


_SPLIT = re.compile(r"[,;\s]+")


def numbers(raw: str, port: Port, sent: str, count: int | None = None,
            integer: bool = False, separator: str | None = None) -> list[float] | list[int]:
    """The numbers of a reply (comma, semicolon or blank separated, or ``separator``).

    ``count``: how many are expected (None: at least one). A reply that does not parse
    is a DeviceError quoting the raw text.
    """
    text = raw.strip()
    parts = [p for p in (text.split(separator) if separator else _SPLIT.split(text)) if p.strip()]
    want = f"{count} " if count else ""
    kind = "integers" if integer else "numbers"

    def bad(why: str) -> DeviceError:
        return DeviceError(f"{where(port)}: malformed reply {raw!r} to {sent!r}: {why} "
                           f"(expected {want}{kind})")

    if not parts:
        raise bad("empty")
    if count is not None and len(parts) != count:
        raise bad(f"{len(parts)} values")
    out: list = []
    for p in parts:
        p = p.strip()
        try:
            if integer:
                try:
                    v: float | int = int(p)
                except ValueError:
                    f = float(p)
                    if not f.is_integer():
                        raise ValueError from None
                    v = int(f)
            else:
                v = float(p)
        except (ValueError, OverflowError):
            raise bad(f"{p!r} is not a number") from None
        if integer and not INT64[0] <= v <= INT64[1]:
            raise bad(f"{p} is out of range (a counter value fits in 64 bits)")
        out.append(v)
    return out


def error_queue(port: Port, text: str, policy: Policy, no_error: tuple[str, ...]) -> list[str]:
    """Drain an instrument's error queue: the entries before the 'no error' reply."""
    out: list[str] = []
    for _ in range(MAX_ERRORS):
        reply = query(port, text, policy).strip()
        if not reply or any(reply.startswith(p) for p in no_error):
            return out
        out.append(reply)
    log.warning("%s: error queue still not empty after %d reads of %r", where(port),
                MAX_ERRORS, text)
    return out
