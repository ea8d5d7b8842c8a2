"""Readers of motion controls' compensation tables, each parsing the text as its control
does and giving the table back as a :class:`~.points.PointTable` (corrections to add
to the indicated angle [rad], the control's sign resolved).

These readers share nothing with the writers (:mod:`.controlwriters`) or the table
builder (:mod:`.controls`): a table read back equal to the one intended is evidence
that the file says what was meant, as the control reads it. Each raises DataError
(one line) on what its control would refuse or misread.
"""

from __future__ import annotations

import re

import numpy as np

from enctools.errors import DataError
from enctools.models.romformats.points import PointTable
from enctools.models.romformats.record import PointOptions
from enctools.units import DEG

#: LinuxCNC: EMCMOT_COMP_SIZE, the entries of a joint's compensation table
LINUXCNC_ENTRIES = 256
#: C's strtod as sscanf("%lf") reads it: blanks, then a decimal number (inf/nan refused later)
_STRTOD = r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?(?:inf(?:inity)?|nan))"
_TRIPLET = re.compile(_STRTOD * 3, re.IGNORECASE)


def read_linuxcnc(data: bytes, src: str, options: PointOptions) -> PointTable:
    """A joint compensation file as ``usrmotLoadComp`` and ``EMCMOT_SET_JOINT_COMP`` read it:
    lines of three numbers until the first line that is not; type 0 forward and reverse
    are positions (trim = nominal - position), type 1 trims; trims are stored as float
    (32-bit), nominals must increase, at most 256 entries. The trim is added to the
    command, so the correction is minus the trim."""
    rows = []
    for line in data.decode("latin-1").splitlines():
        m = _TRIPLET.match(line)
        if m is None:
            break
        rows.append([float(g) for g in m.groups()])
    if len(rows) < 2:
        msg = f"{src}: fewer than 2 compensation triplets (nominal forward reverse)"
        raise DataError(msg)
    a = np.array(rows)
    if not np.all(np.isfinite(a)):
        msg = f"{src}: a compensation value is not a finite number"
        raise DataError(msg)
    if len(rows) > LINUXCNC_ENTRIES:
        msg = f"{src}: {len(rows)} entries; LinuxCNC takes {LINUXCNC_ENTRIES} per joint"
        raise DataError(msg)
    if not np.all(np.diff(a[:, 0]) > 0):
        msg = f"{src}: nominal positions must increase (LinuxCNC refuses the entry)"
        raise DataError(msg)
    nominal = a[:, 0]
    trims = (nominal[:, None] - a[:, 1:]) if options.comp_type == 0 else a[:, 1:]
    trims = trims.astype(np.float32).astype(np.float64)
    forward, reverse = -trims[:, 0] * DEG, -trims[:, 1] * DEG
    return PointTable(nominal * DEG, forward,
                      None if np.array_equal(forward, reverse) else reverse)


def _twincat_keys(data: bytes, src: str) -> dict[str, str]:
    """The ``name value`` lines of a TwinCAT CNC list: ``# `` comment lines, blank lines
    and a comment after the value (a blank, then anything) left out."""
    keys: dict[str, str] = {}
    for no, raw in enumerate(data.decode("latin-1").splitlines(), 1):
        line = raw.strip()
        if not line or line == "#" or line.startswith("# "):
            continue
        parts = line.split()
        if len(parts) < 2:
            msg = f"{src}: line {no}: {line[:40]!r} has no value"
            raise DataError(msg)
        if parts[0] in keys:
            msg = f"{src}: line {no}: {parts[0]} is given twice"
            raise DataError(msg)
        keys[parts[0]] = parts[1]
    return keys


def _integer(keys: dict[str, str], name: str, src: str) -> int:
    if name not in keys:
        msg = f"{src}: no {name}"
        raise DataError(msg)
    try:
        return int(keys[name])
    except ValueError:
        msg = f"{src}: {name} {keys[name]!r} is not a whole number"
        raise DataError(msg) from None


