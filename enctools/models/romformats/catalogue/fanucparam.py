"""Fanuc parameter transfer file of a rotary axis's pitch error compensation: the record
the CNC punches and reads through its I/O channel or memory card (``%``, blocks
``N<parameter>Q1A<axis>P<value>``, pitch error data ``N<10000 + point>Q0P<value>``)."""

from __future__ import annotations

import re
from dataclasses import replace

from enctools.models.romformats import registry
from enctools.models.romformats.catalogue.fanuc import FANUC_CONTROL, FANUC_SETTINGS, check, grid
from enctools.models.romformats.record import CONTROL, TableFormat, lazy

#: what only this format's content has (a file's first 4 KiB): a parameter or pitch
#: data block of the Q-keyed format
SIGNATURE = re.compile(rb"^N\d{5}Q[01](?:A\d{1,2})?P", re.MULTILINE)

FANUC_PARAM = registry.register(TableFormat(
    "fanuc-param", "Fanuc parameter transfer file (pitch error data, 3620-3625, 1851)",
    CONTROL, write_table=lazy(".controlwriters", "write_fanuc_param"),
    read_points=lazy(".controlreaders", "read_fanuc_param"),
    control=replace(FANUC_CONTROL, grid_rule=grid), sign=None, settings=FANUC_SETTINGS,
    read_settings=frozenset({"axis", "detection_unit_deg"}),
    check=check, signature=SIGNATURE, rank=31))
