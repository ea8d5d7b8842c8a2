"""ACS SPiiPlus ACSPL+ program: a REAL array filled element by element, then
``ERRORMAP1D axis, zone, base, step, array`` and ``ERRORMAPON``; values in degrees."""

from __future__ import annotations

import re
from typing import Any

from enctools.errors import SettingsError
from enctools.models.romformats import registry
from enctools.models.romformats.record import CONTROLLER, TableFormat, lazy

#: ACSPL+ user variable names, the conservative common subset: a letter, then letters,
#: digits or _; at most 32 characters
ACS_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}")
#: ACS axis indices accepted: 0..ACS_MAX_AXIS
ACS_MAX_AXIS = 127
#: the words of the ACS program written here: no array may take one of their names
ACS_WORDS = frozenset({"AXIS_NO", "GLOBAL", "REAL", "INT", "STOP", "ERRORMAP1D",
                       "ERRORUNMAP", "ERRORMAPON"})


def check_zone(target: Any) -> None:
    """A zone or measuring-system index is a whole number >= 0."""
    zone = target.zone
    if isinstance(zone, bool) or not isinstance(zone, int) or zone < 0:
        msg = f"`zone` must be a whole number >= 0, not {zone!r}"
        raise SettingsError(msg)


def check(target: Any, entries: int | None) -> None:
    """Only a name or a number lands in the program: the axis a number, the array a name
    that is not a word of the program."""
    check_zone(target)
    if not (re.fullmatch(r"[0-9]{1,3}", target.axis) and int(target.axis) <= ACS_MAX_AXIS):
        msg = f"`axis` must be an ACS axis number 0..{ACS_MAX_AXIS}, not {target.axis!r}"
        raise SettingsError(msg)
    if not ACS_NAME.fullmatch(target.name):
        msg = (f"`array_name` must be an ACSPL+ name (a letter, then letters, digits or _, at "
               f"most 32 characters), not {target.name!r}")
        raise SettingsError(msg)
    if target.name.upper() in ACS_WORDS:
        msg = (f"`array_name` {target.name!r} is a word of the program written "
               f"({', '.join(sorted(ACS_WORDS))}); choose another name")
        raise SettingsError(msg)


#: what only this format's content has (a file's first 4 KiB)
SIGNATURE = re.compile(rb"^\s*ERRORMAP1D\s", re.MULTILINE)

ACS = registry.register(TableFormat(
    "acs", "ACS SPiiPlus ERRORMAP1D program", CONTROLLER, (".prg", ".acs"),
    write_values=lazy(".writers", "write_acs"), read_values=lazy(".readers", "read_acs"),
    read_points=lazy(".controlreaders", "read_acs"), sign=None, max_entries=100_000,
    resolution_source="ACS: the axis' position step in degrees, as its user units give it",
    default_axis="0", settings=frozenset({"zone", "array_name"}),
    read_settings=frozenset({"array_name"}), check=check, signature=SIGNATURE, rank=10))
