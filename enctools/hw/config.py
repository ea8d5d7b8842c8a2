"""A rig file's backend tables as the instrument backends read them.

Unknown keys are refused naming the closest known one, values are type-checked, and
relative paths are taken relative to the rig file's folder.
"""

from __future__ import annotations

import difflib
import math
import re
import string
from pathlib import Path
from typing import Any

from enctools.data.rig import Rig
from enctools.data.riglimits import MAX_TEMPLATE_WIDTH, fmt
from enctools.errors import DataError


def check_keys(table: dict[str, Any], allowed: set[str], rig: Rig, where: str) -> None:
    """Reject unknown keys of a backend table, naming it and the closest known key."""
    for key in table:
        if key not in allowed:
            hint = difflib.get_close_matches(key, allowed, n=1)
            did = f"; did you mean {hint[0]!r}?" if hint else ""
            msg = f"rig file {rig.source}: unknown key {key!r} in [{where}]{did}"
            raise DataError(msg)


#: the ranges of the numbers of the backend tables (enc-rig(5) LIMITS): key -> (least,
#: greatest), bounds included
BACKEND_RANGES: dict[str, tuple[float, float]] = {
    "timeout_s": (0.001, 3600.0), "retries": (0, 100), "poll_s": (0.001, 60.0),
    "move_timeout_s": (0.001, 86400.0), "buffer_s": (0.01, 3600.0), "field": (0, 1000),
    "scale": (-1e12, 1e12), "offset": (-1e12, 1e12),
}


def need(table: dict[str, Any], key: str, types: type | tuple[type, ...], rig: Rig,
         where: str, default: Any = None) -> Any:
    """``table[key]`` checked against ``types`` (and a number against its range in
    :data:`BACKEND_RANGES`); ``default`` when absent (None: required)."""
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
    if key in BACKEND_RANGES and isinstance(value, int | float):
        lo, hi = BACKEND_RANGES[key]
        if not (math.isfinite(value) and lo <= value <= hi):
            msg = (f"rig file {rig.source}: {where}.{key} must be {fmt(lo)}..{fmt(hi)}, "
                   f"not {fmt(value)}")
            raise DataError(msg)
    return value


def rig_dir(rig: Rig) -> Path:
    """The folder of the rig file (relative paths in it are relative to it)."""
    src = rig.source
    if src.endswith("(bundled)"):
        return Path.cwd()
    return Path(src).resolve().parent


#: a format spec (Python's mini-language): [[fill]align][sign][z][#][0][width][grouping]
#: [.precision][type]; the digits of width and precision are taken apart
_SPEC = re.compile(r"(?:.?[<>=^])?[-+ ]?z?#?0?(?P<width>[0-9]*)[,_]?"
                   r"(?:\.(?P<precision>[0-9]*))?[a-zA-Z%]?", re.DOTALL)


def spec_size(spec: str) -> int:
    """The larger of the width and the precision a format spec declares (0: none); a
    spec that is not of the mini-language counts 0 (formatting it then fails)."""
    m = _SPEC.fullmatch(spec)
    if m is None:
        return 0
    return max(_digits(m["width"]), _digits(m["precision"]))


def _digits(text: str | None) -> int:
    """The number ``text`` spells (0 when empty), 10^18 for more than 18 digits."""
    return int(text) if text and len(text) <= 18 else (10**18 if text else 0)


def check_template(tpl: str, fields: dict[str, Any], rig: Rig, where: str) -> None:
    """Refuse a command template reaching beyond its plain fields (DataError, one line).

    ``fields``: the allowed names with a sample value each. A field may be only one of
    these names with an optional format spec (``{deg:.4f}``): no attribute or item
    access (``{counts.real}``, ``{x[0]}``), conversion (``!r``), nested or positional
    field, so a rig file cannot make a command out of the values' internals.
    """
    allowed = ", ".join("{" + k + "}" for k in fields)
    rule = (f"allowed fields: {allowed} (plain names, with an optional format spec "
            "such as {deg:.4f})")
    head = f"rig file {rig.source}: {where}: template {tpl!r}"
    try:
        parts = list(string.Formatter().parse(tpl))
    except ValueError as exc:
        msg = f"{head} is not valid ({exc}); {rule}"
        raise DataError(msg) from None
    for _text, name, spec, conv in parts:
        if name is None:
            continue
        bad = "{" + name + (f"!{conv}" if conv else "") + (f":{spec}" if spec else "") + "}"
        if name not in fields or conv is not None or "{" in (spec or ""):
            msg = f"{head} has the field {bad}; {rule}"
            raise DataError(msg)
        if spec_size(spec or "") > MAX_TEMPLATE_WIDTH:
            size = spec_size(spec or "")
            msg = (f"rig file {rig.source}: {where}: the field {bad[:40]!r} declares a width "
                   f"or precision of {size if size < 10**18 else '10^18 or more'}, more "
                   f"than {MAX_TEMPLATE_WIDTH}")
            raise DataError(msg)
    try:
        tpl.format(**fields)
    except (KeyError, ValueError, IndexError, TypeError) as exc:
        msg = f"{head} is not valid ({type(exc).__name__}: {exc}); {rule}"
        raise DataError(msg) from None
