"""Head geometry: a head's counts, its column's field metadata and the rig, in one place.

A readings stream stores each head as an int64 column of counts whose field metadata
carries the head's geometry. This module

- encodes that metadata (:func:`head_field`) and decodes it (:func:`head_info`,
  :class:`HeadInfo`);
- names the angles computed from counts (seed 000 eq. (1)): the scale angle under a
  head, the head's reading of the spindle angle, the zero-based head angle, and the
  means of several heads;
- reads the rig back from a stream's metadata (:func:`rig_encoders`), so no caller
  digs in ``meta["rig"]`` by hand.

A head at nominal angle alpha [rad] whose counter is zeroed at the grating line
``zero_count`` [count] reads ``counts`` [count]:

- scale angle under the head [rad] = (counts + zero_count) * 2 pi / counts_per_rev;
- spindle reading [rad] = scale angle - alpha, the spindle angle plus the head's
  errors (:func:`head_reading`);
- zero-based head angle [rad] = counts * 2 pi / counts_per_rev (:func:`head_angle`),
  which is the spindle reading plus the head's offset alpha - zero_count * 2 pi /
  counts_per_rev (:func:`head_offset`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np
import pyarrow as pa

from enctools.data.limits import FIELD_RANGES
from enctools.data.schemas import (
    check_field_values,
    columns_with_role,
    field_meta,
    make_field,
    parse_field_value,
)
from enctools.errors import DataError
from enctools.units import DEG, TWO_PI

if TYPE_CHECKING:  # the rig module is imported where a stream's rig is read back
    from enctools.data.rig import Encoder

#: head counts [count] as numpy or Arrow
Counts: TypeAlias = np.ndarray | pa.Array | pa.ChunkedArray


# ------------------------------------------------------------ encode and decode


def head_field(name: str, encoder: str, alpha_deg: float, counts_per_rev: int,
               periods_per_rev: int, interpolation: int, radius_m: float, zero_count: int,
               **extra: Any) -> pa.Field:
    """The int64 column [count] of a head, its geometry in the field metadata.

    Parameters
    ----------
    name, encoder : the head's column and the encoder it reads.
    alpha_deg : nominal angle of the head [deg].
    counts_per_rev, periods_per_rev, interpolation : counts and signal periods per
        revolution [count], counts per signal period.
    radius_m : scale radius [m].
    zero_count : the grating line the head's counter is zeroed at [count].
    extra : further metadata (an average of heads names the heads it averages).
    """
    return make_field(name, pa.int64(), "count", "head", encoder=encoder,
                      alpha_deg=repr(float(alpha_deg)), counts_per_rev=counts_per_rev,
                      periods_per_rev=periods_per_rev, interpolation=interpolation,
                      radius_m=repr(float(radius_m)), zero_count=zero_count, **extra)


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
    index = schema.get_field_index(name)  # a lookup, where schema.names builds every name
    if index < 0 and name not in schema.names:
        heads = columns_with_role(schema, "head")
        msg = f"{source}: no head {name!r} in the readings (heads: {', '.join(heads) or 'none'})"
        raise DataError(msg)
    fm = field_meta(schema.field(name if index < 0 else index))  # < 0: a name given twice
    if fm.get("role") != "head":
        msg = f"{source}: column {name!r} is not a head"
        raise DataError(msg)
    check_field_values(name, fm, source)
    ranges = FIELD_RANGES["head"]

    def value(key: str, default: str | None = None) -> Any:
        text = fm.get(key, default)
        if text is None:
            msg = f"{source}: column {name!r} lacks field metadata {key}"
            raise DataError(msg)
        return parse_field_value(text, ranges[key])

    cpr, ppr = value("counts_per_rev"), value("periods_per_rev")
    return HeadInfo(name=name, encoder=value("encoder"), alpha=value("alpha_deg") * DEG,
                    counts_per_rev=cpr, periods_per_rev=ppr,
                    interpolation=value("interpolation", str(cpr // ppr)),
                    radius_m=value("radius_m"), zero_count=value("zero_count", "0"))


def heads(schema: pa.Schema) -> list[HeadInfo]:
    """Every head of a readings schema, in column order."""
    return [head_info(schema, n) for n in columns_with_role(schema, "head")]


# ---------------------------------------------------------------------- angles


def _as_numpy(counts: Counts) -> np.ndarray:
    if isinstance(counts, (pa.Array, pa.ChunkedArray)):
        return counts.to_numpy(zero_copy_only=False)
    return np.asarray(counts)


def head_angle(counts: Counts, info: HeadInfo) -> np.ndarray:
    """Zero-based head angle [rad]: counts * 2 pi / counts_per_rev (zero at the head's zero).

    It differs from the head's spindle reading (:func:`head_reading`) by the head's
    offset (:func:`head_offset`), less than one signal period.
    """
    # one pass: the counts converted to float64 within the product (as astype would)
    return np.multiply(_as_numpy(counts), TWO_PI / info.counts_per_rev, dtype=np.float64)


def head_offset(counts_per_rev: int, zero_count: int, alpha: float) -> float:
    """Zero-based head angle minus spindle reading [rad]: alpha - zero_count * 2 pi / cpr.

    ``alpha``: the head's nominal angle [rad]; ``zero_count``: the grating line its
    counter is zeroed at [count].
    """
    return alpha - zero_count * TWO_PI / counts_per_rev


def head_reading(counts: Counts, counts_per_rev: int, zero_count: int,
                 alpha: float) -> np.ndarray:
    """A head's reading of the spindle angle theta [rad]: theta + its errors.

    The scale angle under the head, ``(counts + zero_count) * 2 pi / counts_per_rev``,
    minus its nominal angle ``alpha`` [rad] (seed 000 eq. (1)); computed as the
    zero-based angle minus :func:`head_offset`, which keeps the rounding at the size of
    theta rather than theta + alpha.
    """
    zero_based = _as_numpy(counts).astype(np.float64) * (TWO_PI / counts_per_rev)
    return zero_based - head_offset(counts_per_rev, zero_count, alpha)


def mean_head_reading(columns: Sequence[Counts], infos: Sequence[HeadInfo]) -> np.ndarray:
    """Mean spindle reading of several heads [rad] (:func:`head_reading` of each)."""
    total = np.zeros(len(_as_numpy(columns[0])))
    for counts, i in zip(columns, infos, strict=True):
        total += head_reading(counts, i.counts_per_rev, i.zero_count, i.alpha)
    return total / len(infos)


def mean_head_angle(columns: Sequence[Counts], infos: Sequence[HeadInfo]) -> np.ndarray:
    """Mean zero-based angle of several heads [rad] (:func:`head_angle` of each)."""
    total = np.zeros(len(_as_numpy(columns[0])))
    for counts, i in zip(columns, infos, strict=True):
        total += head_angle(counts, i)
    return total / len(infos)


def signal_step(counts: np.ndarray, info: HeadInfo) -> np.ndarray:
    """Interpolation step within the signal period [count], 0..interpolation - 1."""
    c = np.asarray(counts, dtype=np.int64)
    n = info.interpolation
    # (c + zero_count) mod n = (c + zero_count mod n) mod n: no pass when it is 0
    shift = info.zero_count % n if n > 0 else info.zero_count
    out = None
    if shift:
        c = out = c + shift
    if n > 0 and n & (n - 1) == 0:  # a power of two: the floor modulo, without a division
        return np.bitwise_and(c, n - 1, out=out)
    return np.mod(c, n, out=out)


def signal_phase(counts: np.ndarray, info: HeadInfo) -> np.ndarray:
    """Phase within the signal period [rad], 0..2 pi, from a head's counts."""
    return signal_step(counts, info) * (TWO_PI / info.interpolation)


# ------------------------------------------------------------ the rig, read back


def rig_encoders(meta: Mapping[str, Any]) -> tuple[Encoder, ...]:
    """The encoders of the rig a stream was recorded on (``meta["rig"]``), in rig order.

    Read back from the description ``enc acquire`` writes (``Rig.to_dict``); keys
    missing from it take the defaults of :class:`~enctools.data.rig.Encoder` (0 for
    the scale's counts and size). None when the stream names no rig.
    """
    rig = meta.get("rig")
    if not isinstance(rig, Mapping):
        return ()
    try:
        return tuple(_encoder(e) for e in rig.get("encoders") or () if isinstance(e, Mapping))
    except (TypeError, ValueError) as exc:
        raise _malformed(exc) from None


def _malformed(exc: Exception) -> DataError:
    return DataError(f"the rig description in the metadata has a malformed encoder: {exc}")


def rig_encoder(meta: Mapping[str, Any], name: str) -> Encoder | None:
    """The rig's encoder called ``name`` (:func:`rig_encoders`), or None."""
    return next((e for e in rig_encoders(meta) if e.name == name), None)


def rig_measure_heads(meta: Mapping[str, Any], encoder: str) -> tuple[str, ...]:
    """The heads whose mean is encoder ``encoder``'s reading (its ``measure_heads``).

    Empty when the rig is not recorded or has no such encoder.
    """
    rig = meta.get("rig")
    if not isinstance(rig, Mapping):
        return ()
    try:  # the one list, read as _encoder reads it: no rig module, no other encoder built
        return next((tuple(str(h) for h in e.get("measure_heads") or ())
                     for e in rig.get("encoders") or ()
                     if isinstance(e, Mapping) and str(e.get("name", "")) == encoder), ())
    except (TypeError, ValueError) as exc:
        raise _malformed(exc) from None


def _encoder(d: Mapping[str, Any]) -> Encoder:
    from enctools.data.rig import Encoder, Head

    name = str(d.get("name", ""))

    def num(obj: Mapping[str, Any], key: str, kind: type, default: Any, where: str = "") -> Any:
        value = obj.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or (
                kind is int and not float(value).is_integer()):
            msg = (f"rig encoder {name!r}{where}: {key} = {str(value)[:40]!r} is not "
                   f"{'an integer' if kind is int else 'a number'}")
            raise ValueError(msg)
        return kind(value)

    heads = tuple(Head(str(h.get("name", "")), num(h, "angle", float, 0.0, f" head {k}"),
                       num(h, "noise_arcsec", float, 0.0, f" head {k}"),
                       dict(h.get("signal") or {}), dict(h.get("backend") or {}))
                  for k, h in enumerate(d.get("heads") or ()) if isinstance(h, Mapping))
    return Encoder(name=name, periods_per_rev=num(d, "periods_per_rev", int, 0),
                   interpolation=num(d, "interpolation", int, 0),
                   diameter_mm=num(d, "diameter_mm", float, 0.0), heads=heads,
                   model=str(d.get("model", "")), counter_bits=num(d, "counter_bits", int, 32),
                   latency_s=num(d, "latency_s", float, 0.0),
                   plane_mm=num(d, "plane_mm", float, 0.0),
                   measure_heads=tuple(str(h) for h in d.get("measure_heads") or ()),
                   graduation=dict(d.get("graduation") or {}),
                   radial=dict(d.get("radial") or {}))


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
    wanted = rig_measure_heads(meta, enc)
    return [h for h in wanted if h in recorded] or \
        [h for h in recorded if head_info(schema, h, source).encoder == enc]
