"""Columns by the naming rule of the stream kinds (enc-streams(5), NAMING).

- A column's unit is in its field metadata (``unit``), never in its name; a reader
  asks for the unit it computes in and :func:`column` converts from the one the
  stream names, so a stream of an older schema (points v1: ``position`` in deg) reads
  the same as a new one (rad).
- The standard uncertainty of a curve ``name`` is the column ``u_<name>`` with role
  ``uncertainty`` and field metadata ``of = name`` (:func:`uncertainty_name`); readers
  find it by ``of`` (:func:`uncertainty_columns`), not by its name.
"""

from __future__ import annotations

import numpy as np
import pyarrow as pa

from enctools.data.schemas import field_meta
from enctools.errors import DataError
from enctools.units import ANGLE_UNITS, factor, is_length

#: the prefix of an uncertainty column's name
UNCERTAINTY_PREFIX = "u_"


def uncertainty_name(name: str) -> str:
    """The name of the column holding the standard uncertainty of curve ``name``."""
    return UNCERTAINTY_PREFIX + name


def uncertainty_columns(schema: pa.Schema) -> dict[str, str]:
    """Curve name -> the uncertainty column that names it in its field metadata ``of``."""
    out: dict[str, str] = {}
    for f in schema:
        fm = field_meta(f)
        if fm.get("role") == "uncertainty" and "of" in fm:
            out.setdefault(fm["of"], f.name)
    return out


def column_unit(schema: pa.Schema, name: str) -> str | None:
    """The unit a column's field metadata names (None when it names none)."""
    return field_meta(schema.field(name)).get("unit")


def column(table: pa.Table, name: str, unit: str, source: str = "input",
           default_unit: str | None = None) -> np.ndarray:
    """Column ``name`` as float64 in ``unit``, converted from the unit of its field metadata.

    ``default_unit``: the unit of a column whose field metadata names none (else
    ``unit``). Angle units convert through :func:`enctools.units.factor`, and lengths
    (mm, um) through it too; other units must match. DataError with one line when the
    column is missing or its unit is not one that converts to ``unit``.
    """
    if name not in table.column_names:
        msg = f"{source}: no column {name!r}"
        raise DataError(msg)
    have = column_unit(table.schema, name) or default_unit or unit
    values = table.column(name).to_numpy(zero_copy_only=False).astype(np.float64)
    if have == unit:
        return values
    if (have in ANGLE_UNITS and unit in ANGLE_UNITS) or (is_length(have) and is_length(unit)):
        return values * factor(have, unit)
    msg = f"{source}: column {name!r} is in {have!r}; expected {unit!r}"
    raise DataError(msg)


def declared_unit(kind: str, meta: dict, name: str) -> str | None:
    """The unit the schema version a stream declares (metadata ``schema_version``) gives
    column ``name`` of ``kind``: what a column without ``unit`` in its field metadata
    is in (None when the kind names no such column; of several units, the first: points
    v4's position is rad, or mm only where its field metadata says so)."""
    from enctools.data.schemas import kind_spec

    try:
        version = int(meta.get("schema_version", 0))
    except (TypeError, ValueError, OverflowError):
        version = 0
    spec = kind_spec(kind, version if version >= 1 else None)
    col = spec.column(name)
    if col is None or not col.unit:
        return None
    return col.unit if isinstance(col.unit, str) else col.unit[0]
