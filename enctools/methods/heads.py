"""Head arrangements: averaging heads, and the transfer functions of averages and differences.

Heads of one encoder at nominal angles alpha_k [rad] see the graduation error
eps(theta + alpha_k) and the spindle's radial error motion through
``[x sin alpha_k - y cos alpha_k] / R`` (seed 000 eq. (1)).

- Averaging N heads passes the harmonic n of eps with
  ``A(n) = (1/N) sum_k exp(i n alpha_k)`` (seed 000 eqs. (3)-(6)): equally spaced heads
  keep the multiples of N (A = 1) and cancel the rest (A = 0), and radial motion
  cancels whenever ``sum_k exp(i alpha_k) = 0``.
- The difference of head k and head j has ``W_kj(n) = exp(i n alpha_k) - exp(i n alpha_j)``
  (seed 000 eq. (11)); the basic Fourier self-calibration divides by it.

:func:`run` adds averages of heads to a readings stream (enc average-heads).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from enctools.errors import SettingsError
from enctools.units import DEG

if TYPE_CHECKING:
    from collections.abc import Iterator

    import pyarrow as pa

    from enctools.data.streams import Header, InputStream

log = logging.getLogger("enctools")


#: harmonics x heads of A(n) formed at once: 16 MB of complex128 [values]
TRANSFER_BLOCK = 1 << 20


def average_transfer(alphas: np.ndarray, n: np.ndarray) -> np.ndarray:
    """A(n) = mean_k exp(i n alpha_k) of the heads at ``alphas`` [rad] (seed 000 eq. (5)).

    Formed a block of orders at a time (at most :data:`TRANSFER_BLOCK` orders x heads):
    memory does not grow with the band times the heads.
    """
    a = np.asarray(alphas, dtype=np.float64)
    orders = np.asarray(n, dtype=np.float64).ravel()
    out = np.empty(orders.size, dtype=np.complex128)
    step = max(1, TRANSFER_BLOCK // max(a.size, 1))
    for i in range(0, orders.size, step):
        out[i:i + step] = np.exp(1j * np.outer(orders[i:i + step], a)).mean(axis=1)
    return out.reshape(np.shape(n))


def radial_gain(alphas: np.ndarray) -> float:
    """How much of the radial motion an average keeps: |mean_k exp(i alpha_k)|.

    ``alphas``: the heads' nominal angles [rad]. The average's reading moves by
    ``[x <sin alpha> - y <cos alpha>] / R`` [rad] for radial motion x, y [m] at radius
    R [m]; the gain (dimensionless) is 0 where radial motion cancels (equal spacing,
    N >= 2), 1 for a single head.
    """
    return float(abs(np.exp(1j * np.asarray(alphas, dtype=np.float64)).mean()))


@dataclass(frozen=True)
class AverageSummary:
    """Which harmonics an average of heads passes and cancels, up to ``band``."""

    alphas_deg: tuple[float, ...]
    band: int
    passed: tuple[int, ...]       # |A(n)| = 1
    cancelled: tuple[int, ...]    # A(n) = 0
    partial: tuple[int, ...]      # 0 < |A(n)| < 1
    radial_gain: float

    @property
    def equally_spaced_n(self) -> int | None:
        """N when the heads are N equally spaced ones (passes exactly the multiples of N)."""
        n = len(self.alphas_deg)
        want = tuple(k for k in range(1, self.band + 1) if k % n == 0)
        return n if n > 1 and self.passed == want and not self.partial else None

    def describe(self, name: str, heads: list[str]) -> str:
        """One line for a log or a report."""
        eq = self.equally_spaced_n
        if eq:
            keeps = f"keeps the multiples of {eq} of the graduation error and cancels the rest"
        else:
            keeps = (f"keeps {_ranges(self.passed) or 'no harmonic'} fully, cancels "
                     f"{_ranges(self.cancelled) or 'none'}, "
                     f"attenuates {_ranges(self.partial) or 'none'}")
        radial = ("cancels radial motion" if self.radial_gain < 1e-9 else
                  f"keeps {self.radial_gain:.3g} of the radial motion")
        return (f"{name} = mean({', '.join(heads)}) at "
                f"{'/'.join(f'{a:g}' for a in self.alphas_deg)} deg: {keeps} "
                f"(n <= {self.band}); {radial}")


def summarize_average(alphas: np.ndarray, band: int) -> AverageSummary:
    """Passed, cancelled and attenuated harmonics 1..band of a mean of heads at ``alphas`` [rad]."""
    n = np.arange(1, band + 1)
    mag = np.abs(average_transfer(alphas, n))
    passed = tuple(int(k) for k in n[mag > 1 - 1e-9])
    cancelled = tuple(int(k) for k in n[mag < 1e-9])
    partial = tuple(int(k) for k in n[(mag >= 1e-9) & (mag <= 1 - 1e-9)])
    return AverageSummary(tuple(float(a / DEG) for a in alphas), band, passed, cancelled,
                          partial, radial_gain(alphas))


def _ranges(ns: tuple[int, ...] | list[int], limit: int = 12) -> str:
    """'2, 4, 6, ..., 100 (every 2nd)' or '3-7, 12' - a short list of harmonic orders."""
    ns = list(ns)
    if not ns:
        return ""
    if len(ns) > 3:
        steps = set(np.diff(ns))
        if len(steps) == 1 and ns[1] - ns[0] > 1:
            return f"{ns[0]}, {ns[1]}, ..., {ns[-1]}"
    runs: list[str] = []
    start = prev = ns[0]
    for k in [*ns[1:], None]:
        if k is not None and k == prev + 1:
            prev = k
            continue
        if prev - start < 3:
            runs += [str(k) for k in range(start, prev + 1)]
        else:
            runs.append(f"{start}-{prev}")
        if k is not None:
            start = prev = k
    if len(runs) > limit:
        return ", ".join(runs[:limit]) + f", ... ({len(ns)} in all)"
    return ", ".join(runs)


def format_orders(ns: list[int] | tuple[int, ...]) -> str:
    """A short human list of harmonic orders (ranges and arithmetic runs folded)."""
    return _ranges(ns)


@dataclass(frozen=True)
class AverageGroup:
    """A new channel ``name`` = mean of ``heads`` (all of one encoder)."""

    name: str
    heads: tuple[str, ...]


def default_name(heads: list[str] | tuple[str, ...], taken: set[str]) -> str:
    """The paper's naming: H1..H4 -> H, P1,P2 -> P (the common letters), kept unique."""
    import os.path

    prefix = os.path.commonprefix(list(heads)).rstrip("0123456789_.-") or "avg"
    name = prefix
    k = 2
    while name in taken:
        name = f"{prefix}avg" if k == 2 else f"{prefix}avg{k}"
        k += 1
    return name


