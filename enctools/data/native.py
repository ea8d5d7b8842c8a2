"""pyarrow's files opened by the bytes of their names: any name the file system takes.

A name that is not UTF-8 (a Latin-1 ``\\xe9.parquet``, legal on Linux) reaches Python as
text holding surrogates (PEP 383); pyarrow encodes a path as strict UTF-8 and fails on
it. Opened here by ``os.fsencode`` of the name, the same file is read and written.
"""

from __future__ import annotations

import os
from typing import Any

import pyarrow as pa

from enctools.data.limits import BATCH_BYTES

#: rows of a Parquet row group written (fewer when they are wide: BATCH_BYTES) [rows]
GROUP_ROWS = 65536

def native_file(path: str, mode: str = "r") -> pa.NativeFile:
    """``path`` opened as pyarrow's own file (``mode``: ``"r"`` or ``"w"``)."""
    return pa.OSFile(os.fsencode(path), mode=mode)


class ArrowWriter:
    """An Arrow IPC stream or file, or a Parquet file (``fmt``: ``arrows``, ``arrow`` or
    ``parquet``) written into the file named ``target`` (closed with the writer) or into
    the open file ``target`` (stdout, left open); the pyarrow writer protocol
    (``write_batch``, ``close``). Parquet's row groups are of :data:`GROUP_ROWS` rows or
    :data:`~enctools.data.limits.BATCH_BYTES` bytes, whatever the batches written."""

    def __init__(self, fmt: str, target: str | Any, schema: pa.Schema) -> None:
        # Parquet: batches held until GROUP_ROWS rows or BATCH_BYTES bytes make a row group
        self._groups: list[pa.RecordBatch] | None = [] if fmt == "parquet" else None
        self._held = self._rows = 0  # bytes and rows of the batches held
        self._file = native_file(target, "w") if isinstance(target, str) else None
        try:
            self._writer = _writer(fmt, target if self._file is None else self._file, schema)
        except BaseException:
            self.close_file()
            raise

    def write_batch(self, batch: pa.RecordBatch) -> None:
        if self._groups is None:
            self._writer.write_batch(batch)
            return
        self._groups.append(batch)
        self._held += batch.nbytes
        self._rows += batch.num_rows
        if self._held >= BATCH_BYTES or self._rows >= GROUP_ROWS:
            self._flush()

    def _flush(self) -> None:
        """The batches held as one Parquet row group: a closure run written a reading a
        batch would otherwise give a row group a row (129,600 and a 108 MB footer)."""
        if self._groups:
            groups, self._groups, self._held, self._rows = self._groups, [], 0, 0
            table = pa.Table.from_batches(groups)
            self._writer.write_table(table, row_group_size=table.num_rows)

    def close(self) -> None:
        try:
            self._flush()
            self._writer.close()
        finally:
            self.close_file()

    def close_file(self) -> None:
        """Close the file named (an open file given stays open)."""
        if self._file is not None:
            self._file.close()


def _writer(fmt: str, sink: Any, schema: pa.Schema) -> Any:
    if fmt == "arrows":
        return pa.ipc.new_stream(sink, schema)
    if fmt == "arrow":
        return pa.ipc.new_file(sink, schema)
    import pyarrow.parquet as pq  # here: it imports the file systems and ssl

    return pq.ParquetWriter(sink, schema)
