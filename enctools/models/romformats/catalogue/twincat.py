"""TwinCAT CNC compensation value list: leadscrew error compensation (kw.ssfk.*) of a
modulo axis, equidistant points from 0 deg, values in 0.0001 deg."""

from __future__ import annotations

from enctools.models.romformats import registry
from enctools.models.romformats.record import (
    CONTROL,
    Control,
    TableFormat,
    check_axis_number,
    lazy,
)

TWINCAT = registry.register(TableFormat(
    "twincat", "TwinCAT CNC compensation value list", CONTROL, (".lis",),
    write_table=lazy(".controlwriters", "write_twincat"),
    read_points=lazy(".controlreaders", "read_twincat"),
    control=Control(1e-4, 1500, True, (-(1 << 31), (1 << 31) - 1), no_backlash=(
        "its backlash (P-AXIS-00103) is an axis parameter, not in the compensation list, and "
        "a bilateral list (`bidirectional`) holds the reversal")), sign="correction",
    check=check_axis_number, rank=20))
