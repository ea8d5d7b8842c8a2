"""``address,correction`` in decimal, header line first, no comments (its layout in a
sidecar)."""

from __future__ import annotations

import re

from enctools.models.romformats import registry
from enctools.models.romformats.record import MEMORY, TableFormat, lazy

#: what only this format's content has (a file's first 4 KiB)
SIGNATURE = re.compile(rb"\Aaddress,correction\r?\n")

CSV = registry.register(TableFormat(
    "csv", "address,correction in decimal", MEMORY, (".csv",),
    write_values=lazy(".csvtext", "write_csv"),
    read_values=lazy(".readers", "read_csv"), layout_in="sidecar", signature=SIGNATURE, rank=60))