def read_twincat(data: bytes, src: str, options: PointOptions) -> PointTable:
    """A TwinCAT CNC compensation value list's leadscrew error compensation (kw.ssfk.*):
    unit 1 (rotary axis: 0.0001 deg), equidistant points (interval, kw_startpos) or
    setpoints (interval 0), kw_nr_max entries of table[i].pos and, bilateral, .neg,
    each the absolute position error (actual - programmed), i.e. the correction."""
    keys = _twincat_keys(data, src)
    if _integer(keys, "kw.ssfk.unit", src) != 1:
        msg = f"{src}: kw.ssfk.unit 0 (encoder increments): their size is not in the file"
        raise DataError(msg)
    n = _integer(keys, "kw.ssfk.kw_nr_max", src)
    if not 2 <= n <= 1 << 20:
        msg = f"{src}: kw.ssfk.kw_nr_max {n} is not 2..{1 << 20}"
        raise DataError(msg)
    interval = _integer(keys, "kw.ssfk.interval", src)
    if interval > 0:
        start = _integer(keys, "kw.ssfk.kw_startpos", src)
        setpoints = start + interval * np.arange(n)
    else:
        setpoints = np.array([_integer(keys, f"kw.ssfk.table[{i}].setpoint", src)
                              for i in range(n)])
    pos = np.array([_integer(keys, f"kw.ssfk.table[{i}].pos", src) for i in range(n)])
    bilateral = _integer(keys, "kw.ssfk.bilateral", src) == 1
    neg = (np.array([_integer(keys, f"kw.ssfk.table[{i}].neg", src) for i in range(n)])
           if bilateral else None)
    modulo = None
    if _integer(keys, "kw.ssfk.modulo", src) == 1:
        if pos[0] != pos[-1] or (neg is not None and neg[0] != neg[-1]):
            msg = f"{src}: a modulo table's first and last entries differ"
            raise DataError(msg)
        modulo = float(setpoints[-1] - setpoints[0]) * 1e-4 * DEG
    unit = 1e-4 * DEG
    return PointTable(setpoints * unit, pos * unit, None if neg is None else neg * unit,
                      modulo_rad=modulo)


_FANUC_LINE = re.compile(r"(PARAMETER\s+(\d+)\s+AXIS\s+\d+|PITCH\s+(\d+))\s+VALUE\s+([-+]?\d+)")


def read_fanuc(data: bytes, src: str, options: PointOptions) -> PointTable:
    """A Fanuc pitch error setting sheet of a rotary axis: parameters 3620 (reference
    point), 3621 (= 3620 on a rotary axis), 3622, 3623 (magnification), 3624 (interval),
    3625 (travel per rotation) [detection units], and per point the increment over the
    section ending there (points 3621+1..3622, summing to 0; point 3620 repeats the last).
    The compensation is the sum of the increments from the reference position (0 deg),
    x magnification x detection unit; ``options.sign`` says whether it is the correction
    or the error (minus the correction)."""
    params: dict[int, int] = {}
    pitch: dict[int, int] = {}
    du = None
    for raw in data.decode("latin-1").splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        if line.startswith("DETECTION_UNIT_DEG"):
            du = float(line.split()[1])
            continue
        m = _FANUC_LINE.fullmatch(line)
        if m is None:
            msg = f"{src}: cannot read {line[:40]!r}"
            raise DataError(msg)
        (params if m.group(2) else pitch)[int(m.group(2) or m.group(3))] = int(m.group(4))
    missing = [n for n in range(3620, 3626) if n not in params]
    if missing or du is None or not du > 0:
        msg = f"{src}: parameters {missing} or the detection unit are missing"
        raise DataError(msg)
    ref, neg, far, mag, interval, turn = (params[n] for n in range(3620, 3626))
    sections = far - ref
    if neg != ref or sections < 2 or interval * sections != turn:
        msg = (f"{src}: a rotary axis needs 3621 = 3620 and (3622 - 3620) x 3624 = 3625 "
               f"(here {neg}, {ref}, {far}, {interval}, {turn})")
        raise DataError(msg)
    inc = np.array([pitch.get(p, 0) for p in range(ref + 1, far + 1)])
    if inc.sum() != 0 or pitch.get(ref) != pitch.get(far) or np.abs(inc).max() > 7:
        msg = (f"{src}: the increments must sum to 0 over the turn, point {ref} repeat "
               f"point {far}, and each be within +-7")
        raise DataError(msg)
    absolute = np.r_[0, np.cumsum(inc)] * mag * du * DEG
    positions = np.arange(sections + 1) * interval * du * DEG
    backlash = params[1851] * du * DEG if 1851 in params else None
    return PointTable(positions, absolute if options.sign == "correction" else -absolute,
                      backlash_rad=backlash, modulo_rad=turn * du * DEG)


