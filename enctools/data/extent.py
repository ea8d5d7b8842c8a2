"""Where a file says it ends, against where it ends: one file read, not two.

A Parquet or Arrow file is found from its end (the footer), an HDF5 file from its start
(the superblock). A reader that trusts only one end takes two files written one after
the other (``cat a.parquet b.parquet``), or a file with bytes after its end, for one
file, and reads part of it in silence. Each check here compares what the file's own
structure says with the file's size, reading only its metadata (a Parquet file's
unaccounted bytes excepted, in blocks), and raises a DataError naming the source.
"""

from __future__ import annotations

import io
import os
import struct
from typing import IO, Any

import pyarrow as pa

from enctools.data.limits import check_row_group
from enctools.errors import DataError

#: the bytes read at a time where a file's unaccounted bytes are searched [bytes]
BLOCK = 1 << 20


def _size(f: IO[bytes]) -> int:
    return len(f.getbuffer()) if isinstance(f, io.BytesIO) else os.fstat(f.fileno()).st_size


def _read_at(f: IO[bytes], offset: int, n: int) -> bytes:
    f.seek(offset)
    return f.read(n)


def _two_files(source: str, fmt: str, what: str) -> DataError:
    return DataError(f"{source}: {what}: two {fmt} files one after the other, or bytes after "
                     "the end of one; a command reads one file")


def check_parquet(f: IO[bytes], metadata: Any, source: str, groups: bool = False) -> None:
    """DataError unless the Parquet file ``f`` (its ``metadata``, pyarrow's FileMetaData)
    is one file: the column chunks the footer names end before the footer, and between
    them no Parquet file ends and another begins (``PAR1PAR1``). ``groups``: each row
    group within :func:`~enctools.data.limits.check_row_group`'s limits too, in the same
    walk over the footer's row groups."""
    size = _size(f)
    (footer_len,) = struct.unpack("<I", _read_at(f, size - 8, 4))
    footer_start = size - 8 - footer_len
    end = 4
    for i in range(metadata.num_row_groups):
        group = metadata.row_group(i)
        if groups:
            check_row_group(group, source)
        for j in range(group.num_columns):
            c = group.column(j)
            start = c.dictionary_page_offset if c.has_dictionary_page else c.data_page_offset
            end = max(end, (start or c.data_page_offset) + c.total_compressed_size)
    if end > footer_start:
        raise _two_files(source, "Parquet", "the footer names data past its own start")
    pos = end
    while pos < footer_start:  # the page indexes and bloom filters, if any: small
        block = _read_at(f, pos, min(BLOCK + 7, footer_start - pos))
        if b"PAR1PAR1" in block:
            raise _two_files(source, "Parquet", "a Parquet file ends and another begins")
        pos += BLOCK


def check_arrow_file(f: IO[bytes], source: str) -> None:
    """DataError unless the messages of the Arrow file ``f`` end where its footer begins
    (a second file after the first: its footer is read, the first file's messages)."""
    size = _size(f)
    (footer_len,) = struct.unpack("<i", _read_at(f, size - 10, 4))
    footer_start = size - 10 - footer_len
    whole = (pa.BufferReader(f.getvalue()) if isinstance(f, io.BytesIO)
             else pa.memory_map(os.fsencode(f.name)))  # messages' bodies not read
    try:
        whole.seek(8)
        reader = pa.ipc.MessageReader.open_stream(whole)
        while whole.tell() < footer_start:
            try:
                reader.read_next_message()
            except StopIteration:  # the end-of-stream marker
                break
        if whole.tell() != footer_start:
            raise _two_files(source, "Arrow", f"its messages end at byte {whole.tell()}, "
                             f"its footer begins at byte {footer_start}")
    finally:
        whole.close()


#: an HDF5 file's signature, at its start
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def hdf5_end(head: bytes) -> int | None:
    """Where the HDF5 file whose first bytes are ``head`` (64 or more) ends, by its
    superblock: base address + end-of-file address [bytes]; None for a superblock
    version this does not know (HDF5 File Format Specification, "Superblock")."""
    if len(head) < 64 or not head.startswith(HDF5_SIGNATURE):
        return None
    version = head[8]
    if version in (0, 1):
        offsets, at = head[13], 24 if version == 0 else 28
    elif version in (2, 3):
        offsets, at = head[9], 12
    else:
        return None
    if offsets not in (2, 4, 8):
        return None
    base = int.from_bytes(head[at:at + offsets], "little")
    eof = int.from_bytes(head[at + 2 * offsets:at + 3 * offsets], "little")
    return base + eof


def check_hdf5(f: IO[bytes], source: str) -> None:
    """DataError when the HDF5 file ``f`` is longer than its superblock says: a second
    file, or other bytes, after its end (HDF5 itself reads such a file without a word).
    Shorter is left to HDF5, which refuses a truncated file."""
    size = _size(f)
    end = hdf5_end(_read_at(f, 0, 64))
    f.seek(0)
    if end is not None and end < size:
        raise _two_files(source, "HDF5", f"{size - end} bytes after its end at byte {end}")
