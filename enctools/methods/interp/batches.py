"""A readings batch made ready for the fits, most of it on the stream's reader thread.

What a batch needs that depends on it alone is worked out on the reader thread while the
caller's thread sums the one before (``InputStream.batches(prepare=...)``, see
:meth:`enctools.data.streams.InputStream.batches`): the reference's angle and step and
the rows it covers, the heads' counts, the runs and targets. For a continuous run the
trend windows of its reference angle (counted from the first batch's first angle, the
one state kept from batch to batch) with, per head, zeta at each window's first sample
are made on the caller's thread (:meth:`Preparer.finish`), which keeps the two threads
even. The fits then take it (:func:`.readings.check_readings`): the same arrays as when
it was all done on one thread, so the same results bit for bit.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.readings import head_info
from enctools.errors import DataError
from enctools.methods.interp.fit import window_grouping
from enctools.methods.interp.reference import Reference, ReferenceReading
from enctools.methods.interp.tables import CHUNK_ROWS, column
from enctools.methods.trend_lsq import Grouping
from enctools.units import ARCSEC, TWO_PI


@dataclass
class Windows:
    """A batch's trend windows counted from ``origin`` [rad] (the first reference angle
    of the input), and zeta [arcsec] at each window's first sample per head (``first_y``)."""

    grouping: Grouping
    origin: float
    first_y: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass
class Chunk:
    """At most :data:`~.tables.CHUNK_ROWS` rows of a batch, ready for the fits.

    ``ref`` the reference over the rows, ``sel`` the rows it covers (None: all);
    ``ref_rad`` [rad], ``ref_step`` [count], ``groups`` (runs), ``targets`` and
    ``counts`` (per head, integer counts as int64) at those rows; ``finite``: every
    reference angle is finite; ``windows`` (a continuous run with all of them finite).
    """

    batch: pa.RecordBatch
    ref: ReferenceReading
    sel: np.ndarray | None
    ref_rad: np.ndarray
    ref_step: np.ndarray | None
    groups: np.ndarray | None
    targets: np.ndarray | None
    counts: dict[str, np.ndarray]
    finite: bool
    windows: Windows | None = None


@dataclass
class Ready:
    """The chunks of one batch (:class:`Chunk`); ``num_rows`` as the batch's."""

    num_rows: int
    chunks: list[Chunk]


def _integer(c: np.ndarray) -> bool:
    """Counts the compiled kernel takes as int64 (no unsigned 64-bit)."""
    return c.dtype.kind in "iu" and c.dtype.itemsize <= 8 and c.dtype != np.uint64


class Preparer:
    """Called on each batch in order (on the reader thread), gives its :class:`Ready`;
    :meth:`finish` on each chunk in order (on the caller's thread) adds its windows.

    ``heads``: the heads whose counts are taken; ``reference``; ``window`` [rad] the trend
    window of a continuous run (None: none) and ``degree`` the trend's.
    """

    def __init__(self, schema: pa.Schema, heads: Sequence[str], reference: Reference,
                 window: float | None, degree: int) -> None:
        self.schema = schema
        self.heads = [h for h in dict.fromkeys(heads) if h in schema.names]
        self._scales: dict[str, float | None] = {}
        self.reference = reference
        self.has_run, self.has_target = "run" in schema.names, "target" in schema.names
        self.window, self.degree = window, degree
        self.origin: float | None = None
        self._windows = window is not None   # off when the first angles are not finite

    def __call__(self, batch: pa.RecordBatch) -> Ready:
        return Ready(batch.num_rows, [self.chunk(batch.slice(start, CHUNK_ROWS))
                                      for start in range(0, batch.num_rows, CHUNK_ROWS)])

    def chunk(self, batch: pa.RecordBatch) -> Chunk:
        """One chunk of a batch made ready."""
        ref = self.reference.read(batch)
        sel = None if ref.rows is None else np.flatnonzero(ref.rows)
        ref_rad, ref_step = ref.angle_rad, ref.step
        groups = column(batch, "run") if self.has_run else None
        targets = column(batch, "target") if self.has_target else None
        counts = {h: column(batch, h) for h in self.heads}
        if sel is not None:
            ref_rad = ref_rad[sel]
            ref_step = ref_step[sel] if ref_step is not None else None
            groups = groups[sel] if groups is not None else None
            targets = targets[sel] if targets is not None else None
            counts = {h: c[sel] for h, c in counts.items()}
        counts = {h: np.ascontiguousarray(c, dtype=np.int64) if _integer(c) else c
                  for h, c in counts.items()}
        finite = bool(np.isfinite(np.sum(ref_rad)))
        return Chunk(batch, ref, sel, ref_rad, ref_step, groups, targets, counts, finite)

    def finish(self, c: Chunk) -> Chunk:
        """The chunk with its trend windows, on the caller's thread (made on the reader
        thread they left it the longer of the two: measured, 3.1 s against 2.85 s at
        2000 revolutions on two cores)."""
        if self._windows and c.ref_rad.size:
            c.windows = self._windows_of(c)
        return c

    def _windows_of(self, c: Chunk) -> Windows | None:
        """The chunk's trend windows and first zeta of each head (None: not all finite)."""
        if not c.finite:
            if self.origin is None:
                self._windows = False   # the fits choose the origin among finite samples
            return None
        assert self.window is not None
        if self.origin is None:
            self.origin = float(c.ref_rad[0])
        g = window_grouping(c.ref_rad, c.groups, self.origin, self.window, self.degree)
        first_y = {}
        ref_first = c.ref_rad[g.first]
        for h, counts in c.counts.items():
            scale = self._scale(h)
            if counts.dtype == np.int64 and scale is not None:
                y = np.subtract(np.multiply(counts[g.first], scale, dtype=np.float64), ref_first)
                y /= ARCSEC
                first_y[h] = y
        return Windows(g, self.origin, first_y)


    def _scale(self, head: str) -> float | None:
        """A head's radians per count (None: its metadata is refused, which the caller's
        plan of the devices says in its turn)."""
        if head not in self._scales:
            try:
                self._scales[head] = TWO_PI / head_info(self.schema, head).counts_per_rev
            except DataError:
                self._scales[head] = None
        return self._scales[head]


def ready_batches(source: Any, prepare: Preparer) -> Iterator[Chunk]:
    """The chunks of ``source`` (a Table, or a stream whose reader thread prepares them)."""
    if hasattr(source, "to_batches"):
        for b in source.to_batches():
            for c in prepare(b).chunks:
                yield prepare.finish(c)
        return
    for ready in source.batches(prepare=prepare):
        for c in ready.chunks:
            yield prepare.finish(c)