#: a block of a Fanuc parameter transfer file: N<number>Q<1: parameter, 0: pitch data>
_FANUC_BLOCK = re.compile(r"N(\d{1,5})Q([01])(.*)")
_FANUC_AXIS_VALUE = re.compile(r"A(\d{1,2})P([-+]?\d+(?:\.\d*)?)")


def _fanuc_record(data: bytes, src: str) -> list[str]:
    """The blocks of a Fanuc transfer file's record: between the ``%`` leader and the
    next ``%``, one block a line (ISO code: LF ends a block), blanks and CR dropped."""
    lines = [re.sub(r"[ \t\r]", "", ln) for ln in data.decode("latin-1").split("\n")]
    if "%" not in lines or "%" not in lines[lines.index("%") + 1:]:
        msg = f"{src}: no record between a % leader and a closing %"
        raise DataError(msg)
    start = lines.index("%") + 1
    return [ln for ln in lines[start:lines.index("%", start)] if ln]


def _fanuc_blocks(data: bytes, src: str, axis: str | None
                  ) -> tuple[dict[int, float], dict[int, int], str]:
    """The axis's parameters (Q1, A<axis>P<value>) and the pitch error data by point
    (Q0, N<10000 + point>), and the axis read: ``axis``, else the one 3620 names."""
    params: dict[int, dict[str, str]] = {}
    pitch: dict[int, int] = {}
    for block in _fanuc_record(data, src):
        m = _FANUC_BLOCK.fullmatch(block)
        if m is None:
            msg = f"{src}: cannot read the block {block[:40]!r}"
            raise DataError(msg)
        number, rest = int(m.group(1)), m.group(3)
        if m.group(2) == "0":
            if not (re.fullmatch(r"P[-+]?\d+", rest) and number >= 10000):
                msg = f"{src}: pitch error data N{number} must be N<10000 + point>Q0P<integer>"
                raise DataError(msg)
            pitch[number - 10000] = int(rest[1:])
            continue
        pairs = _FANUC_AXIS_VALUE.findall(rest)
        if "".join(f"A{a}P{v}" for a, v in pairs) != rest:
            continue  # a parameter of no axis, or of another type: not the table's
        params[number] = dict(pairs)
    axes = list(params.get(3620, {}))
    name = axis if axis is not None else axes[0] if len(axes) == 1 else None
    if name is None:
        msg = f"{src}: parameter 3620 names axes {axes}; give the axis"
        raise DataError(msg)
    values = {n: float(v[name]) for n, v in params.items() if name in v}
    return values, pitch, name


def read_fanuc_param(data: bytes, src: str, options: PointOptions) -> PointTable:
    """A Fanuc parameter transfer file as the CNC reads it, for a rotary axis (``options.axis``,
    else the one 3620 names): 3620 (reference point), 3621 (3620 or 3620 + 1), 3622,
    3623 (magnification), 3624 (interval [deg]), 3625 (travel per rotation [deg]); the
    pitch data of points 3620 + 1..3622 (Q0 blocks N10000 + point), each the increment
    over the section ending there, summing to 0; 1851 (backlash) if given. Values are in
    the axis's detection unit (``options.detection_unit_deg``: the file does not state
    it); the compensation is the sum of the increments from the reference position (0
    deg) x magnification x detection unit; ``options.sign`` says whether it is the
    correction or the error. 1851 is the backlash added when the axis moves against its
    reference return direction (taken as +)."""
    values, pitch, axis = _fanuc_blocks(data, src, options.axis)
    missing = [n for n in range(3620, 3626) if n not in values]
    if missing:
        msg = f"{src}: axis {axis} lacks parameters {missing}"
        raise DataError(msg)
    ref, neg, far, mag = (int(values[n]) for n in range(3620, 3624))
    interval, turn = values[3624], values[3625]
    sections = far - ref
    if neg not in (ref, ref + 1) or sections < 2 or mag < 1 or \
            abs(interval * sections - turn) > 1e-9 * max(turn, 1.0):
        msg = (f"{src}: a rotary axis needs 3621 = 3620 or 3620 + 1, magnification >= 1 and "
               f"(3622 - 3620) x 3624 = 3625 (here {ref}, {neg}, {far}, {mag}, {interval}, {turn})")
        raise DataError(msg)
    lost = [p for p in range(ref + 1, far + 1) if p not in pitch]
    if lost:
        msg = f"{src}: no pitch error data for points {lost[:5]}"
        raise DataError(msg)
    inc = np.array([pitch[p] for p in range(ref + 1, far + 1)])
    if inc.sum() != 0:
        msg = f"{src}: the increments of points {ref + 1}..{far} sum to {inc.sum()}, not 0"
        raise DataError(msg)
    du = options.detection_unit_deg
    absolute = np.r_[0, np.cumsum(inc)] * mag * du * DEG
    positions = np.arange(sections + 1) * interval * DEG
    backlash = values[1851] * du * DEG if 1851 in values else None
    return PointTable(positions, absolute if options.sign == "correction" else -absolute,
                      backlash_rad=backlash, modulo_rad=turn * DEG)