def average_field(schema: pa.Schema, group: AverageGroup, band: int = 100,
                  source: str = "input") -> pa.Field:
    """The head field of an average of heads: exact integer sum of their counts.

    The new column holds ``sum_k (counts_k)`` with ``counts_per_rev = N * cpr``,
    ``interpolation = N * interpolation`` and ``zero_count = sum_k zero_count_k`` and
    ``alpha_deg = mean_k alpha_k``: its reading (:func:`enctools.data.readings.head_reading`)
    is exactly the mean of the heads' readings (seed 000 eqs. (3), (6)); no rounding.
    Field metadata ``average_of`` names the heads; ``passes`` lists what A(n) keeps.
    """
    import pyarrow as pa

    from enctools.data.readings import head_info
    from enctools.data.schemas import make_field
    from enctools.errors import DataError

    infos = [head_info(schema, h, source) for h in group.heads]
    if len(infos) < 1:
        raise SettingsError(f"`groups` {group.name}: no heads given")
    encs = {i.encoder for i in infos}
    cprs = {i.counts_per_rev for i in infos}
    if len(encs) > 1 or len(cprs) > 1:
        msg = (f"`groups` {group.name}: heads {', '.join(group.heads)} are of different "
               f"encoders ({', '.join(sorted(encs))}); average heads of one scale")
        raise SettingsError(msg)
    if len(set(group.heads)) != len(group.heads):
        raise SettingsError(f"`groups` {group.name}: a head is named twice")
    if group.name in schema.names:
        raise SettingsError(f"`groups` {group.name}: the input already has a column {group.name!r}")
    n = len(infos)
    alphas = np.array([i.alpha for i in infos])
    _check_text(group, alphas)
    s = summarize_average(alphas, band)
    i0 = infos[0]
    if n * i0.counts_per_rev > (1 << 62) // 1024:
        raise DataError(f"`groups` {group.name}: counts would overflow int64")
    return make_field(group.name, pa.int64(), "count", "head", encoder=i0.encoder,
                      alpha_deg=repr(float(alphas.mean() / DEG)),
                      counts_per_rev=n * i0.counts_per_rev, periods_per_rev=i0.periods_per_rev,
                      interpolation=n * i0.interpolation, radius_m=repr(i0.radius_m),
                      zero_count=sum(i.zero_count for i in infos),
                      average_of=",".join(group.heads),
                      average_alphas_deg=",".join(repr(float(a / DEG)) for a in alphas),
                      passes=format_orders(s.passed) or "none",
                      radial_gain=f"{s.radial_gain:.3g}" if s.radial_gain > 1e-12 else "0")


