"""Readings streams as the methods see them: heads, their geometry, their angles.

A readings stream stores each head as int64 counts with field metadata; this
module turns the field metadata into :class:`HeadInfo` and counts into radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyarrow as pa

from enctools.data.schemas import columns_with_role, field_meta
from enctools.errors import DataError
from enctools.units import DEG, TWO_PI


@dataclass(frozen=True)
class HeadInfo:
    """A head as recorded: its encoder and geometry (angles in rad, radius in m)."""

    name: str
    encoder: str
    alpha: float
    counts_per_rev: int
    periods_per_rev: int
    interpolation: int
    radius_m: float
    zero_count: int

    @property
    def signal_period(self) -> float:
        """One signal period [rad]."""
        return TWO_PI / self.periods_per_rev


def head_info(schema: pa.Schema, name: str, source: str = "input") -> HeadInfo:
    """The :class:`HeadInfo` of head column ``name``; DataError if it is not a head."""
    if name not in schema.names:
        heads = columns_with_role(schema, "head")
        msg = f"{source}: no head {name!r} in the readings (heads: {', '.join(heads) or 'none'})"
        raise DataError(msg)
    fm = field_meta(schema.field(name))
    if fm.get("role") != "head":
        msg = f"{source}: column {name!r} is not a head"
        raise DataError(msg)
    cpr = int(fm["counts_per_rev"])
    ppr = int(fm["periods_per_rev"])
    return HeadInfo(name=name, encoder=fm["encoder"], alpha=float(fm["alpha_deg"]) * DEG,
                    counts_per_rev=cpr, periods_per_rev=ppr,
                    interpolation=int(fm.get("interpolation", cpr // ppr)),
                    radius_m=float(fm["radius_m"]), zero_count=int(fm.get("zero_count", 0)))


def heads(schema: pa.Schema) -> list[HeadInfo]:
    """Every head of a readings schema, in column order."""
    return [head_info(schema, n) for n in columns_with_role(schema, "head")]


def measuring_heads(schema: pa.Schema, meta: dict, source: str = "input") -> list[str]:
    """Names of the heads that read the angle of the first head's encoder.

    The rig's ``measure_heads`` of that encoder (``meta["rig"]``) that are recorded,
    else every recorded head of that encoder. DataError when there is no head.
    """
    recorded = columns_with_role(schema, "head")
    if not recorded:
        msg = f"{source}: no head columns in the readings"
        raise DataError(msg)
    enc = head_info(schema, recorded[0], source).encoder
    wanted: list[str] = []
    for e in (meta.get("rig") or {}).get("encoders", []):
        if e.get("name") == enc:
            wanted = list(e.get("measure_heads") or [])
    return [h for h in wanted if h in recorded] or \
        [h for h in recorded if head_info(schema, h, source).encoder == enc]


def head_angle(counts: np.ndarray | pa.Array, info: HeadInfo) -> np.ndarray:
    """Head reading [rad] from counts: counts * 2 pi / counts_per_rev (zero at the head)."""
    c = counts.to_numpy(zero_copy_only=False) if isinstance(counts, (pa.Array, pa.ChunkedArray)) \
        else np.asarray(counts)
    return c.astype(np.float64) * (TWO_PI / info.counts_per_rev)


def signal_step(counts: np.ndarray, info: HeadInfo) -> np.ndarray:
    """Interpolation step within the signal period [count], 0..interpolation - 1."""
    c = np.asarray(counts, dtype=np.int64) + info.zero_count
    return np.mod(c, info.interpolation)


def signal_phase(counts: np.ndarray, info: HeadInfo) -> np.ndarray:
    """Phase within the signal period [rad], 0..2 pi, from a head's counts."""
    return signal_step(counts, info) * (TWO_PI / info.interpolation)
