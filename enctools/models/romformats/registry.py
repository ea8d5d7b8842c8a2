"""The correction-table formats, by name: one :class:`~.record.TableFormat` record each.

The formats of enctools are the modules of :mod:`.catalogue`, each calling
:func:`register`; they are found and imported on first use. A format of one's own is
one more module there, or one :func:`register` call before the table is written or
read (and :func:`unregister` when it is done with). enc make-rom and enc correct build
their choices, help and "applies to" checks from these records.
"""

from __future__ import annotations

import importlib
import pkgutil

from enctools.errors import SettingsError
from enctools.models.romformats.record import (
    ADDRESSED_SETTINGS,
    CONTROL,
    CONTROLLER,
    FAMILIES,
    MEMORY,
    TableFormat,
)

__all__ = ["ADDRESSED_SETTINGS", "CONTROL", "CONTROLLER", "MEMORY", "TableFormat",
           "by_extension", "extensions", "find", "get", "names", "records", "register",
           "unregister"]

_RECORDS: dict[str, TableFormat] = {}
_FOUND = False


def register(fmt: TableFormat, replace: bool = False) -> TableFormat:
    """Add ``fmt`` to the registry (a name or an extension taken already is an error
    unless ``replace``); the record itself, for a module to keep."""
    _discover()
    old = _RECORDS.get(fmt.name)
    if old is not None and old is not fmt and not replace:
        msg = f"table format {fmt.name!r} is registered already"
        raise ValueError(msg)
    for ext in fmt.extensions:
        other = by_extension(ext)
        if other is not None and other.name != fmt.name and not replace:
            msg = f"extension {ext} names the {other.name} table format already"
            raise ValueError(msg)
    _RECORDS[fmt.name] = fmt
    return fmt


def unregister(name: str) -> None:
    """Remove the record of ``name`` (a format registered for a while, as a test does)."""
    _RECORDS.pop(name, None)


def _discover() -> None:
    """Import the records of the catalogue's modules, once."""
    global _FOUND
    if _FOUND:
        return
    _FOUND = True
    from enctools.models.romformats import catalogue

    for info in pkgutil.iter_modules(catalogue.__path__):
        importlib.import_module(f"{catalogue.__name__}.{info.name}")


def records(family: str | None = None) -> list[TableFormat]:
    """Every registered format (of ``family``), in the order they are listed."""
    _discover()
    if family is not None and family not in FAMILIES:
        msg = f"no family {family!r} ({', '.join(FAMILIES)})"
        raise ValueError(msg)
    return sorted((r for r in _RECORDS.values() if family is None or r.family == family),
                  key=lambda r: (FAMILIES.index(r.family), r.rank, r.name))


def names(*families: str) -> tuple[str, ...]:
    """The formats' names (of ``families``; none given: all), in the order listed."""
    return tuple(r.name for r in records() if not families or r.family in families)


def find(name: str) -> TableFormat | None:
    """The record of ``name``, or None."""
    _discover()
    return _RECORDS.get(name)


def get(name: str) -> TableFormat:
    """The record of ``name``; SettingsError (naming ``target``) when none is registered."""
    found = find(name)
    if found is None:
        msg = f"`target` must be one of {', '.join(names())}, not {name!r}"
        raise SettingsError(msg)
    return found


def extensions() -> dict[str, str]:
    """Every extension that names a format -> the format's name."""
    return {ext: r.name for r in records() for ext in r.extensions}


def by_extension(ext: str) -> TableFormat | None:
    """The format a file extension (``.mif``, any case) names, or None."""
    _discover()
    ext = ext.lower()
    return next((r for r in _RECORDS.values() if ext in r.extensions), None)