def _heidenhain_table(data: bytes, src: str, columns: tuple[str, ...]
                      ) -> dict[str, list[str]]:
    """A HEIDENHAIN table (``BEGIN`` line, a header naming the columns, rows, ``[END]``)
    as its columns' fields, each field starting under its column's name and running to
    the next column's start; DataError if a column of ``columns`` is missing."""
    lines = data.decode("latin-1").splitlines()
    if len(lines) < 3 or not lines[0].startswith("BEGIN") or lines[-1].strip() != "[END]":
        msg = f"{src}: not a HEIDENHAIN table (BEGIN line, header, rows, [END])"
        raise DataError(msg)
    starts = {m.group(): m.start() for m in re.finditer(r"\S+", lines[1])}
    missing = [c for c in columns if c not in starts]
    if missing:
        msg = f"{src}: no {' or '.join(missing)} column"
        raise DataError(msg)
    bounds = sorted(starts.values()) + [1 << 30]
    return {name: [line[a:bounds[bounds.index(a) + 1]].strip() for line in lines[2:-1]]
            for name, a in starts.items() if name in columns}


def read_heidenhain_cma(data: bytes, src: str, axis: str) -> str:
    """A HEIDENHAIN assignment table (.CMA): the .COM table named in the axis's column on
    the one line marked active (``*`` in ACTIVE)."""
    table = _heidenhain_table(data, src, (axis, "ACTIVE"))
    active = [i for i, mark in enumerate(table["ACTIVE"]) if mark == "*"]
    if len(active) != 1:
        msg = f"{src}: {len(active)} lines marked active; the control takes one"
        raise DataError(msg)
    name = table[axis][active[0]]
    if not name:
        msg = f"{src}: the active line names no table for axis {axis}"
        raise DataError(msg)
    return name


def read_heidenhain(data: bytes, src: str, options: PointOptions) -> PointTable:
    """A HEIDENHAIN compensation value table (.COM): ``BEGIN`` line, a header naming the
    columns (each field starts under its name), rows, ``[END]``; AXISPOS [deg] and the
    axis's column [deg] (``options.axis``, else C); ``options.sign`` says whether the value
    is the correction or the error."""
    axis = options.axis or "C"
    table = _heidenhain_table(data, src, ("AXISPOS", axis))
    try:
        pos = np.array([float(v) for v in table["AXISPOS"]])
        val = np.array([float(v) for v in table[axis]])
    except ValueError:
        msg = f"{src}: a table field is not a number"
        raise DataError(msg) from None
    if len(pos) < 2:
        msg = f"{src}: fewer than 2 compensation points"
        raise DataError(msg)
    if len(pos) > 256:
        msg = f"{src}: {len(pos)} compensation points; a table holds 256"
        raise DataError(msg)
    modulo = 360.0 * DEG if pos[0] == 0.0 and pos[-1] == 360.0 else None
    return PointTable(pos * DEG, (val if options.sign == "correction" else -val) * DEG,
                      modulo_rad=modulo)


