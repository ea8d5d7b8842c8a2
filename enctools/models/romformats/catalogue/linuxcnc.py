"""LinuxCNC joint compensation file: ``nominal forward reverse`` a line [deg]."""

from __future__ import annotations

from typing import Any

from enctools.errors import SettingsError
from enctools.models.romformats import registry
from enctools.models.romformats.record import CONTROL, Control, TableFormat, lazy


def check(settings: Any, entries: int | None) -> None:
    """The file names no joint."""
    if settings.axis is not None:
        msg = "`axis`: a LinuxCNC compensation file names no joint ([JOINT_n] COMP_FILE does)"
        raise SettingsError(msg)


LINUXCNC = registry.register(TableFormat(
    "linuxcnc", "LinuxCNC joint compensation file", CONTROL,
    write_table=lazy(".controlwriters", "write_linuxcnc"),
    read_points=lazy(".controlreaders", "read_linuxcnc"),
    control=Control(1e-6, 256, True, None, exact_spacing=False, no_backlash=(
        "LinuxCNC ignores [JOINT_n]BACKLASH when a COMP_FILE is given (ini-config.adoc): "
        "its table per direction (`bidirectional`) holds the reversal")), sign="error",
    settings=frozenset({"comp_type"}), read_settings=frozenset({"comp_type"}),
    check=check, rank=10))
