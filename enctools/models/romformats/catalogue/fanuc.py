"""Fanuc pitch error compensation setting sheet for a rotary axis: parameters 3620-3625
(and the backlash, 1851) and one incremental value per compensation point from the home
(reference) point."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from enctools.errors import SettingsError
from enctools.models.romformats import registry
from enctools.models.romformats.record import (
    CONTROL,
    Control,
    TableFormat,
    check_axis_number,
    lazy,
)

#: pitch error compensation point numbers 0..FANUC_LAST_POINT
FANUC_LAST_POINT = 1023
#: largest |compensation value| of one point, in units of magnification x detection unit
#: (the conservative limit; see enc-make-rom(1))
FANUC_MAX_STEP = 7
#: the increment systems and the least command increment of a rotation axis each gives
#: [deg]: the detection unit of the table when the command multiplier is 1 (enc-make-rom(1))
INCREMENT_SYSTEMS = (("IS-A", 1e-2), ("IS-B", 1e-3), ("IS-C", 1e-4))
#: parameter 1851 (backlash compensating value, word axis, detection units): its valid
#: data range (FANUC Series 0i/0i Mate-MODEL C Parameter Manual B-64120EN/01, 1851)
BACKLASH_RANGE = (-9999, 9999)
#: the rules of a rotary axis's pitch error compensation, the sheet's and the transfer
#: file's alike
FANUC_CONTROL = Control(1e-3, FANUC_LAST_POINT + 1, False, (-FANUC_MAX_STEP, FANUC_MAX_STEP),
                        incremental=True, increment_systems=INCREMENT_SYSTEMS,
                        backlash_range=BACKLASH_RANGE, no_bidirectional=(
                            "bidirectional pitch error compensation (3605#0 BDPx, 3626, 3627; "
                            "A-77810E) is not written: the data numbers of the negative "
                            "direction's pitch data on the Series 30i are not confirmed "
                            "(B-63950EN not read for them); use `backlash` (1851)"))
#: the settings of enc make-rom a Fanuc table takes beyond a control's
FANUC_SETTINGS = frozenset({"detection_unit", "home_point", "increment_system"})


def check(settings: Any, entries: int | None) -> None:
    """The home point a point number, the axis a number 0..32."""
    if not 0 <= settings.home_point < FANUC_LAST_POINT:
        msg = f"`home_point` must be 0..{FANUC_LAST_POINT - 1}, not {settings.home_point}"
        raise SettingsError(msg)
    check_axis_number(settings)


def grid(settings: Any, sections: int) -> str | None:
    """A whole number of detection units between points, the point numbers within
    0..FANUC_LAST_POINT."""
    du = settings.detection_unit_deg
    per_turn = round(360.0 / du)
    if abs(per_turn * du - 360.0) > 1e-9 or per_turn % sections:
        return (f"a spacing of 360/{sections} deg is not a whole number of "
                f"detection units ({du!r} deg)")
    if settings.home_point + sections > FANUC_LAST_POINT:
        return (f"points {settings.home_point}..{settings.home_point + sections} pass the "
                f"last point number {FANUC_LAST_POINT}")
    return None


FANUC = registry.register(TableFormat(
    "fanuc", "Fanuc pitch error compensation sheet", CONTROL,
    write_table=lazy(".controlwriters", "write_fanuc"),
    read_points=lazy(".controlreaders", "read_fanuc"),
    control=replace(FANUC_CONTROL, grid_rule=grid), sign=None, settings=FANUC_SETTINGS,
    check=check, rank=30))
