"""The device interface every backend implements.

An acquisition talks to a :class:`Session`: a :class:`Counter` for the encoder heads
(hardware-timed blocks for continuous runs, single synchronised samples for steps),
named :class:`Sensor` objects (probes, autocollimator), an :class:`Axis` and a
:class:`Clock` (real time for instruments, virtual time for the simulator).

Counter values are raw: unsigned integers that wrap at ``2**counter_bits``;
:mod:`enctools.acquire` unwraps them into int64 counts.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any

import numpy as np

from enctools.errors import SettingsError


@dataclass(frozen=True)
class Channel:
    """A column a device delivers: name, unit, role and field metadata."""

    name: str
    unit: str
    role: str | None = None
    meta: dict[str, Any] | None = None


class Clock:
    """Wall-clock time (s) and sleeping; the simulator substitutes virtual time."""

    def now(self) -> float:
        """The time [s] (monotonic; only differences mean anything)."""
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        """Wait ``seconds`` [s] (nothing for 0 or less)."""
        if seconds > 0:
            time.sleep(seconds)


def carry_partial(exc: BaseException, block: dict[str, np.ndarray]) -> None:
    """Attach to ``exc`` the samples a block read completed before ``exc`` stopped it.

    A counter whose ``read_block`` is stopped by a fault or an interruption (SIGINT,
    SIGTERM) after some samples passes them on this way: the acquisition writes them
    before the run ends, so every sample read is kept.
    """
    if len(block.get("t", ())) > 0:
        exc.enc_partial_block = block  # type: ignore[attr-defined]


def partial_block(exc: BaseException) -> dict[str, np.ndarray] | None:
    """The completed samples :func:`carry_partial` attached to ``exc``, if any."""
    block = getattr(exc, "enc_partial_block", None)
    return block if isinstance(block, dict) else None


class Counter(ABC):
    """The encoder heads' counters, read together."""

    heads: tuple[str, ...]
    counter_bits: dict[str, int]

    @abstractmethod
    def start(self, interval_s: float) -> None:
        """Start hardware-timed sampling every ``interval_s`` seconds."""

    @abstractmethod
    def read_block(self, max_samples: int) -> dict[str, np.ndarray]:
        """The next samples since the last call (at most ``max_samples``): ``t`` [s] and
        one raw counter array [count] per head. Stopped by an exception after some
        samples, it attaches them to it (:func:`carry_partial`)."""

    @abstractmethod
    def stop(self) -> None:
        """Stop hardware-timed sampling."""

    @abstractmethod
    def read_now(self) -> dict[str, np.ndarray]:
        """One software-timed sample of every head [count] (arrays of length 1, with ``t`` [s])."""


class Sensor(ABC):
    """An auxiliary instrument giving one value per reading (probe, autocollimator)."""

    channel: Channel

    @abstractmethod
    def read(self) -> float:
        """One reading in the channel's unit."""


class Axis(ABC):
    """The motion axis of the rotary table."""

    @abstractmethod
    def rotate(self, speed: float) -> None:
        """Turn continuously at ``speed`` [rad/s]."""

    @abstractmethod
    def stop(self) -> None:
        """Stop turning."""

    @abstractmethod
    def move_to(self, angle: float) -> None:
        """Move to ``angle`` [rad] as read by the feedback encoder, and wait in position."""


class Session(ABC):
    """An open rig: its counter, sensors, axis and clock. Close it when done."""

    counter: Counter
    sensors: dict[str, Sensor]
    axis: Axis
    clock: Clock

    def channels(self) -> list[Channel]:
        """Extra columns this session delivers with each counter block (raw signals)."""
        return []

    def truth(self) -> dict[str, Any] | None:
        """Ground truth to carry in the stream's metadata (simulator only)."""
        return None

    def describe(self) -> dict[str, Any]:
        """What the backend says of itself (goes into the settings metadata)."""
        return {}

    def turn_polygon(self, setting: int) -> None:
        """Set the polygon on the table turned by ``setting`` faces from its first setting
        (a closure run of enc acquire); a rig that cannot refuses it before any output."""
        msg = (f"`mode` closure: the {self.describe().get('backend', 'rig')!s} backend cannot "
               "turn the polygon on the table; closure runs are simulated (backend sim)")
        raise SettingsError(msg)

    def close(self) -> None:  # noqa: B027 - a session without devices has nothing to release
        """Release the devices."""

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
