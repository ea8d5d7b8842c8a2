"""A user's table opened from a path: text, or Parquet/Arrow/HDF5 without enctools metadata.

What a command that takes "a table or a stream" opens before the method sees it:
:func:`is_table_file` tells a user's table from a stream by its bytes and its sidecar,
:func:`read` reads a table as named columns (:class:`~enctools.data.tables.RawTable`),
and :func:`open_input` opens either, so the methods take what was opened and never a
path (:mod:`enctools.methods.points`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from enctools.data.streams import InputStream
    from enctools.data.tables import RawTable

__all__ = ["UserTable", "is_table_file", "open_input", "read"]


@dataclass
class UserTable:
    """A user's table as read: its columns and where it came from (``source``: its path)."""

    raw: RawTable
    source: str


def is_table_file(path: str | None) -> bool:
    """Whether ``path`` names a user's table, not a stream: a regular file of text
    without a sidecar, or a Parquet, Arrow or HDF5 table without enctools metadata.

    A stream starts with its format's magic bytes and carries enctools metadata, or is a
    CSV or TSV table with its enctools sidecar (read as a stream, see enc-streams(5); a
    CSVW sidecar another program wrote, without enctools' part, leaves it a table); stdin
    (None, "-") and pipes are streams (a pipe can be read once only). An unreadable path
    is not a table: opening it as a stream then says what is wrong.
    """
    import os
    import stat

    from enctools.data.csvio import sidecar_path
    from enctools.data.streams import detect_format
    from enctools.data.tables import is_plain

    if path is None or path == "-" or (os.path.exists(sidecar_path(path)) and
                                       _enctools_sidecar(path)):
        return False
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return False
        with open(path, "rb") as f:
            head = f.read(8)
    except OSError:
        return False
    if not head:
        return False
    fmt = detect_format(head)
    return fmt is None or is_plain(path, fmt)


def _enctools_sidecar(path: str) -> bool:
    """Whether the sidecar beside ``path`` is enctools' (it has an ``enctools`` part), or
    cannot be read (then opening the stream says why)."""
    from enctools.data.csvio import read_sidecar
    from enctools.errors import DataError

    try:
        doc = read_sidecar(path)
    except DataError:
        return True
    return not isinstance(doc, dict) or "enctools" in doc


def read(path: str, decimal_comma: bool = False) -> UserTable:
    """The table at ``path``: text (``#`` comments, any header; ``decimal_comma``: a
    comma is a number's decimal mark) or, by its magic bytes, Parquet, Arrow or HDF5
    read as named columns."""
    from enctools.data.streams import detect_format
    from enctools.data.tables import read_binary, read_text

    source = str(path)
    with open(source, "rb") as f:
        fmt = detect_format(f.read(8))
    return UserTable(read_text(source, decimal_comma) if fmt is None else
                     read_binary(source, fmt), source)


def open_input(path: str | None, kind: str, decimal_comma: bool = False
               ) -> UserTable | InputStream:
    """A user's table when ``path`` is one (:func:`is_table_file`; ``decimal_comma``: as
    :func:`read`), else the stream of ``kind`` at ``path`` (None, "-": stdin)."""
    from enctools.data import streams

    if path is not None and is_table_file(path):
        return read(path, decimal_comma)
    return streams.open_input(path, kind)
