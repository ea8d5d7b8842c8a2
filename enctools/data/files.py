"""Output files that are not streams: the overwrite rule and a write that leaves nothing partial.

A command checks each file it will write with :func:`check_new_file` before doing any
work (so a refusal costs nothing), then writes it with :func:`write_atomic`: into a
temporary file in the same folder, renamed over the target only once complete, as NCO
does. An interrupted or failed write leaves the old file (or none) in place.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

from enctools.errors import UsageError


def check_new_file(path: str, force: bool) -> None:
    """UsageError unless ``path`` can be written: not a folder, absent or ``force``, in a
    folder that exists and is writable."""
    p = Path(path)
    if p.is_dir():
        msg = f"output {path}: is a directory; give a file name"
        raise UsageError(msg)
    if p.exists() and not force:
        msg = f"output {path} exists; use --force to replace it"
        raise UsageError(msg)
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        msg = f"output {path}: folder {parent} does not exist"
        raise UsageError(msg)
    if not os.access(parent, os.W_OK):
        msg = f"output {path}: folder {parent} is not writable"
        raise UsageError(msg)


def write_atomic(path: str | Path, data: bytes | Callable[[BinaryIO], None], *,
                 durable: bool = False, mode: int | None = None) -> None:
    """Write ``data`` (bytes, or a function writing to a binary file) to ``path`` atomically.

    The file gets ``mode`` (default: 0o666 less the umask, as ``open`` would give).
    ``durable``: fsync the file and its folder, so the file survives a power cut once
    this returns (history records).
    """
    p = Path(path)
    folder = p.parent if str(p.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=str(folder))
    try:
        with os.fdopen(fd, "wb") as f:
            if isinstance(data, bytes):
                f.write(data)
            else:
                data(f)
            if durable:
                f.flush()
                os.fsync(f.fileno())
        if mode is None:
            mask = os.umask(0)
            os.umask(mask)
            mode = 0o666 & ~mask
        os.chmod(tmp, mode)
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    if durable:
        try:  # make the rename itself durable
            dfd = os.open(str(folder), os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)
        except OSError:
            pass
