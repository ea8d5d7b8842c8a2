"""Stream kinds: the versioned schema files in ``schemas/`` and validation against them.

A kind names its columns either by ``name`` or by ``role`` (a field-metadata key, so
that a kind can have any number of head or curve columns). Validation checks the
kind and version in the metadata, the presence, type and unit of every column, the
field metadata each role needs, and the required metadata keys; it raises
:class:`~enctools.errors.DataError` with one line naming what does not fit.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa

from enctools.data import limits
from enctools.errors import DataError

KINDS = ("readings", "deviations", "spectrum", "points", "model", "rom")


@dataclass(frozen=True)
class ColumnSpec:
    """One column (by name) or a family of columns (by role) of a kind."""

    type: str
    unit: str | tuple[str, ...]  # several: any of them (an uncertainty has its curve's unit)
    name: str | None = None
    role: str | None = None
    required: bool = False
    min: int = 0
    field_metadata: tuple[str, ...] = ()
    description: str = ""


@dataclass(frozen=True)
class KindSpec:
    """A stream kind as described by its schema file."""

    kind: str
    version: int
    description: str
    columns: tuple[ColumnSpec, ...]
    required_meta: tuple[str, ...]

    def column(self, name: str) -> ColumnSpec | None:
        return next((c for c in self.columns if c.name == name), None)

    def role(self, role: str) -> ColumnSpec | None:
        return next((c for c in self.columns if c.role == role), None)


def _schema_dir() -> Path:
    """Where the schema files are: inside the wheel, else the source tree's schemas/."""
    package = Path(__file__).resolve().parent.parent  # enctools/
    packaged = package / "schemas"  # as importlib.resources would find it, without its import cost
    return packaged if packaged.is_dir() else package.parent / "schemas"


@functools.cache
def kind_spec(kind: str, version: int | None = None) -> KindSpec:
    """The schema of a kind: the newest, or the one of ``version`` when that file exists.

    Streams of an older version are read as they were written: each column in the
    unit its field metadata names (:func:`enctools.data.columns.column` converts it).
    """
    if kind not in KINDS:
        msg = f"unknown stream kind {kind!r} (kinds: {', '.join(KINDS)})"
        raise DataError(msg)
    files = sorted(_schema_dir().glob(f"{kind}.v*.json"),
                   key=lambda p: int(p.name.split(".v")[1].split(".")[0]))
    chosen = [p for p in files if p.name == f"{kind}.v{version}.json"]
    raw: dict[str, Any] = json.loads((chosen or files)[-1].read_text())
    cols = tuple(ColumnSpec(type=c["type"], unit=_units(c.get("unit", "")), name=c.get("name"),
                            role=c.get("role"), required=c.get("required", False),
                            min=c.get("min", 0), field_metadata=tuple(c.get("field_metadata", ())),
                            description=c.get("description", ""))
                 for c in raw["columns"])
    return KindSpec(raw["kind"], int(raw["version"]), raw["description"], cols,
                    tuple(raw["metadata"]["required"]))


def _units(unit: str | list[str]) -> str | tuple[str, ...]:
    return unit if isinstance(unit, str) else tuple(unit)


def field_meta(field: pa.Field) -> dict[str, str]:
    """A field's metadata as str -> str."""
    return {k.decode(): v.decode() for k, v in (field.metadata or {}).items()}


def make_field(name: str, type_: pa.DataType, unit: str, role: str | None = None,
               **meta: Any) -> pa.Field:
    """A field with enctools field metadata (unit, role and role keys, as strings)."""
    md = {"unit": unit}
    if role:
        md["role"] = role
    md.update({k: str(v) for k, v in meta.items()})
    return pa.field(name, type_, metadata=md)


def _type_ok(want: str, t: pa.DataType) -> bool:
    if want == "float":
        return pa.types.is_floating(t)
    if want == "int":
        return pa.types.is_integer(t)
    if want == "string":
        return pa.types.is_string(t) or pa.types.is_large_string(t)
    return False


