"""Verilog ``$readmemh`` text: one hex word a line, // comments."""

from __future__ import annotations

import re

from enctools.models.romformats import registry
from enctools.models.romformats.record import MEMORY, TableFormat, lazy

#: what only this format's content has (a file's first 4 KiB)
SIGNATURE = re.compile(rb"\A(?://[^\n]*\n)+@0+\s*\n")

MEM = registry.register(TableFormat(
    "mem", "Verilog $readmemh text", MEMORY, (".mem",),
    write_values=lazy(".writers", "write_mem"),
    read_values=lazy(".readers", "read_mem"),
    fast_read=lazy(".readers", "fast_mem"), signature=SIGNATURE, rank=50))
