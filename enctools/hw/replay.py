"""Replay: re-stream a recorded readings file, as fast as possible or at its pace.

The batches pass through untouched (zero-copy); with ``pace=True`` each batch is
held back until its last sample's time ``t`` [s] has elapsed since the start.
"""

from __future__ import annotations

from collections.abc import Iterator

import pyarrow as pa
import pyarrow.compute as pc

from enctools.data.streams import InputStream
from enctools.hw.base import Clock


def replay(stream: InputStream, pace: bool = False,
           clock: Clock | None = None) -> Iterator[pa.RecordBatch]:
    """The batches of a readings stream, optionally paced by its ``t`` column."""
    clock = clock or Clock()
    start = clock.now()
    t0: float | None = None
    for batch in stream.batches():
        if pace and batch.num_rows:
            t = batch.column(batch.schema.get_field_index("t"))
            if t0 is None:
                t0 = float(t[0].as_py())
            wait = (float(pc.max(t).as_py()) - t0) - (clock.now() - start)
            clock.sleep(wait)
        yield batch
