"""Intel HEX: the raw image, 16 data bytes a record, type 04 extended linear address
records (32-bit byte addresses: at most 4 GiB)."""

from __future__ import annotations

import re
from typing import Any

from enctools.errors import SettingsError
from enctools.models.romformats import registry
from enctools.models.romformats.record import MEMORY, TableFormat, lazy

#: Intel HEX's 32-bit byte addresses
IHEX_MAX_BYTES = 1 << 32


def check(target: Any, entries: int | None) -> None:
    """The image fits 32-bit byte addresses."""
    if entries is not None and entries * target.storage_bytes > IHEX_MAX_BYTES:
        msg = (f"ihex: {entries * target.storage_bytes} bytes exceed the 4 GiB of "
               "32-bit Intel HEX addresses")
        raise SettingsError(msg)


#: what only this format's content has (a file's first 4 KiB)
SIGNATURE = re.compile(rb"\A:[0-9A-F]{10,}\r?\n(?::[0-9A-F]{10,}\r?\n)*(?::00000001FF\s*)?\Z"
                       rb"|\A(?::[0-9A-F]{10,}\r?\n){4}")

IHEX = registry.register(TableFormat(
    "ihex", "Intel HEX of the raw image", MEMORY, (".hex", ".ihex"),
    write_values=lazy(".writers", "write_ihex"),
    read_values=lazy(".readers", "read_ihex"),
    fast_read=lazy(".readers", "fast_ihex"),
    layout_in="sidecar", binary=True, settings=frozenset({"endian"}),
    check=check, signature=SIGNATURE, rank=20))
