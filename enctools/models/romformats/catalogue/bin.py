"""Raw two's-complement words, little or big endian, 1, 2 or 4 bytes each."""

from __future__ import annotations

from typing import Any

from enctools.errors import SettingsError
from enctools.models.romformats import registry
from enctools.models.romformats.record import MEMORY, TableFormat, lazy


def check(target: Any, entries: int | None) -> None:
    """The byte order is one of the two."""
    if target.endian not in ("little", "big"):
        msg = f"`endian` must be little or big, not {target.endian!r}"
        raise SettingsError(msg)


BIN = registry.register(TableFormat(
    "bin", "raw two's-complement words", MEMORY, (".bin", ".rom"),
    write_values=lazy(".writers", "write_bin"),
    read_values=lazy(".readers", "read_bin"),
    layout_in=None, binary=True, settings=frozenset({"endian"}),
    check=check, rank=10))
