"""HEIDENHAIN compensation value table (.COM) of one rotary axis: columns NR, AXISPOS
[deg] and the axis's own column [deg]; with the assignment table (.CMA) that names it
for the axis on its active line. The control's generation (``tnc``) names the rules."""

from __future__ import annotations

from typing import Any

from enctools.errors import SettingsError
from enctools.models.romformats import registry
from enctools.models.romformats.record import (
    CONTROL,
    Companion,
    Control,
    TableFormat,
    check_axis,
    lazy,
)

#: the generations whose technical manuals give the rules, and what each is
GENERATIONS = {"407": "TNC 407/415/425 (Technical Manual 243 020, 01.98)",
               "620": "MANUALplus 620 and its generation (Technical Manual MANUALplus 620)"}
#: compensation points in one .COM table (TNC 407 Technical Manual, module 9095: error 3)
HEIDENHAIN_POINTS = 256


def check(settings: Any, entries: int | None) -> None:
    """The axis a HEIDENHAIN axis name; the generation named, and one whose spacing rule
    can divide the turn."""
    check_axis(settings, r"[A-Z][A-Z0-9]{0,7}", "a HEIDENHAIN axis name (an upper-case "
               "letter, then letters or digits, at most 8)")
    tnc = settings.tnc
    if tnc is None:
        msg = ("heidenhain: name the control's generation with `tnc` (407: TNC 407/415/425; "
               "620: MANUALplus 620 and its generation): their spacing rules differ")
        raise SettingsError(msg)
    if tnc not in GENERATIONS:
        msg = f"`tnc` must be one of {', '.join(GENERATIONS)}, not {tnc!r}"
        raise SettingsError(msg)
    if tnc == "407":
        msg = ("`tnc` 407: TNC 407/415/425 space the compensation points a power of two "
               "apart (Technical Manual 243 020: 2^n x 0.1 um), and no power of two of a "
               f"decimal unit divides 360 deg within {HEIDENHAIN_POINTS} points: a rotary "
               "axis's turn cannot be written for them")
        raise SettingsError(msg)


HEIDENHAIN = registry.register(TableFormat(
    "heidenhain", "HEIDENHAIN compensation value table and its .CMA", CONTROL, (".com",),
    write_table=lazy(".controlwriters", "write_heidenhain"),
    read_points=lazy(".controlreaders", "read_heidenhain"),
    control=Control(1e-4, HEIDENHAIN_POINTS, False, None, no_backlash=(
        "the sign of its backlash machine parameter and of the .COM BACKLASH column is not "
        "confirmed from the technical manuals read"), no_bidirectional=(
        "the meaning and sign of the .COM BACKLASH column (the negative direction's values) "
        "are not confirmed")), sign=None, default_axis="C",
    settings=frozenset({"tnc"}), read_settings=frozenset({"axis"}), check=check, rank=40,
    companion=Companion(".cma", lazy(".controlwriters", "write_heidenhain_cma"),
                        lazy(".controlreaders", "read_heidenhain_cma"))))
