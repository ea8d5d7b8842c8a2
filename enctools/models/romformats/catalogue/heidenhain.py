"""HEIDENHAIN compensation value table (.COM) of one rotary axis: columns NR, AXISPOS
[deg] and the axis's own column [deg]."""

from __future__ import annotations

from typing import Any

from enctools.models.romformats import registry
from enctools.models.romformats.record import CONTROL, Control, TableFormat, check_axis, lazy


def check(settings: Any, entries: int | None) -> None:
    """The axis a HEIDENHAIN axis name."""
    check_axis(settings, r"[A-Z][A-Z0-9]{0,7}", "a HEIDENHAIN axis name (an upper-case "
               "letter, then letters or digits, at most 8)")


HEIDENHAIN = registry.register(TableFormat(
    "heidenhain", "HEIDENHAIN compensation value table", CONTROL, (".com",),
    write_table=lazy(".controlwriters", "write_heidenhain"),
    read_points=lazy(".controlreaders", "read_heidenhain"),
    control=Control(1e-4, 256, False, None), sign=None, default_axis="C", check=check,
    rank=40))
