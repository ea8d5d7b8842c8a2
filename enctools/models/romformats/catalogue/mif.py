"""Altera/Intel Memory Initialization File (WIDTH, DEPTH, HEX radix)."""

from __future__ import annotations

import re

from enctools.models.romformats import registry
from enctools.models.romformats.record import MEMORY, TableFormat, lazy

#: what only this format's content has (a file's first 4 KiB)
SIGNATURE = re.compile(rb"^\s*DEPTH\s*=\s*\d+\s*;", re.MULTILINE)

MIF = registry.register(TableFormat(
    "mif", "Altera/Intel Memory Initialization File", MEMORY, (".mif",),
    write_values=lazy(".writers", "write_mif"),
    read_values=lazy(".readers", "read_mif"),
    fast_read=lazy(".readers", "fast_mif"), signature=SIGNATURE, rank=30))
