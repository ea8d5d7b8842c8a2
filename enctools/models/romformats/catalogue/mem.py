"""Verilog ``$readmemh`` text: one hex word a line, // comments."""

from __future__ import annotations

from enctools.models.romformats import registry
from enctools.models.romformats.record import MEMORY, TableFormat, lazy

MEM = registry.register(TableFormat(
    "mem", "Verilog $readmemh text", MEMORY, (".mem",),
    write_values=lazy(".writers", "write_mem"),
    read_values=lazy(".readers", "read_mem"),
    fast_read=lazy(".readers", "fast_mem"), rank=50))
