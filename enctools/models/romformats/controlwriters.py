"""Writers of motion controls' compensation tables: one function per control.

Each takes an open binary file, a built :class:`~.controls.ControlTable` (stored
values in steps of the control's resolution, in the control's sign) and the comment
lines (written where the format has comments). Values are printed at the control's
resolution from whole numbers of steps (integer arithmetic: no binary fraction ever
reaches the text). The layouts and their sources are in enc-make-rom(1), CONTROLS.
"""

from __future__ import annotations

import re
from typing import IO

import numpy as np

from enctools.errors import SettingsError
from enctools.models.romformats.controls import ControlTable
from enctools.models.romformats.words import Target, comment_text


def fixed(steps: int, decimals: int, plus: bool = False) -> str:
    """``steps`` x 10^-decimals as a decimal number with exactly ``decimals`` digits."""
    sign = "-" if steps < 0 else "+" if plus else ""
    whole, frac = divmod(abs(int(steps)), 10 ** decimals)
    return f"{sign}{whole}.{frac:0{decimals}d}" if decimals else f"{sign}{whole}"


def _decimals(resolution_deg: float) -> int:
    """Digits after the point of a resolution that is a power of ten [deg]."""
    d = round(-np.log10(resolution_deg))
    if abs(10.0 ** -d - resolution_deg) > 1e-15:
        msg = f"resolution {resolution_deg!r} deg is not a power of ten"
        raise ValueError(msg)
    return int(d)


def _grid_steps(t: ControlTable, decimals: int) -> np.ndarray:
    """The grid's positions in steps of 10^-decimals deg."""
    return np.rint(t.grid_deg * 10 ** decimals).astype(np.int64)


def write_linuxcnc(f: IO[bytes], t: ControlTable, comment: list[str]) -> None:
    """A LinuxCNC joint compensation file: ``nominal forward reverse`` a line [deg].

    COMP_FILE_TYPE 0: forward and reverse are the positions the joint reaches when
    commanded to the nominal (nominal - trim); type 1: they are the trims added to the
    command (minus the correction). The comment lines come after the data: the loader
    stops at the first line that is not three numbers.
    """
    d = _decimals(t.resolution_deg)
    nominal = _grid_steps(t, d)
    trims = [t.forward, t.forward if t.backward is None else t.backward]
    if t.settings.comp_type == 0:
        trims = [nominal - v for v in trims]
    lines = [f"{fixed(n, d)} {fixed(a, d)} {fixed(b, d)}\n"
             for n, a, b in zip(nominal.tolist(), trims[0].tolist(), trims[1].tolist(),
                                strict=True)]
    lines += [f"# {comment_text(c, ascii_only=True)}\n" for c in comment]
    f.write("".join(lines).encode("ascii"))


def write_twincat(f: IO[bytes], t: ControlTable, comment: list[str]) -> None:
    """A TwinCAT CNC compensation value list: leadscrew error compensation (kw.ssfk.*) of
    a modulo axis, equidistant points from 0 deg, values in 0.0001 deg (unit 1)."""
    steps = 10 ** _decimals(t.resolution_deg)
    interval = round(t.spacing_deg * steps)
    out = [f"# {comment_text(c, ascii_only=True)}\n" for c in comment]
    rows = [("kopf.log_achs_nr", t.settings.axis or "1"), ("kw.ssfk.unit", 1),
            ("kw.ssfk.interval", interval), ("kw.ssfk.kw_startpos", 0),
            ("kw.ssfk.kw_nr_max", t.grid_deg.size),
            ("kw.ssfk.bilateral", int(t.backward is not None)), ("kw.ssfk.modulo", 1)]
    neg = t.forward if t.backward is None else t.backward  # unilateral: both the same
    rows += [(f"kw.ssfk.table[{i}].pos", v) for i, v in enumerate(t.forward.tolist())]
    rows += [(f"kw.ssfk.table[{i}].neg", v) for i, v in enumerate(neg.tolist())]
    out += [f"{k:<32} {v}\n" for k, v in rows]
    f.write("".join(out).encode("ascii"))


