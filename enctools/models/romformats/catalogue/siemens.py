"""SINUMERIK interpolatory compensation (``$AA_ENC_COMP``) for a rotary axis with
modulo: points 0..k, 0 deg and 360 deg both present with the same value, no gaps,
``$AA_ENC_COMP_STEP/MIN/MAX/IS_MODULO``; values in degrees."""

from __future__ import annotations

import re
from typing import Any

from enctools.errors import SettingsError
from enctools.models.romformats import registry
from enctools.models.romformats.catalogue.acs import check_zone
from enctools.models.romformats.record import CONTROLLER, BacklashFile, TableFormat, lazy

#: SINUMERIK axis names: a letter, then letters, digits or _; at most 8 characters
#: (Siemens programming manual: axis identifiers up to 8 characters, e.g. AX1, C1)
SIEMENS_AXIS = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,7}")


def check(target: Any, entries: int | None) -> None:
    """The measuring system a number, the axis a SINUMERIK axis name."""
    check_zone(target)
    if not SIEMENS_AXIS.fullmatch(target.axis):
        msg = (f"`axis` must be a SINUMERIK axis name (a letter, then letters, digits or _, "
               f"at most 8 characters, e.g. AX1 or C1), not {target.axis!r}")
        raise SettingsError(msg)


def check_backlash(target: Any) -> None:
    """The machine data file is named for the machine axis's number (_N_AX<n>_TEA_INI):
    the axis must be given as AX<n>."""
    if not re.fullmatch(r"AX[1-9][0-9]{0,2}", target.axis):
        msg = (f"`backlash`: siemens: the machine data file is named for the machine axis's "
               f"number (_N_AX<n>_TEA_INI); give `axis` as AX<n>, not {target.axis!r}")
        raise SettingsError(msg)


#: what only this format's content has (a file's first 4 KiB)
SIGNATURE = re.compile(rb"^\s*\$AA_ENC_COMP\[", re.MULTILINE)

SIEMENS = registry.register(TableFormat(
    "siemens", "SINUMERIK $AA_ENC_COMP table", CONTROLLER, (".spf", ".mpf", ".ini"),
    write_values=lazy(".writers", "write_siemens"),
    read_values=lazy(".readers", "read_siemens"),
    read_points=lazy(".controlreaders", "read_siemens"), max_entries=5_000,
    resolution_source="SINUMERIK: 1 / MD10210 $MN_INT_INCR_PER_DEG",
    default_axis="AX1", settings=frozenset({"zone", "backlash"}),
    backlash_file=BacklashFile("_tea.ini", lazy(".controlwriters", "write_siemens_backlash"),
                               lazy(".controlreaders", "read_siemens_backlash"),
                               check_backlash),
    check=check, signature=SIGNATURE, rank=20))
