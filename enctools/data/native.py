"""pyarrow's files opened by the bytes of their names: any name the file system takes.

A name that is not UTF-8 (a Latin-1 ``\\xe9.parquet``, legal on Linux) reaches Python as
text holding surrogates (PEP 383); pyarrow encodes a path as strict UTF-8 and fails on
it. Opened here by ``os.fsencode`` of the name, the same file is read and written.
"""

from __future__ import annotations

import os
from typing import Any

import pyarrow as pa


def native_file(path: str, mode: str = "r") -> pa.NativeFile:
    """``path`` opened as pyarrow's own file (``mode``: ``"r"`` or ``"w"``)."""
    return pa.OSFile(os.fsencode(path), mode=mode)


class ArrowWriter:
    """An Arrow IPC stream or file, or a Parquet file (``fmt``: ``arrows``, ``arrow`` or
    ``parquet``) written into the file named ``target`` (closed with the writer) or into
    the open file ``target`` (stdout, left open); the pyarrow writer protocol
    (``write_batch``, ``close``)."""

    def __init__(self, fmt: str, target: str | Any, schema: pa.Schema) -> None:
        self._file = native_file(target, "w") if isinstance(target, str) else None
        try:
            self._writer = _writer(fmt, target if self._file is None else self._file, schema)
        except BaseException:
            self.close_file()
            raise

    def write_batch(self, batch: pa.RecordBatch) -> None:
        self._writer.write_batch(batch)

    def close(self) -> None:
        try:
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
