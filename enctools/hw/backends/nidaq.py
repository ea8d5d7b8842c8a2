"""The ``nidaq`` backend: NI-DAQmx angular-encoder counter channels for the heads
(:mod:`enctools.hw.nidaq`), hardware-timed; the other roles through line instruments."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from enctools.hw.backends import Backend, register

if TYPE_CHECKING:
    from enctools.data.rig import Rig
    from enctools.hw.base import Clock, Counter


def open_counter(rig: Rig, cfg: dict[str, Any], clock: Clock, t0: float) -> Counter:
    """One DAQmx counter task per head (``[backend.counter]``, the heads' ``backend``)."""
    from enctools.hw.nidaq import NidaqCounter

    return NidaqCounter(rig, cfg, clock, t0)


BACKEND = register(Backend(
    "nidaq", "NI-DAQmx counter channels", counter=open_counter, package="nidaqmx",
    extra="nidaq", needs=" (and the NI-DAQmx driver from ni.com)", rank=3))