def validate(schema: pa.Schema, meta: dict[str, Any], expect: str | tuple[str, ...] | None,
             source: str) -> str:
    """Check a stream header against its kind; return the kind.

    ``expect``: the kind(s) the caller accepts (None accepts any). ``source`` names
    the input in messages.
    """
    spec = _header_kind(meta, expect, source)
    kind = spec.kind
    if len(schema) > limits.MAX_COLUMNS:
        msg = f"{source}: {len(schema)} columns; at most {limits.MAX_COLUMNS} are read"
        raise DataError(msg)
    check_identifiers(schema, meta, source)
    names = set(schema.names)
    if len(names) < len(schema):
        twice = next(n for n in schema.names if schema.names.count(n) > 1)
        msg = f"{source}: column {twice!r} appears twice; which one is meant cannot be told"
        raise DataError(msg)
    for col in spec.columns:
        if col.required and col.name not in names:
            msg = f"{source}: {kind} stream lacks the required column {col.name!r}"
            raise DataError(msg)
    role_counts: dict[str, int] = {}
    for f in schema:
        role = field_meta(f).get("role")
        if spec.column(f.name) is None and role is not None:
            role_counts[role] = role_counts.get(role, 0) + 1
        _check_column(f, schema, spec, source)
    for col in spec.columns:
        if col.role and role_counts.get(col.role, 0) < col.min:
            msg = f"{source}: {kind} stream has no {col.role} column"
            raise DataError(msg)
    for key in spec.required_meta:
        if key not in meta:
            msg = f"{source}: {kind} stream lacks the metadata key {key!r}"
            raise DataError(msg)
    _check_meta_types(meta, source)
    return kind


#: the names and numbers of a stream's metadata (enc-streams(5)), as paths of keys ("*":
#: every item of an array), and the field metadata that names an encoder or a head (a
#: column's own name is text a person may give, --name: shown escaped, not refused)
_META_IDENTIFIERS = (("rig", "name"), ("rig", "encoders", "*", "name"),
                     ("rig", "encoders", "*", "model"),
                     ("rig", "encoders", "*", "heads", "*", "name"),
                     ("rig", "encoders", "*", "measure_heads", "*"),
                     ("rig", "probes", "*", "name"), ("rig", "autocollimator", "name"),
                     ("rig", "motion", "feedback"), ("polygon_certificate", "certificate"))
_FIELD_IDENTIFIERS = ("encoder", "head")


def check_identifiers(schema: pa.Schema, meta: dict[str, Any], source: str) -> None:
    """The names in field metadata and the metadata's names and numbers
    (:data:`_META_IDENTIFIERS`) hold no character that reads other than it is
    (:func:`enctools.data.text.check_identifier`): a DataError naming the one found."""
    from enctools.data.text import check_identifier

    for f in schema:
        fm = field_meta(f)
        for key in _FIELD_IDENTIFIERS:
            if key in fm:
                check_identifier(fm[key], f"{source}: column {f.name!r}: field metadata {key}")
    for path in _META_IDENTIFIERS:
        for where, value in _at(meta, path, "metadata "):
            if isinstance(value, str):
                check_identifier(value, f"{source}: {where}")


def _at(node: Any, path: tuple[str, ...], where: str) -> list[tuple[str, Any]]:
    """The values at ``path`` in ``node``, each with where it is (``rig.encoders[0].name``)."""
    if not path:
        return [(where, node)]
    key, rest = path[0], path[1:]
    if key == "*":
        items = node if isinstance(node, list) else []
        return [found for i, item in enumerate(items)
                for found in _at(item, rest, f"{where}[{i}]")]
    if not isinstance(node, dict) or key not in node:
        return []
    return _at(node[key], rest, f"{where}{'' if where.endswith(' ') else '.'}{key}")


#: metadata keys whose values are JSON objects (tables of named values) in every kind
_OBJECT_META = ("rig", "settings", "truth", "model", "rom")


