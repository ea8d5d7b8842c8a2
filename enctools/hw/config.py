"""A rig file's backend tables as the instrument backends read them.

Unknown keys are refused naming the closest known one, values are type-checked, and
relative paths are taken relative to the rig file's folder.
"""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import Any

from enctools.data.rig import Rig
from enctools.errors import DataError


def check_keys(table: dict[str, Any], allowed: set[str], rig: Rig, where: str) -> None:
    """Reject unknown keys of a backend table, naming it and the closest known key."""
    for key in table:
        if key not in allowed:
            hint = difflib.get_close_matches(key, allowed, n=1)
            did = f"; did you mean {hint[0]!r}?" if hint else ""
            msg = f"rig file {rig.source}: unknown key {key!r} in [{where}]{did}"
            raise DataError(msg)


def need(table: dict[str, Any], key: str, types: type | tuple[type, ...], rig: Rig,
         where: str, default: Any = None) -> Any:
    """``table[key]`` checked against ``types``; ``default`` when absent (None: required)."""
    if key not in table:
        if default is None:
            msg = f"rig file {rig.source}: [{where}] needs the key {key!r}"
            raise DataError(msg)
        return default
    value = table[key]
    if isinstance(value, bool) and bool not in (types if isinstance(types, tuple) else (types,)):
        ok = False
    else:
        ok = isinstance(value, types)
    if not ok:
        msg = f"rig file {rig.source}: {where}.{key} has the wrong type: {value!r}"
        raise DataError(msg)
    return value


def rig_dir(rig: Rig) -> Path:
    """The folder of the rig file (relative paths in it are relative to it)."""
    src = rig.source
    if src.endswith("(bundled)"):
        return Path.cwd()
    return Path(src).resolve().parent
