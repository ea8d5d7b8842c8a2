"""The section of a linear axis's points stream: ISO 230-2 or VDI/DGQ 3441 in um.

A points stream whose position is a length (points v4: position [mm], deviation [um],
metadata ``axis`` linear; enc-points(1), LINEAR AXES) is a linear axis's positioning
test, an ISO 230-2 log of a laser interferometer for one. Its section holds the
figures of the report's standard in um over targets in mm, computed as a rotary axis's
are (:func:`enctools.report.iso230.iso230_2`) but never modulo a turn; the standard's
x = actual - target is -deviation (a points stream's deviation is indicated - true).
What belongs to a rotary axis alone (a curve over a turn, its harmonics, the closure
of 0 and 360 deg, the polygon run's budget) is left out with one note.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.columns import column
from enctools.errors import DataError
from enctools.report.iso230 import iso230_2, target_positions
from enctools.report.vdi3441 import from_iso

#: positions closer than this are one target [mm] (a log gives its targets exactly)
TOLERANCE_MM = 1e-3
#: the note that says what a linear axis's section leaves out
LEFT_OUT = ("a linear axis: no curve over a turn, no harmonics, no closure of 0 and 360, "
            "no uncertainty budget (a rotary axis's); its positioning figures follow")


def linear_points(table: pa.Table, s: Any, opts: Any) -> None:
    """The section ``s`` (a ``sections.Section``) of a linear axis's points ``table``:
    positions [mm], deviations [um], the report's standard's figures [um]."""
    pos = column(table, "position", "mm", s.source)
    dev = column(table, "deviation", "um", s.source)
    if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(dev))):
        msg = f"{s.source}: a position or deviation is NaN or infinite"
        raise DataError(msg)
    direction, run = (table.column(c).to_numpy(zero_copy_only=False)
                      if c in table.schema.names else None for c in ("direction", "run"))
    s.unit = "um"
    targets = target_positions(pos, TOLERANCE_MM)[0]
    s.info |= {"axis": "linear", "positions": int(targets.size), "points": int(pos.size),
               "travel": f"{targets.min():g} to {targets.max():g} mm"}
    s.notes.append(LEFT_OUT)
    try:
        iso = iso230_2(pos, -dev, direction, TOLERANCE_MM, run=run, linear=True)
    except DataError as exc:
        s.notes.append(f"no {opts.standard_name} figures: "
                       f"{str(exc).removeprefix('ISO 230-2: ')}")
        return
    iso.x_sign = -1
    if opts.standard == "vdi3441":
        try:
            s.vdi = from_iso(iso)
        except DataError as exc:
            s.notes.append(f"no {opts.standard_name} figures: {exc}")
        return
    s.iso = iso
    s.notes += iso.warnings