def write_fanuc(f: IO[bytes], t: ControlTable, comment: list[str]) -> None:
    """A Fanuc pitch error compensation setting sheet for a rotary axis: parameters
    3620-3625 of the axis, 1851 (backlash) when one is written, and one incremental value
    per compensation point."""
    s = t.settings
    axis = s.axis or "1"
    du = s.detection_unit_deg
    sections = t.grid_deg.size - 1
    per_turn = round(360.0 / du)
    r = s.home_point
    params = [(3620, r, "compensation point of the reference position"),
              (3621, r, "farthest point on the - side"),
              (3622, r + sections, "farthest point on the + side"),
              (3623, t.magnification, "magnification"),
              (3624, per_turn // sections, "interval [detection units]"),
              (3625, per_turn, "travel per rotation [detection units]")]
    if t.backlash is not None:
        params.append((1851, t.backlash, "backlash [detection units]"))
    increments = np.diff(t.forward)
    out = [f"# {comment_text(c, ascii_only=True)}\n" for c in comment]
    system = f"  # increment system {s.increment_system}" if s.increment_system else ""
    out.append(f"DETECTION_UNIT_DEG {du!r}{system}\n")
    out += [f"PARAMETER {n} AXIS {axis} VALUE {v}  # {what}\n" for n, v, what in params]
    out.append(f"PITCH {r} VALUE {increments[-1]:+d}  # the same as point {r + sections}\n")
    out += [f"PITCH {r + 1 + i} VALUE {v:+d}\n" for i, v in enumerate(increments.tolist())]
    f.write("".join(out).encode("ascii"))


def _fanuc_real(steps: int, decimals: int) -> str:
    """A Fanuc real parameter: ``steps`` (>= 0) x 10^-decimals with its trailing zeros
    dropped and one digit after the point kept (30.0, 27.5, 0.125)."""
    whole, frac = divmod(int(steps), 10 ** decimals)
    digits = f"{frac:0{decimals}d}".rstrip("0") if decimals else ""
    return f"{whole}.{digits or '0'}"


def write_fanuc_param(f: IO[bytes], t: ControlTable, comment: list[str]) -> None:
    """A Fanuc parameter transfer file (the CNC's punch and read format, ISO code): ``%``,
    blocks ``N<parameter>Q1A<axis>P<value>`` of the axis's pitch error compensation
    parameters 3620-3625 (3624 and 3625 real, in deg) and, with a backlash, 1851, then
    the pitch error compensation data ``N<10000 + point>Q0P<value>``, then ``%``. A rotary
    axis: points 3620 + 1 .. 3622 hold the increments over the turn (summing to 0), 3621 =
    3620 + 1, and point 3620 repeats point 3622. The format has no comment: ``comment``
    is left out."""
    s = t.settings
    axis = s.axis or "1"
    d = _decimals(s.detection_unit_deg)
    sections = t.grid_deg.size - 1
    per_turn = 360 * 10 ** d
    r = s.home_point
    params = [(3620, str(r)), (3621, str(r + 1)), (3622, str(r + sections)),
              (3623, str(t.magnification)),
              (3624, _fanuc_real(per_turn // sections, d)), (3625, _fanuc_real(per_turn, d))]
    if t.backlash is not None:
        params.insert(0, (1851, str(t.backlash)))
    increments = np.diff(t.forward).tolist()
    out = ["%\n"] + [f"N{n:05d}Q1A{axis}P{v}\n" for n, v in params]
    out += [f"N{10000 + p:05d}Q0P{v}\n"
            for p, v in zip(range(r, r + sections + 1), [increments[-1], *increments],
                            strict=True)]
    out.append("%\n")
    f.write("".join(out).encode("ascii"))


def write_heidenhain(f: IO[bytes], t: ControlTable, comment: list[str]) -> None:
    """A HEIDENHAIN compensation value table (.COM) of one rotary axis: columns NR,
    AXISPOS [deg] and the axis's own column [deg]. HEIDENHAIN tables have no comment
    lines: ``comment`` is left out."""
    d = _decimals(t.resolution_deg)
    axis = t.settings.axis or "C"
    out = [f"BEGIN {axis}.COM\n", f"{'NR':<8}{'AXISPOS':<16}{axis}\n"]
    out += [f"{i:<8}{fixed(p, d, True):<16}{fixed(v, d, True)}\n"
            for i, (p, v) in enumerate(zip(_grid_steps(t, d).tolist(), t.forward.tolist(),
                                           strict=True))]
    out.append("[END]\n")
    f.write("".join(out).encode("ascii"))



def write_heidenhain_cma(f: IO[bytes], t: ControlTable, com_name: str) -> None:
    """The HEIDENHAIN assignment table (.CMA) of the .COM table ``com_name``: a column
    named for the axis holding the .COM file's name, the line marked active (``*`` in
    ACTIVE), the fields starting under their column names as in the .COM."""
    if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,63}", com_name):
        msg = (f"heidenhain: the .CMA names the table by its file name, which must be "
               f"letters, digits, _ . or - (at most 64), not {com_name!r}")
        raise SettingsError(msg)
    axis = t.settings.axis or "C"
    width = max(16, len(com_name) + 2, len(axis) + 2)
    cma = com_name.rsplit(".", 1)[0] + ".CMA"
    out = [f"BEGIN {cma.upper()}\n", f"{'NR':<8}{axis:<{width}}ACTIVE\n",
           f"{0:<8}{com_name:<{width}}*\n", "[END]\n"]
    f.write("".join(out).encode("ascii"))


#: the PLC names of the TwinCAT NC PTP table and its parameters
TWINCAT_NC_TABLE = "aEncCompTable"
TWINCAT_NC_PARAMETER = "stEncCompParameter"


def write_twincat_nc(f: IO[bytes], t: ControlTable, comment: list[str]) -> None:
    """A TwinCAT PLC declaration (Structured Text) of the table MC_TableBasedPositionCompensation
    reads: ``aEncCompTable`` (Position, Compensation [deg], equidistant and increasing,
    0..360 deg) and ``stEncCompParameter`` (MinPosition 0, MaxPosition 360, the element
    count, both directions, Modulo TRUE). Comments are ``(* *)`` with every ``*`` of the
    text escaped, so none can close one."""
    d = _decimals(t.resolution_deg)
    n = t.grid_deg.size
    out = [f"(* {comment_text(c, ascii_only=True, reserved='*')} *)\n" for c in comment]
    out += ["VAR_GLOBAL\n",
            f"    {TWINCAT_NC_PARAMETER} : ST_PositionCompensationTableParameter := (\n",
            f"        MinPosition := {fixed(0, d)}, MaxPosition := {fixed(360 * 10 ** d, d)},\n",
            f"        NoOfTableElements := {n}, "
            "Direction := E_WorkDirection.WorkDirectionBoth, Modulo := TRUE);\n",
            f"    {TWINCAT_NC_TABLE} : ARRAY[1..{n}] OF ST_PositionCompensationTableElement := [\n"]
    rows = zip(_grid_steps(t, d).tolist(), t.forward.tolist(), strict=True)
    out += [f"        (Position := {fixed(p, d)}, Compensation := {fixed(v, d)})"
            f"{',' if i < n - 1 else ''}\n" for i, (p, v) in enumerate(rows)]
    out += ["    ];\n", "END_VAR\n"]
    f.write("".join(out).encode("ascii"))


def write_siemens_backlash(f: IO[bytes], t: Target, steps: int, comment: list[str]) -> None:
    """A SINUMERIK machine data file of the axis (punch tape format): its name
    ``%_N_AX<n>_TEA_INI`` first in its first line, the comment lines (``;``), the
    assignment ``$MA_BACKLASH[e,AX<n>]=value`` (MD32450, deg, positive when the encoder
    leads the machine part) at the table's resolution, and M17."""
    from enctools.models.romformats.writers import PROGRAM_LINE, _comments

    assert t.decimals is not None  # a controller's table is written at its resolution
    head = f"%_N_{t.axis}_TEA_INI\n" + _comments(comment, "; ", ascii_only=True,
                                                  width=PROGRAM_LINE)
    f.write((head + f"$MA_BACKLASH[{t.zone},{t.axis}]={fixed(steps, t.decimals)}\nM17\n")
            .encode("ascii"))
