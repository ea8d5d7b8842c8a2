"""Xilinx coefficient file (memory_initialization_radix=16;
memory_initialization_vector=...;)."""

from __future__ import annotations

from enctools.models.romformats import registry
from enctools.models.romformats.record import MEMORY, TableFormat, lazy

COE = registry.register(TableFormat(
    "coe", "Xilinx coefficient file", MEMORY, (".coe",),
    write_values=lazy(".writers", "write_coe"),
    read_values=lazy(".readers", "read_coe"),
    fast_read=lazy(".readers", "fast_coe"), rank=40))