def read_siemens(data: bytes, src: str, options: PointOptions) -> PointTable:
    """A SINUMERIK ``$AA_ENC_COMP`` table: the points MIN + i x STEP [deg], each value the
    compensation added to the measuring system's actual value (K3, MSEC: a positive value
    moves the axis in the negative direction), i.e. the correction; modulo MAX - MIN
    when IS_MODULO is 1."""
    from enctools.models.romformats.readers import siemens_table

    step, lo, hi, modulo, vals = siemens_table(data, src)
    if not (step > 0 and np.all(np.isfinite(vals))):
        msg = f"{src}: STEP must be > 0 and every value a finite number"
        raise DataError(msg)
    positions = lo + step * np.arange(vals.size)
    return PointTable(positions * DEG, vals * DEG,
                      modulo_rad=(hi - lo) * DEG if modulo == 1 else None)


def read_acs(data: bytes, src: str, options: PointOptions) -> PointTable:
    """An ACS program's ERRORMAP1D map: points base + i x step [deg], values [deg];
    ``options.sign`` says whether a value is the correction or the error, its array is
    ``options.array_name``. No wrap is assumed."""
    from enctools.models.romformats.readers import acs_map

    base, step, vals = acs_map(data, options.array_name, src)
    if not (step > 0 and np.all(np.isfinite(vals))):
        msg = f"{src}: the map's step must be > 0 and every value a finite number"
        raise DataError(msg)
    positions = base + step * np.arange(vals.size)
    return PointTable(positions * DEG, (vals if options.sign == "correction" else -vals) * DEG)


#: IEC 61131-3 (TwinCAT 3) numbers: an LREAL literal or an integer
_ST_NUMBER = r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?"
_ST_FIELD = re.compile(r"(\w+)\s*:=\s*([\w.+-]+)", re.IGNORECASE)
_ST_DECLARATION = re.compile(r"(\w+)\s*:\s*(ARRAY\s*\[\s*(\d+)\s*\.\.\s*(\d+)\s*\]\s*OF\s*)?"
                             r"(\w+)\s*:=\s*(\(.*?\)|\[.*?\])\s*;", re.IGNORECASE | re.DOTALL)


def _st_fields(text: str, src: str) -> dict[str, str]:
    """``name := value`` pairs of one structure initialiser, names upper-cased (Structured
    Text is not case-sensitive); DataError on a name given twice."""
    fields: dict[str, str] = {}
    for name, value in _ST_FIELD.findall(text):
        if name.upper() in fields:
            msg = f"{src}: {name} is given twice in one initialiser"
            raise DataError(msg)
        fields[name.upper()] = value
    return fields


def _st_number(fields: dict[str, str], name: str, src: str) -> float:
    value = fields.get(name.upper())
    if value is None or not re.fullmatch(_ST_NUMBER, value):
        msg = f"{src}: {name} is missing or not a number ({value!r})"
        raise DataError(msg)
    return float(value)


