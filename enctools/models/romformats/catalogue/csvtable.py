"""``address,correction`` in decimal, header line first, no comments (its layout in a
sidecar)."""

from __future__ import annotations

from enctools.models.romformats import registry
from enctools.models.romformats.record import MEMORY, TableFormat, lazy

CSV = registry.register(TableFormat(
    "csv", "address,correction in decimal", MEMORY, (".csv",),
    write_values=lazy(".csvtext", "write_csv"),
    read_values=lazy(".readers", "read_csv"), rank=60))
