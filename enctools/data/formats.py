"""Which format a stream file or pipe holds: the order of authority (enc-streams(5), FORMATS).

1. What the user says (a command's format option): the caller's, before anything here.
2. A known extension (:data:`EXTENSIONS`): ``.parquet``, ``.h5``, ``.arrow``, ``.arrows``,
   ``.csv`` ... A CSV or TSV table's sidecar beside it makes it a text stream too.
3. The content, only where its signature is unambiguous: Parquet's ``PAR1`` at both ends
   (Apache Parquet file format), the Arrow IPC file's ``ARROW1`` at both ends (Arrow
   columnar format, IPC file format), HDF5's 8-byte signature at offset 0 (HDF5 file
   format specification, superblock).
4. An Arrow IPC stream, whose messages begin with the continuation marker ``FF FF FF FF``
   (Arrow columnar format, encapsulated message format): on a pipe, or in a file that
   claims nothing else (no extension of another format). Any raw image may begin with
   those bytes (a table whose first words are -1), so the marker never overrides a name.

On a pipe only the first bytes are seen before reading: the prefix decides
(:func:`detect_format`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import IO

from enctools.data import csvio

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
ARROWS_MARKER = b"\xff\xff\xff\xff"
#: first bytes of each format (on a pipe the prefix is all there is to go by)
MAGIC = {
    b"PAR1": "parquet",
    b"ARROW1": "arrow",
    ARROWS_MARKER: "arrows",
    HDF5_SIGNATURE: "hdf5",
}
#: the signatures a file carries at its end as well as its start
ENDS = {"parquet": b"PAR1", "arrow": b"ARROW1"}
EXTENSIONS = {".parquet": "parquet", ".pq": "parquet", ".h5": "hdf5", ".hdf5": "hdf5",
              ".arrow": "arrow", ".feather": "arrow", ".arrows": "arrows", ".ipc": "arrows",
              **csvio.EXTENSIONS}
FORMATS = ("arrows", "parquet", "arrow", "hdf5", *csvio.FORMATS)
#: the names of the formats in messages
NAMES = {"arrows": "an Arrow IPC stream", "parquet": "Parquet", "arrow": "an Arrow file",
         "hdf5": "HDF5", "csv": "CSV", "tsv": "TSV"}


def detect_format(prefix: bytes) -> str | None:
    """The format named by a stream's first bytes (a pipe's), or None."""
    for magic, fmt in MAGIC.items():
        if prefix.startswith(magic):
            return fmt
    return None


def signature(head: bytes, tail: bytes) -> str | None:
    """The format a file's first and last bytes name unambiguously, or None: ``PAR1`` or
    ``ARROW1`` at both ends, the HDF5 signature at the start. The Arrow stream's marker is
    not one (:func:`content_format`)."""
    if head.startswith(HDF5_SIGNATURE):
        return "hdf5"
    for fmt, magic in ENDS.items():
        if head.startswith(magic) and tail.endswith(magic) and len(head) >= len(magic):
            return fmt
    return None


def content_format(head: bytes, tail: bytes) -> str | None:
    """The format of a file that claims none by its name: its :func:`signature`, else an
    Arrow IPC stream when it begins with the continuation marker, else None."""
    return signature(head, tail) or ("arrows" if head.startswith(ARROWS_MARKER) else None)


def ends(f: IO[bytes], size: int = 8) -> tuple[bytes, bytes]:
    """The first and last ``size`` bytes of a seekable file (its position put back to 0)."""
    f.seek(0)
    head = f.read(size)
    f.seek(0, os.SEEK_END)
    length = f.tell()
    f.seek(max(0, length - size))
    tail = f.read(size)
    f.seek(0)
    return head, tail


def path_ends(path: str, size: int = 8) -> tuple[bytes, bytes]:
    """:func:`ends` of the file at ``path`` (OSError when it cannot be read)."""
    with open(path, "rb") as f:
        return ends(f, size)


def by_name(path: str) -> str | None:
    """The format a file's name claims: its extension's, or csv/tsv when a CSV or TSV
    table's sidecar is beside it; None when the name claims no stream format."""
    ext = EXTENSIONS.get(Path(path).suffix.lower())
    return ext or csvio.text_format(path)


def file_format(path: str, f: IO[bytes]) -> str | None:
    """A seekable file's format by the order of authority: its name (:func:`by_name`),
    else its content (:func:`content_format`); None when neither says."""
    return by_name(path) or content_format(*ends(f))


def mismatch(fmt: str, head: bytes, tail: bytes) -> str:
    """What to add to the refusal of a file named as ``fmt`` that does not decode as one:
    the format its content has, when that differs (empty otherwise)."""
    found = content_format(head, tail)
    if found is None or found == fmt:
        return ""
    ext = next(e for e, f in EXTENSIONS.items() if f == found)
    return (f"; its content is {NAMES[found]}: name it {ext}, or pipe it in (< FILE), "
            "as the name decides a file's format")