def read_twincat_nc(data: bytes, src: str, options: PointOptions) -> PointTable:
    """A TwinCAT PLC declaration of MC_TableBasedPositionCompensation's table as the PLC
    compiles it: comments ``(* *)`` dropped; the one ST_PositionCompensationTableParameter
    (MinPosition, MaxPosition, NoOfTableElements, Direction, Modulo) and the one ARRAY
    [a..b] OF ST_PositionCompensationTableElement initialised element by element
    (Position, Compensation [deg]); the table equidistant and increasing from MinPosition
    to MaxPosition, its count the array's and NoOfTableElements; Direction both (a
    one-direction table is not read); Modulo TRUE wraps MaxPosition - MinPosition.
    ``options.sign`` says whether Compensation is the correction or the error."""
    text = re.sub(r"\(\*.*?\*\)", " ", data.decode("latin-1"), flags=re.DOTALL)
    decls = {m.group(5).upper(): m for m in _ST_DECLARATION.finditer(text)}
    param = decls.get("ST_POSITIONCOMPENSATIONTABLEPARAMETER")
    table = decls.get("ST_POSITIONCOMPENSATIONTABLEELEMENT")
    if param is None or table is None or table.group(2) is None:
        msg = (f"{src}: no initialised ST_PositionCompensationTableParameter and ARRAY OF "
               "ST_PositionCompensationTableElement")
        raise DataError(msg)
    p = _st_fields(param.group(6), src)
    lo, hi = _st_number(p, "MinPosition", src), _st_number(p, "MaxPosition", src)
    count = int(_st_number(p, "NoOfTableElements", src))
    if p.get("DIRECTION", "").upper().rsplit(".", 1)[-1] != "WORKDIRECTIONBOTH":
        msg = f"{src}: Direction {p.get('DIRECTION')!r}: only a table for both directions is read"
        raise DataError(msg)
    elements = re.findall(r"\(([^()]*)\)", table.group(6))
    rows = [_st_fields(e, src) for e in elements]
    pos = np.array([_st_number(r, "Position", src) for r in rows])
    val = np.array([_st_number(r, "Compensation", src) for r in rows])
    bounds = int(table.group(4)) - int(table.group(3)) + 1
    if not 2 <= count == pos.size == bounds:
        msg = (f"{src}: NoOfTableElements {count}, {pos.size} elements initialised, "
               f"ARRAY of {bounds}: they must agree (2 or more)")
        raise DataError(msg)
    step = np.diff(pos)
    if pos[0] != lo or pos[-1] != hi or not (np.all(step > 0)
                                            and np.ptp(step) <= 1e-9 * (hi - lo)):
        msg = f"{src}: the positions must run equidistant from MinPosition to MaxPosition"
        raise DataError(msg)
    modulo = p.get("MODULO", "FALSE").upper() == "TRUE"
    return PointTable(pos * DEG, (val if options.sign == "correction" else -val) * DEG,
                      modulo_rad=(hi - lo) * DEG if modulo else None)


#: a SINUMERIK machine data assignment line: an optional MD number (N32450), the
#: assignment, an optional line checksum (' and 4 hex digits), an optional ; comment
_MD_LINE = re.compile(r"(?:N\d+\s*)?\$MA_BACKLASH\[\s*(\d+)\s*,\s*(\w+)\s*\]\s*=\s*"
                      r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?:'[0-9A-Fa-f]{4})?\s*"
                      r"(?:;.*)?")


def read_siemens_backlash(data: bytes, src: str, table: bytes) -> float:
    """MD32450 $MA_BACKLASH [deg] of a SINUMERIK machine data file (``%_N_AX<n>_TEA_INI``
    first, assignment lines, ``;`` comments, M17) for the measuring system and axis the
    table ``table`` compensates (its ``$AA_ENC_COMP[e,N,axis]`` lines): the axis the
    file's name numbers, the value positive when the encoder leads the machine part."""
    lines = [ln.strip() for ln in data.decode("latin-1").splitlines()]
    name = re.fullmatch(r"%_N_(AX\d+)_TEA_INI", lines[0] if lines else "")
    if name is None:
        msg = f"{src}: not a machine data file of an axis (%_N_AX<n>_TEA_INI first)"
        raise DataError(msg)
    m = re.search(rb"^\s*\$AA_ENC_COMP\[\s*(\d+)\s*,\s*\d+\s*,\s*(\w+)\s*\]", table,
                  re.MULTILINE)
    if m is None:
        msg = f"{src}: the table beside it has no $AA_ENC_COMP line naming its axis"
        raise DataError(msg)
    zone, axis = int(m.group(1)), m.group(2).decode("latin-1")
    if axis != name.group(1):
        msg = f"{src}: holds the machine data of {name.group(1)}, the table compensates {axis}"
        raise DataError(msg)
    found = {}
    for line in lines[1:]:
        if not line or line.startswith(";") or line == "M17":
            continue
        md = _MD_LINE.fullmatch(line)
        if md is None or md.group(2) != axis:
            msg = f"{src}: cannot read {line[:40]!r} (an $MA_BACKLASH line of {axis})"
            raise DataError(msg)
        found[int(md.group(1))] = float(md.group(3))
    if zone not in found or not np.isfinite(found[zone]):
        msg = f"{src}: no $MA_BACKLASH[{zone},{axis}] (the table's measuring system)"
        raise DataError(msg)
    return found[zone]
