"""The correction-table formats, by name: one :class:`~.record.TableFormat` record each.

The formats of enctools are the modules of :mod:`.catalogue`, each calling
:func:`register`; they are found and imported on first use. A format of one's own is
one more module there, or one :func:`register` call before the table is written or
read (and :func:`unregister` when it is done with). enc make-rom and enc correct build
their choices, help and "applies to" checks from these records.
"""

from __future__ import annotations

from enctools.errors import SettingsError
from enctools.models.romformats.record import (
    ADDRESSED_SETTINGS,
    CONTROL,
    CONTROLLER,
    FAMILIES,
    MEMORY,
    READ_SETTINGS,
    TableFormat,
)
from enctools.registry import Registry

__all__ = ["ADDRESSED_SETTINGS", "CONTROL", "CONTROLLER", "MEMORY", "READ_SETTINGS",
           "TableFormat", "by_extension", "extensions", "find", "get", "names", "records",
           "register", "unregister"]

#: the formats, registered by the modules of the catalogue
_FORMATS: Registry[TableFormat] = Registry("table format", lambda f: f.name,
                                          "enctools.models.romformats.catalogue")


def register(fmt: TableFormat, replace: bool = False) -> TableFormat:
    """Add ``fmt`` to the registry (a name or an extension taken already is an error
    unless ``replace``); the record itself, for a module to keep."""
    for ext in fmt.extensions:
        other = by_extension(ext)
        if other is not None and other.name != fmt.name and not replace:
            msg = f"extension {ext} names the {other.name} table format already"
            raise ValueError(msg)
    return _FORMATS.register(fmt, replace)


#: remove the record of ``name`` (a format registered for a while, as a test does)
unregister = _FORMATS.unregister


def records(family: str | None = None) -> list[TableFormat]:
    """Every registered format (of ``family``), in the order they are listed."""
    if family is not None and family not in FAMILIES:
        msg = f"no family {family!r} ({', '.join(FAMILIES)})"
        raise ValueError(msg)
    return sorted((r for r in _FORMATS.values() if family is None or r.family == family),
                  key=lambda r: (FAMILIES.index(r.family), r.rank, r.name))


def names(*families: str) -> tuple[str, ...]:
    """The formats' names (of ``families``; none given: all), in the order listed."""
    return tuple(r.name for r in records() if not families or r.family in families)


def find(name: str) -> TableFormat | None:
    """The record of ``name``, or None."""
    return _FORMATS.find(name)


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
    ext = ext.lower()
    return next((r for r in _FORMATS.values() if ext in r.extensions), None)
