"""Altera/Intel Memory Initialization File (WIDTH, DEPTH, HEX radix)."""

from __future__ import annotations

from enctools.models.romformats import registry
from enctools.models.romformats.record import MEMORY, TableFormat, lazy

MIF = registry.register(TableFormat(
    "mif", "Altera/Intel Memory Initialization File", MEMORY, (".mif",),
    write_values=lazy(".writers", "write_mif"),
    read_values=lazy(".readers", "read_mif"),
    fast_read=lazy(".readers", "fast_mif"), rank=30))
