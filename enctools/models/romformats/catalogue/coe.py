"""Xilinx coefficient file (memory_initialization_radix=16;
memory_initialization_vector=...;)."""

from __future__ import annotations

import re

from enctools.models.romformats import registry
from enctools.models.romformats.record import MEMORY, TableFormat, lazy

#: what only this format's content has (a file's first 4 KiB)
SIGNATURE = re.compile(rb"^\s*memory_initialization_radix\s*=", re.MULTILINE | re.IGNORECASE)

COE = registry.register(TableFormat(
    "coe", "Xilinx coefficient file", MEMORY, (".coe",),
    write_values=lazy(".writers", "write_coe"),
    read_values=lazy(".readers", "read_coe"),
    fast_read=lazy(".readers", "fast_coe"), signature=SIGNATURE, rank=40))