def _check_meta_types(meta: dict[str, Any], source: str) -> None:
    """The metadata's tables are objects and its history a list of lines (enc-streams(5))."""
    for key in _OBJECT_META:
        if key in meta and not isinstance(meta[key], dict):
            msg = (f"{source}: metadata {key!r} must be an object, "
                   f"not {type(meta[key]).__name__}")
            raise DataError(msg)
    history = meta.get("history", [])
    if not (isinstance(history, list) and all(isinstance(x, str) for x in history)):
        msg = f"{source}: metadata 'history' must be a list of lines"
        raise DataError(msg)


def _header_kind(meta: dict[str, Any], expect: str | tuple[str, ...] | None,
                 source: str) -> KindSpec:
    """The spec of the kind a header names, once it is one the caller reads and not newer
    than this enctools reads."""
    kind = meta.get("kind")
    if kind is None:
        msg = f"{source}: not an enctools stream (no 'kind' in its metadata)"
        raise DataError(msg)
    if isinstance(expect, str):
        expect = (expect,)
    if expect is not None and kind not in expect:
        msg = f"{source}: is a {kind} stream; this command reads {' or '.join(expect)}"
        raise DataError(msg)
    spec = kind_spec(kind)
    try:
        version = int(meta.get("schema_version", 0))
    except (TypeError, ValueError, OverflowError):
        msg = (f"{source}: schema_version must be a whole number, not "
               f"{str(meta.get('schema_version'))[:40]!r}")
        raise DataError(msg) from None
    if version > spec.version:
        msg = (f"{source}: {kind} schema version {version} is newer than this enctools "
               f"reads ({spec.version}); upgrade enctools")
        raise DataError(msg)
    return kind_spec(kind, version) if version >= 1 else spec


def _check_column(f: pa.Field, schema: pa.Schema, spec: KindSpec, source: str) -> None:
    """One column against its kind: known (by name or role), type, unit, field metadata."""
    kind = spec.kind
    fm = field_meta(f)
    role = fm.get("role")
    col = spec.column(f.name)
    if col is None and role is not None:
        col = spec.role(role)
        if col is None:
            msg = f"{source}: column {f.name!r} has role {role!r}, unknown to kind {kind}"
            raise DataError(msg)
    if col is None:
        known = [c.name for c in spec.columns if c.name]
        msg = (f"{source}: column {f.name!r} is not part of a {kind} stream "
               f"(columns: {', '.join(known)}; others need a 'role')")
        raise DataError(msg)
    if not _type_ok(col.type, f.type):
        msg = f"{source}: column {f.name!r} must be {col.type}, not {f.type}"
        raise DataError(msg)
    unit = fm.get("unit")
    units = (col.unit,) if isinstance(col.unit, str) else col.unit
    if unit is not None and unit not in units:
        want = " or ".join(repr(u) for u in units)
        msg = f"{source}: column {f.name!r} is in {unit!r}; a {kind} stream wants {want}"
        raise DataError(msg)
    of = fm.get("of")
    if role == "uncertainty" and of in schema.names and unit is not None:
        of_unit = field_meta(schema.field(of)).get("unit")
        if of_unit is not None and of_unit != unit:
            msg = (f"{source}: column {f.name!r} is in {unit!r} but the curve it is the "
                   f"uncertainty of, {of!r}, is in {of_unit!r}")
            raise DataError(msg)
    missing = [k for k in col.field_metadata if k not in fm]
    if missing:
        msg = f"{source}: column {f.name!r} lacks field metadata {', '.join(missing)}"
        raise DataError(msg)
    check_field_values(f.name, fm, source)


