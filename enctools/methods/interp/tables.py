"""Readings as the interpolation check takes them: columns as numpy, batches, a bounded whole.

The reference mode streams its input in chunks of :data:`CHUNK_ROWS`; the modes
that need the whole input (signals mode, a reference file matched by time) read at
most :data:`MAX_SWEEP_SAMPLES` rows.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyarrow as pa

from enctools.errors import DataError

#: --signals, --corrected and --ref-file read their input whole; longer inputs are refused
MAX_SWEEP_SAMPLES = 1_000_000

#: rows handed to the fit at once (bounds the temporaries of a large batch)
CHUNK_ROWS = 1 << 16


def read_sweep(source: Any, max_samples: int = MAX_SWEEP_SAMPLES,
               why: str = "the signals mode") -> pa.Table:
    """All of a stream's readings as one Arrow table, refusing more than ``max_samples`` rows.

    The modes that need the whole table (``why``: the Heydemann fit of the signals mode,
    a reference file matched by time) read at most this many rows; a longer input
    is refused at the first batch past it, before it fills the memory. The
    reference mode proper streams (:func:`enctools.methods.interp.readings.check_readings`).
    """
    batches = []
    rows = 0
    for b in source.batches():
        rows += b.num_rows
        if rows > max_samples:
            source.close()
            msg = (f"{source.source}: more than {max_samples:,} samples; {why} reads its input "
                   "whole: record fewer revolutions or a sweep, "
                   "or check against a reference in the same stream (`reference` HEAD or probes)")
            raise DataError(msg)
        batches.append(b)
    return pa.Table.from_batches(batches, schema=source.schema)


def column(table: pa.Table | pa.RecordBatch, name: str) -> np.ndarray:
    """A column as numpy: int64 stays integer (counts), the rest float64 (nulls -> NaN)."""
    col = table.column(name)
    if pa.types.is_integer(col.type) and col.null_count == 0:
        return col.to_numpy()
    return col.cast(pa.float64()).to_numpy(zero_copy_only=False)
