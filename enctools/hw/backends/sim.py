"""The ``sim`` backend: the virtual rig of :mod:`enctools.hw.sim` (seed 000's measurement
model on a virtual clock, its ground truth carried in the stream's metadata)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from enctools.hw.backends import Backend, Opening, register

if TYPE_CHECKING:
    from enctools.data.rig import Rig
    from enctools.hw.base import Session


def open_session(rig: Rig, opening: Opening) -> Session:
    """The virtual rig; ``[backend] realtime = true`` paces it as ``opening.realtime`` does."""
    from enctools.hw.sim import VirtualRig

    return VirtualRig(rig, seed=opening.seed, signals=opening.signals,
                      realtime=opening.realtime or bool(rig.backend.get("realtime", False)))


BACKEND = register(Backend("sim", "the simulator", session=open_session, signals=True,
                           simulated=True, backend_keys=frozenset({"seed", "realtime"}), rank=0))