def _check_text(group: AverageGroup, alphas: np.ndarray) -> None:
    """SettingsError, before any summary is formed, when the average's field metadata
    (the heads it averages and their angles) would be longer than a stream carries
    (:data:`~enctools.data.limits.MAX_FIELD_TEXT`)."""
    from enctools.data.limits import MAX_FIELD_TEXT

    names = len(",".join(group.heads))
    angles = len(",".join(repr(float(a / DEG)) for a in alphas))
    if max(names, angles) > MAX_FIELD_TEXT:
        msg = (f"`groups` {group.name}: an average of {len(group.heads)} heads; naming them "
               f"and their angles takes {max(names, angles)} characters of field metadata, "
               f"at most {MAX_FIELD_TEXT}: average fewer heads at once")
        raise SettingsError(msg)


def average_column(batch: pa.RecordBatch, group: AverageGroup) -> pa.Array:
    """The summed counts [count] of the group's heads in one batch (int64, exact: a sum
    beyond int64 is refused). Summed in numpy; columns with nulls (null sums) by Arrow."""
    from enctools.data.arrays import arrow_array
    from enctools.errors import DataError

    columns = [batch.column(h) for h in group.heads]
    if any(c.null_count for c in columns):
        return _average_column_with_nulls(columns)
    total = columns[0].to_numpy().astype(np.int64, copy=False)
    for c in columns[1:]:
        add = c.to_numpy().astype(np.int64, copy=False)
        s = total + add
        if np.any((total ^ s) & (add ^ s) < 0):  # a sum of two of one sign has the other
            msg = f"`groups` {group.name}: the heads' summed counts overflow int64"
            raise DataError(msg)
        total = s
    return arrow_array(total)


def _average_column_with_nulls(columns: list[pa.Array]) -> pa.Array:
    """:func:`average_column` of head columns, some with nulls: a row's sum is null where
    any of its counts is (Arrow's checked sum)."""
    import pyarrow as pa
    import pyarrow.compute as pc

    total = columns[0]
    for c in columns[1:]:
        total = pc.add_checked(total, c)
    return total if total.type == pa.int64() else total.cast(pa.int64())


