"""The folder layout of the nightly history dataset: Hive partitions ``rig=NAME/year=YYYY``.

One folder per rig and UTC year, the way DuckDB, Spark and ``pyarrow.dataset`` read a
partitioned Parquet dataset: the rig and the year live in the folder names, not in the
files. A rig name is percent-encoded (``urllib.parse.quote`` with no safe character, so
``/``, ``=``, ``%`` and spaces become ``%2F``, ``%3D``, ``%25``, ``%20``), which those
engines decode back. Kept free of numpy and pyarrow: ``enc-nightly`` checks its
rig's name here before anything heavy is imported.
"""

from __future__ import annotations

from pathlib import Path
from urllib.parse import quote

#: longest encoded rig folder name [bytes]; file systems allow 255 per name
RIG_FOLDER_MAX = 200


def rig_folder(rig: str) -> str:
    """The partition folder name of ``rig``: ``rig=`` and its percent-encoded name.

    An empty name, or one whose folder name would exceed :data:`RIG_FOLDER_MAX`
    bytes, is refused (``ValueError``, said as the caller's option).
    """
    if not rig:
        msg = "a rig name must not be empty"
        raise ValueError(msg)
    name = "rig=" + quote(rig, safe="")
    if len(name.encode()) > RIG_FOLDER_MAX:
        msg = (f"the rig name {rig[:40]!r}... makes a history folder name of "
               f"{len(name.encode())} bytes; at most {RIG_FOLDER_MAX}")
        raise ValueError(msg)
    return name


def partition_folder(root: str | Path, rig: str, year: int) -> Path:
    """The folder of one rig's runs of one UTC year: ``ROOT/rig=NAME/year=YYYY``."""
    return Path(root) / rig_folder(rig) / f"year={year:04d}"
