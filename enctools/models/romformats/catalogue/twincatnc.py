"""TwinCAT NC PTP position compensation: a PLC declaration (IEC 61131-3 Structured Text)
of the table and parameters that Tc2_MC2's MC_TableBasedPositionCompensation reads:
an ARRAY OF ST_PositionCompensationTableElement (Position, Compensation [deg]) and an
ST_PositionCompensationTableParameter (MinPosition, MaxPosition, NoOfTableElements,
Direction, Modulo)."""

from __future__ import annotations

import re
from typing import Any

from enctools.errors import SettingsError
from enctools.models.romformats import registry
from enctools.models.romformats.record import CONTROL, Control, TableFormat, lazy

#: points written at most: the function block documents no limit; the library's choice
TWINCAT_NC_POINTS = 3601
#: what only this format's content has (a file's first 4 KiB)
SIGNATURE = re.compile(rb"ST_PositionCompensationTableElement", re.IGNORECASE)



def check(settings: Any, entries: int | None) -> None:
    """The declaration names no axis: the function block's Axis input does."""
    if settings.axis is not None:
        msg = ("`axis`: the PLC declaration names no axis (MC_TableBasedPositionCompensation's "
               "Axis input does)")
        raise SettingsError(msg)


TWINCAT_NC = registry.register(TableFormat(
    "twincat-nc", "TwinCAT NC PTP table for MC_TableBasedPositionCompensation", CONTROL,
    (".st",), write_table=lazy(".controlwriters", "write_twincat_nc"),
    read_points=lazy(".controlreaders", "read_twincat_nc"),
    control=Control(1e-6, TWINCAT_NC_POINTS, False, None, exact_spacing=False, no_backlash=(
        "MC_TableBasedPositionCompensation takes no backlash value"), no_bidirectional=(
        "whether two blocks, one per direction (Direction Positive, Negative), combine on one "
        "axis is not confirmed")), sign=None,
    check=check, signature=SIGNATURE, rank=25))