def head_alphas(field: pa.Field) -> np.ndarray:
    """The angles [rad] of the heads behind a head column: one, or those it averages."""
    from enctools.data.schemas import field_meta

    fm = field_meta(field)
    if "average_alphas_deg" in fm:
        return np.array([float(a) for a in fm["average_alphas_deg"].split(",")]) * DEG
    return np.array([float(fm["alpha_deg"])]) * DEG


@dataclass(frozen=True)
class Settings:
    """What enc average-heads does: its options, checked together.

    ``groups``: (name or None, heads) of each new channel, the name defaulting to the
    heads' common prefix (:func:`default_name`); empty: each encoder's measuring heads
    (rig metadata ``measure_heads``) when two or more are recorded. ``band``: the
    harmonics 1..K over which each average's A(n) is summarised; ``drop``: leave the
    averaged heads out of the output.
    """

    groups: tuple[tuple[str | None, tuple[str, ...]], ...] = ()
    band: int = 100
    drop: bool = False

    def __post_init__(self) -> None:
        if self.band < 1:
            msg = f"`band` must be > 0, not {self.band}"
            raise SettingsError(msg)


def run(source: InputStream, settings: Settings) -> tuple[Header, Iterator[pa.RecordBatch]]:
    """A readings stream in; the same stream with the averaged channels added, batch by batch."""
    import pyarrow as pa

    schema = source.schema
    groups = settings.groups or _measuring_groups(source)
    resolved, fields = _averages(schema, groups, settings.band, source.source)
    dropped = {h for g in resolved for h in g.heads} if settings.drop else set()
    keep = [f for f in schema if f.name not in dropped]
    out_schema = pa.schema(keep + fields)
    header = source.header.derive("readings", out_schema,
                                  **{k: v for k, v in source.meta.items()
                                     if k in ("settings", "mode")})
    header.meta["averages"] = {g.name: list(g.heads) for g in resolved}

    def batches() -> Iterator[pa.RecordBatch]:
        for b in source.batches():
            cols = [b.column(f.name) for f in keep] + [average_column(b, g) for g in resolved]
            yield pa.RecordBatch.from_arrays(cols, schema=out_schema)

    return header, batches()


def _measuring_groups(source: InputStream) -> tuple[tuple[str | None, tuple[str, ...]], ...]:
    """Each encoder's recorded measuring heads, as unnamed groups, where there are two or more."""
    from enctools.data.readings import rig_encoders
    from enctools.data.schemas import columns_with_role

    present = set(columns_with_role(source.schema, "head"))
    groups: list[tuple[str | None, tuple[str, ...]]] = []
    for enc in rig_encoders(source.meta):
        hs = tuple(h for h in enc.measure_heads if h in present)
        if len(hs) >= 2:
            groups.append((None, hs))
    if not groups:
        msg = "no `groups` given and the rig names no measuring heads to average"
        raise SettingsError(msg)
    return tuple(groups)


def _averages(schema: pa.Schema, groups: tuple[tuple[str | None, tuple[str, ...]], ...],
              band: int, source: str) -> tuple[list[AverageGroup], list[pa.Field]]:
    """The named groups and their fields; logs what each average keeps of the harmonics."""
    from enctools.data.readings import head_info

    taken = set(schema.names)
    resolved: list[AverageGroup] = []
    fields = []
    for name, hs in groups:
        if name is not None and any(g.name == name for g in resolved):
            msg = f"`groups` {name}: the name is given to two averages"
            raise SettingsError(msg)
        g = AverageGroup(name or default_name(hs, taken), tuple(hs))
        fields.append(average_field(schema, g, band, source))
        taken.add(g.name)
        resolved.append(g)
        alphas = np.array([head_info(schema, h).alpha for h in hs])
        s = summarize_average(alphas, band)
        log.info("%s", s.describe(g.name, list(hs)))
        if s.radial_gain > 1e-9 and len(hs) > 1:
            log.warning("%s: heads %s are not equally spaced: radial motion does not cancel "
                        "(%.3g of it remains)", g.name, ",".join(hs), s.radial_gain)
    return resolved, fields