def check_field_values(name: str, fm: dict[str, str], source: str) -> None:
    """A column's field metadata within :data:`~enctools.data.limits.FIELD_RANGES`.

    DataError with one line naming the column, the key, its value and the range.
    """
    ranges = limits.FIELD_RANGES.get(fm.get("role", ""), {})
    for key, text in fm.items():
        if len(text) > limits.MAX_FIELD_TEXT:
            msg = (f"{source}: column {name!r}: field metadata {key!r} has {len(text)} "
                   f"characters; at most {limits.MAX_FIELD_TEXT}")
            raise DataError(msg)
        rng = ranges.get(key)
        if rng is not None and parse_field_value(text, rng) is None:
            shown = text if len(text) <= 40 else text[:40] + "..."
            msg = (f"{source}: column {name!r}: field metadata {key}={shown!r} is out of "
                   f"range; it must be {rng.describe()}")
            raise DataError(msg)
    if fm.get("role") == "head":
        _check_head_periods(name, fm, source)


def _check_head_periods(name: str, fm: dict[str, str], source: str) -> None:
    """counts_per_rev = periods_per_rev * interpolation (the interpolation given or not)."""
    ranges = limits.FIELD_RANGES["head"]
    cpr = parse_field_value(fm.get("counts_per_rev", ""), ranges["counts_per_rev"])
    ppr = parse_field_value(fm.get("periods_per_rev", ""), ranges["periods_per_rev"])
    if not isinstance(cpr, int) or not isinstance(ppr, int):
        return
    interp = fm.get("interpolation")
    ok = cpr % ppr == 0 if interp is None else \
        parse_field_value(interp, ranges["interpolation"]) == cpr // ppr and cpr % ppr == 0
    if not ok:
        msg = (f"{source}: column {name!r}: counts_per_rev={cpr} is not periods_per_rev={ppr} "
               f"times interpolation={interp or 'an integer'}")
        raise DataError(msg)


def parse_field_value(text: str, rng: limits.Range) -> float | int | str | None:
    """A field-metadata value as its range's type, or None when it is not one in range."""
    if rng.type == "text":
        return text if (not rng.choices or text in rng.choices) and text.strip() else None
    try:
        value = float(text)
    except ValueError:
        return None
    if not rng.min <= value <= rng.max:  # also refuses NaN
        return None
    if rng.type == "int":
        if not value.is_integer():
            return None
        try:
            return int(text)
        except ValueError:
            return int(value)
    return value


def check_new_columns(kind: str, names: list[str], what: str) -> None:
    """Names a command will give columns of a ``kind`` output by role: none empty, none
    a named column of the kind (``theta``...), none twice; ``what`` (a setting's field
    between backticks, or words) names their origin in the one-line SettingsError,
    raised before any work."""
    from enctools.errors import SettingsError

    fixed = {c.name for c in kind_spec(kind).columns if c.name}
    for name in names:
        if not name.strip() or len(name) > limits.MAX_FIELD_TEXT or name in fixed:
            why = "is a column of its own" if name in fixed else "is not a column name"
            msg = f"{what} {name!r} {why} in a {kind} stream; choose another"
            raise SettingsError(msg)
    if len(set(names)) < len(names):
        msg = f"{what}: the names {', '.join(names)} are not distinct"
        raise SettingsError(msg)


def columns_with_role(schema: pa.Schema, role: str) -> list[str]:
    """Names of the columns whose field metadata has this role, in schema order."""
    return [f.name for f in schema if field_meta(f).get("role") == role]


def column_with_role(schema: pa.Schema, role: str, name: str | None, source: str,
                     option: str) -> str:
    """The column of ``role`` to use: ``name`` if given, else the only one.

    DataError with one line naming the choices when there is none, several and no
    ``name``, or ``name`` is not a column of that role (``option`` chooses one).
    """
    names = columns_with_role(schema, role)
    have = ", ".join(names) or "none"
    if name is None:
        if len(names) != 1:
            msg = f"{source}: {len(names)} {role} columns ({have}); choose one with {option}"
            raise DataError(msg)
        return names[0]
    if name not in names:
        msg = f"{source}: no {role} column {name!r} (have: {have})"
        raise DataError(msg)
    return name
