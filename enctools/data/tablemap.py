"""Calibration points from a user's table: which column is what, in which unit.

The table settings of enc-points(1), TABLES, as one :class:`Mapping`: the columns of
the indicated angle (``column_position``, or ``column_measured`` beside a
``column_reference``), the reference angle, the deviation, the direction and the run,
each found by its title when no setting names it, with a unit per column. :func:`map_table` turns a
:class:`~enctools.data.tables.RawTable` into :class:`TablePoints`:

- the position of a point is the indicated angle (what the encoder reads), the index
  of a correction table; the reference angle is kept beside it;
- reference + measured: deviation = measured - reference, wrapped to +-180 deg; their
  constant zero offset (circular mean) is removed by default (``zero_offset="keep"``
  keeps it) and always reported; the positions are the measured angles mod 360 deg;
- position + deviation, or reference + deviation: the deviations as given (the offset,
  their mean, is reported and removed only with ``zero_offset="remove"``);
- a linear axis (:func:`linear_points`): position and deviation both lengths (mm, um,
  nm, by option, title or cell), read into mm and um; no reference or measured column.

Bad rows (not a number, NaN, out of range, a unit other than the column's), two points
at one position, and a reference that steps back where the indicated angle goes on are
refused with one line naming the line (row) or column.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from enctools.data import limits
from enctools.data.tables import UNITS, RawTable, cell_unit, title_unit
from enctools.data.text import printable
from enctools.errors import DataError, SettingsError
from enctools.units import LENGTH_UNITS, counts_factor, factor, is_length

#: the columns a table maps to, in the order they are looked for
ROLES = ("reference", "measured", "position", "deviation", "direction", "run")
ANGLES = ("position", "reference", "measured")
#: a column found by its title (without its unit): the whole name, or one of its words
_NAMES = {"position": {"position", "pos", "angle", "theta"},
          "deviation": {"deviation", "error", "err", "dev"},
          "direction": {"direction", "dir"}, "run": {"run"}}
_WORDS = {"reference": {"reference", "ref", "true", "stage", "nominal", "target"},
          "measured": {"measured", "indicated", "reading", "encoder", "sensor"}}
ZERO_OFFSET = ("remove", "keep")
#: the sign a deviation column is printed in: enctools' indicated - true (the default),
#: or ISO 230-2's and VDI/DGQ 3441's positional deviation x = actual - target, read as
#: its negative (enc-points(1), TABLES)
DEVIATION_SIGNS = ("indicated-true", "actual-target")
#: fields a points stream's metadata names only when given (streams made before them
#: read the same)
_LATER = ("decimal_comma", "columns_forward", "columns_reverse", "deviation_sign")
_ARCSEC_PER_DEG = factor("deg", "arcsec")


@dataclass(frozen=True)
class Mapping:
    """How a table's columns map to points; None: found by title, or the default.

    column_position, column_reference, column_measured, column_deviation,
    column_direction, column_run : the column of each role (:data:`ROLES`), by title
        (or 1-based number); the position is the indicated angle (the measured angle
        is the same, named beside a reference).
    position_unit, reference_unit, measured_unit : deg (default), rad, arcsec, arcmin,
        urad, mrad or counts; deviation_unit likewise, arcsec by default.
    counts_per_rev : counts a revolution, for a column in counts.
    zero_offset : remove or keep the constant offset between indicated and reference
        angle (None: remove for reference + measured, keep for a deviation column).
    decimal_comma : a text table's numbers have a decimal comma (``1,25``; the table is
        then separated by tabs, semicolons or blanks); None: a decimal point.
    columns_forward, columns_reverse : a wide table's deviation columns, one a run, of
        the forward (+1) and the reverse (-1) direction (run k: the k-th of each; a name
        may list several separated by commas): in place of a deviation, direction and
        run column.
    deviation_sign : the sign of the deviation column(s): ``indicated-true`` (None, the
        default: enctools') or ``actual-target`` (ISO 230-2's x_ij = P_ij - P_i, VDI/DGQ
        3441's), which is read as its negative.
    """

    column_position: str | None = None
    column_reference: str | None = None
    column_measured: str | None = None
    column_deviation: str | None = None
    column_direction: str | None = None
    column_run: str | None = None
    position_unit: str | None = None
    reference_unit: str | None = None
    measured_unit: str | None = None
    deviation_unit: str | None = None
    counts_per_rev: int | None = None
    zero_offset: str | None = None
    decimal_comma: bool | None = None
    columns_forward: tuple[str, ...] | None = None
    columns_reverse: tuple[str, ...] | None = None
    deviation_sign: str | None = None

    def column(self, role: str) -> str | None:
        """The column named for ``role`` (None: found by its title)."""
        return getattr(self, f"column_{role}")

    @staticmethod
    def option(role: str) -> str:
        """The setting naming a role's column (or a wide table's ``columns_forward``,
        ``columns_reverse``), as a field between backticks."""
        return f"`{role}`" if role.startswith("columns_") else f"`column_{role}`"

    def __post_init__(self) -> None:
        for role in (*ANGLES, "deviation"):
            unit = getattr(self, f"{role}_unit")
            if unit is not None and unit not in UNITS:
                msg = f"`{role}_unit` must be one of {', '.join(UNITS)}, not {unit!r}"
                raise SettingsError(msg)
            if unit == "counts" and self.counts_per_rev is None:
                msg = f"`{role}_unit` counts needs `counts_per_rev`"
                raise SettingsError(msg)
        lo, hi = 1, 1 << 40
        if self.counts_per_rev is not None and not lo <= self.counts_per_rev <= hi:
            msg = f"`counts_per_rev` must be in [{lo}, {hi}], not {self.counts_per_rev}"
            raise SettingsError(msg)
        if self.column_position is not None and self.column_measured is not None:
            msg = ("`column_position` and `column_measured` both name the indicated angle: "
                   "give one")
            raise SettingsError(msg)
        if self.zero_offset is not None and self.zero_offset not in ZERO_OFFSET:
            msg = f"`zero_offset` must be remove or keep, not {self.zero_offset!r}"
            raise SettingsError(msg)
        if self.deviation_sign is not None and self.deviation_sign not in DEVIATION_SIGNS:
            msg = (f"`deviation_sign` must be {' or '.join(DEVIATION_SIGNS)}, not "
                   f"{self.deviation_sign!r}")
            raise SettingsError(msg)
        self._check_wide()

    def _check_wide(self) -> None:
        """A wide table's columns give the deviation, direction and run: refused beside
        a column named for one of them."""
        if not self.wide():
            return
        named = [f"`column_{r}`" for r in ("deviation", "direction", "run")
                 if self.column(r) is not None]
        if named:
            msg = (f"`columns_forward` and `columns_reverse` give the deviation, direction and "
                   f"run of a wide table: not with {', '.join(named)}")
            raise SettingsError(msg)

    def wide(self) -> bool:
        """Whether a wide table's deviation columns are named (one a run and direction)."""
        return bool(self.columns_forward or self.columns_reverse)

    def given(self) -> list[str]:
        """The settings given, each as its field between backticks."""
        return [f"`{f.name}`" for f in fields(self) if getattr(self, f.name) is not None]

    def names_columns(self) -> bool:
        """Whether any column is named by a setting (then other columns are ignored)."""
        return any(self.column(r) is not None for r in ROLES)

    def to_meta(self) -> dict[str, Any]:
        """The mapping as given (None: found by title, or the default), a column by its
        role (``position``)."""
        return {f.name.removeprefix("column_"): getattr(self, f.name) for f in fields(self)
                if f.name not in _LATER or getattr(self, f.name) is not None}


@dataclass
class TablePoints:
    """Points of a table: angles [deg], deviations [arcsec], direction, run.

    position_deg : the indicated angle; reference_deg : the reference angle;
    deviation : indicated - reference [arcsec], less the zero offset when removed;
    zero_offset_arcsec : the constant offset between indicated and reference angle
    (circular mean of indicated - reference) [arcsec]; columns : role -> title used.
    """

    position_deg: np.ndarray
    reference_deg: np.ndarray
    deviation: np.ndarray
    direction: np.ndarray
    run: np.ndarray
    zero_offset_arcsec: float
    offset_removed: bool
    columns: dict[str, str]
    units: dict[str, str]
    #: "rotary"; or "linear": positions (``position_deg``, ``reference_deg``) in mm,
    #: deviations and the zero offset (``zero_offset_arcsec``) in um
    axis: str = "rotary"

    def meta(self) -> dict[str, Any]:
        """What the points stream's metadata says of the table (enc-streams(5), points)."""
        offset = "zero_offset_um" if self.axis == "linear" else "zero_offset_arcsec"
        return {"columns": dict(self.columns), "units": dict(self.units),
                offset: self.zero_offset_arcsec, "zero_offset_removed": self.offset_removed}


def _options_line() -> str:
    return ("map them with `column_position` COL `column_deviation` COL, or "
            "`column_reference` COL `column_measured` COL (or `column_reference` COL "
            "`column_deviation` COL), and `column_direction` COL, `column_run` COL; "
            "units: `position_unit`, `reference_unit`, `measured_unit`, `deviation_unit` "
            f"({', '.join(UNITS)}; counts with `counts_per_rev`)")


def _cannot_map(raw: RawTable, what: str, mapping: Mapping) -> DataError:
    found = ", ".join(repr(printable(t)) for t in raw.titles)
    return DataError(f"{raw.source}: {what}; columns found: {found}; {_options_line()}")


def _named(raw: RawTable, name: str, role: str, mapping: Mapping) -> int:
    """The column an option names: by title (any case), else by its 1-based number."""
    exact = [k for k, t in enumerate(raw.titles) if t == name]
    loose = [k for k, t in enumerate(raw.titles) if t.strip().lower() == name.strip().lower()]
    if exact or len(loose) == 1:
        return (exact or loose)[0]
    if name.isdigit() and 1 <= int(name) <= len(raw.titles):
        return int(name) - 1
    raise _cannot_map(raw, f"{mapping.option(role)} {printable(name)!r}: no such column",
                      mapping)


def _found(raw: RawTable, role: str, taken: set[int], mapping: Mapping) -> int | None:
    """The column found for ``role`` by its title (None: none; DataError: several)."""
    hits = []
    for k, t in enumerate(raw.titles):
        name = title_unit(t)[0]
        if k not in taken and (name in _NAMES.get(role, ()) or
                               set(name.replace("_", " ").split()) & _WORDS.get(role, set())):
            hits.append(k)
    if len(hits) > 1:
        titles = ", ".join(repr(printable(raw.titles[k])) for k in hits)
        raise _cannot_map(raw, f"columns {titles} could each be the {role}: name one with "
                          f"{mapping.option(role)}", mapping)
    return hits[0] if hits else None


def resolve(raw: RawTable, mapping: Mapping) -> dict[str, int]:
    """Role -> column index: as the options name them, else found by title. DataError
    naming the columns found and the options when the table does not map."""
    cols: dict[str, int] = {}
    for role in ROLES:
        name = mapping.column(role)
        if name is not None:
            cols[role] = _named(raw, name, role, mapping)
    for role in ROLES:
        known = {"indicated" if r in ("position", "measured") else r for r in cols}
        enough = role in (*ANGLES, "deviation") and len(
            known & {"indicated", "reference", "deviation"}) >= 2
        if role not in cols and not enough and (role != "position" or "measured" not in cols):
            k = _found(raw, role, set(cols.values()), mapping)
            if k is not None:
                cols[role] = k
    if "measured" in cols and "position" in cols:
        raise _cannot_map(raw, "both a position and a measured column: name one", mapping)
    have = {"indicated" if r in ("position", "measured") else r for r in cols}
    angles = sorted(have & {"indicated", "reference", "deviation"})
    if len(angles) != 2:
        found = f" (found: {', '.join(angles)})" if angles else ""
        raise _cannot_map(raw, "a table needs two of indicated angle, reference and "
                          f"deviation{found}", mapping)
    for role in (*ANGLES, "deviation"):
        if getattr(mapping, f"{role}_unit") is not None and role not in cols:
            msg = f"`{role}_unit`: the table has no {role} column"
            raise SettingsError(msg)
    unused = [t for k, t in enumerate(raw.titles) if k not in cols.values()]
    listed = ", ".join(repr(printable(t)) for t in unused)
    if unused and not mapping.names_columns():
        raise _cannot_map(raw, f"unknown column(s) {listed}", mapping)
    if unused:
        logging.getLogger("enctools").info("%s: columns not used: %s", raw.source, listed)
    return cols


# ------------------------------------------------------------------------- values


def _unit(raw: RawTable, k: int, role: str, mapping: Mapping) -> str | None:
    """A column's unit: its option's and its title's, which must agree (None: neither)."""
    given = getattr(mapping, f"{role}_unit")
    said = title_unit(raw.titles[k])[1]
    if given is not None and said is not None and given != said:
        msg = (f"{raw.source}: column {printable(raw.titles[k])!r}: its title says {said}, "
               f"`{role}_unit` says {given} (mixed units)")
        raise DataError(msg)
    return given or said


def cells(raw: RawTable, k: int, unit: str | None) -> tuple[np.ndarray, str | None]:
    """A column's numbers and unit: a text column's cells parsed, each unit written in a
    cell the column's (DataError naming the line otherwise)."""
    col = raw.columns[k]
    name = printable(raw.titles[k])
    if isinstance(col, np.ndarray):
        if col.dtype.kind != "f":
            msg = f"{raw.source}: column {name!r} is not numbers ({col.dtype})"
            raise DataError(msg)
        return col, unit
    out = np.empty(len(col))
    for i, cell in enumerate(col):
        parsed = cell_unit(cell, raw.decimal_comma)
        if parsed is None:
            hint = ("" if raw.decimal_comma or cell_unit(cell, True) is None else
                    " (a decimal comma: give `decimal_comma`)")
            msg = (f"{raw.source}: {raw.where(i)}, column {name!r}: {printable(cell)!r} is not "
                   f"a number{hint}")
            raise DataError(msg)
        out[i], said = parsed
        if said is not None and unit is not None and said != unit:
            msg = (f"{raw.source}: {raw.where(i)}, column {name!r}: {printable(cell)!r} is in "
                   f"{said}, the column in {unit} (mixed units)")
            raise DataError(msg)
        unit = unit or said
    return out, unit


def values(raw: RawTable, k: int, role: str, mapping: Mapping) -> tuple[np.ndarray, str]:
    """Column ``k`` as ``role``: angles [deg], deviations [arcsec] (a length: positions
    [mm], deviations [um]), checked finite and within the limits of enc-streams(5); and
    the unit it was read in."""
    raw_values, unit = cells(raw, k, _unit(raw, k, role, mapping))
    linear = is_length(unit)
    to = ("um" if linear else "arcsec") if role == "deviation" else ("mm" if linear else "deg")
    unit = unit or to
    scale = (counts_factor(mapping.counts_per_rev or 0, to) if unit == "counts"
             else factor(unit, to))
    with np.errstate(over="ignore", invalid="ignore"):
        out = raw_values * scale
    bound = (limits.MAX_ABS_LENGTH_M / LENGTH_UNITS[to] if linear else
             limits.MAX_ABS_ARCSEC if role == "deviation" else limits.MAX_ABS_DEG)
    bad = np.flatnonzero(~(np.abs(out) <= bound))
    if bad.size:
        i = int(bad[0])
        where = f"{raw.source}: {raw.where(i)}, column {printable(raw.titles[k])!r}"
        msg = (f"{where}: NaN or infinite" if not np.isfinite(raw_values[i]) else
               f"{where}: {raw_values[i]:g} {unit} is beyond +-{bound:g} {to} "
               "(enc-streams(5), LIMITS)")
        raise DataError(msg)
    return out, unit


def _whole(raw: RawTable, k: int, role: str, allowed: tuple[int, int]) -> np.ndarray:
    """A direction or run column: whole numbers within ``allowed`` (directions: +-1)."""
    v, _ = cells(raw, k, None)
    lo, hi = allowed
    ok = np.isfinite(v) & (v == np.round(v)) & (v >= lo) & (v <= hi)
    if role == "direction":
        ok &= np.abs(v) == 1
    bad = np.flatnonzero(~ok)
    if bad.size:
        i = int(bad[0])
        what = "+1 or -1" if role == "direction" else f"a whole number {lo}..{hi}"
        msg = (f"{raw.source}: {raw.where(i)}, column {printable(raw.titles[k])!r}: "
               f"{v[i]:g} is not {what}")
        raise DataError(msg)
    return v


# -------------------------------------------------------------------------- points


def _wrap_deg(x: np.ndarray) -> np.ndarray:
    """Angles [deg] wrapped to [-180, 180)."""
    return np.mod(x + 180.0, 360.0) - 180.0


def circular_mean_deg(x: np.ndarray) -> float:
    """The circular mean of angles [deg], in [-180, 180]."""
    rad = x * factor("deg", "rad")
    return float(np.angle(np.mean(np.exp(1j * rad)))) * factor("rad", "deg")


def map_table(raw: RawTable, mapping: Mapping) -> TablePoints:
    """The points of a table (module docstring): positions at the indicated angle; a wide
    table's (``columns_forward``, ``columns_reverse``) a point per run and direction of
    each row (:func:`melt`)."""
    if mapping.wide():
        long, long_mapping, said = melt(raw, mapping)
        points = map_table(long, long_mapping)
        for role in ("deviation", "direction", "run"):
            points.columns.pop(role, None)
        points.columns |= said["columns"]
        points.units["deviation"] = said["unit"]
        return points
    cols = resolve(raw, mapping)
    got = {r: values(raw, k, r, mapping) for r, k in cols.items() if r not in ("direction", "run")}
    _signed(raw, got, mapping)
    n = len(raw)
    direction = (_whole(raw, cols["direction"], "direction", (-1, 1)) if "direction" in cols
                 else np.ones(n))
    run = (_whole(raw, cols["run"], "run", (0, 2**31 - 1)) if "run" in cols else np.zeros(n))
    if any(is_length(u) for _, u in got.values()):
        points = linear_points(raw, mapping, got, (direction, run))
        points.columns = {r: raw.titles[k] for r, k in cols.items()}
        check_rows(raw, points, False)
        return points
    indicated = got.get("position", got.get("measured", (None, "")))[0]
    reference = got["reference"][0] if "reference" in got else None
    if indicated is not None and reference is not None:
        diff = _wrap_deg(indicated - reference)
        offset = circular_mean_deg(diff)
        removed = mapping.zero_offset != "keep"
        dev = (_wrap_deg(diff - offset) if removed else diff) * _ARCSEC_PER_DEG
        indicated = np.mod(indicated, 360.0)
    else:
        dev = got["deviation"][0]
        offset = float(np.mean(dev)) / _ARCSEC_PER_DEG
        removed = mapping.zero_offset == "remove"
        if indicated is None:
            assert reference is not None  # resolve(): two of indicated, reference, deviation
            indicated = reference + dev / _ARCSEC_PER_DEG
        reference = indicated - dev / _ARCSEC_PER_DEG
        if removed:
            dev = dev - offset * _ARCSEC_PER_DEG
    points = TablePoints(indicated, reference, dev, direction.astype(np.int8),
                         run.astype(np.int32), offset * _ARCSEC_PER_DEG, removed,
                         {r: raw.titles[k] for r, k in cols.items()},
                         {r: u for r, (_, u) in got.items()})
    check_rows(raw, points, "reference" in cols)
    return points


def _signed(raw: RawTable, got: dict[str, tuple[np.ndarray, str]], mapping: Mapping) -> None:
    """The deviation of ``got`` in enctools' sign: a log printing ISO 230-2's x = actual -
    target (``deviation_sign`` actual-target) read as -x, indicated - true (the axis
    stands where its own scale reads the target: the target is the indicated position,
    the interferometer's reading the true one). SettingsError without a deviation
    column: a reference and a measured angle give their own sign."""
    if mapping.deviation_sign != "actual-target":
        return
    if "deviation" not in got:
        msg = (f"{raw.source}: `deviation_sign` is the sign of a deviation column; this table "
               "gives a reference and a measured angle, whose deviation is measured - "
               "reference")
        raise SettingsError(msg)
    dev, unit = got["deviation"]
    got["deviation"] = (-dev, unit)


def linear_points(raw: RawTable, mapping: Mapping, got: dict[str, tuple[np.ndarray, str]],
                  direction_run: tuple[np.ndarray, np.ndarray]) -> TablePoints:
    """The points of a linear axis: ``got`` (role -> values, unit read) a position [mm]
    and a deviation [um], both read from lengths (DataError naming the column that is
    not, or a reference or measured column, which a linear axis's table does not
    take). The deviation as given, its mean the offset (removed with ``zero_offset``
    remove); the reference position - deviation [mm]."""
    for role, (_, unit) in got.items():
        if not is_length(unit):
            msg = (f"{raw.source}: the {role} column is in {unit} and another in a length: a "
                   "linear axis's position and deviation are both lengths (mm, um, nm)")
            raise DataError(msg)
    for role in got:
        if role not in ("position", "deviation"):
            msg = (f"{raw.source}: a linear axis's table (lengths) takes its targets as "
                   f"`column_position` beside a deviation, not a {role} column")
            raise DataError(msg)
    if set(got) != {"position", "deviation"}:
        msg = f"{raw.source}: a linear axis's table needs a position and a deviation column"
        raise DataError(msg)
    position, dev = got["position"][0], got["deviation"][0]
    offset = float(np.mean(dev))
    removed = mapping.zero_offset == "remove"
    if removed:
        dev = dev - offset
    direction, run = direction_run
    return TablePoints(position, position - dev * factor("um", "mm"), dev,
                       direction.astype(np.int8), run.astype(np.int32), offset, removed, {},
                       {r: u for r, (_, u) in got.items()}, axis="linear")


def check_rows(raw: RawTable, p: TablePoints, has_reference: bool) -> None:
    """Two points at one position of one run and direction, and (with a reference column)
    a reference that steps back where the indicated angle goes on, are refused
    (DataError naming both lines)."""
    order = np.lexsort((p.position_deg, p.direction, p.run))
    a, b = order[:-1], order[1:]
    same = (p.run[a] == p.run[b]) & (p.direction[a] == p.direction[b])
    twice = np.flatnonzero(same & (p.position_deg[a] == p.position_deg[b]))
    if twice.size:
        i, j = int(a[twice[0]]), int(b[twice[0]])
        msg = (f"{raw.source}: {raw.where(j)} repeats the position of {raw.where(i)} "
               f"({p.position_deg[i]:.10g} {'mm' if p.axis == 'linear' else 'deg'}, "
               f"run {p.run[i]}, direction "
               f"{p.direction[i]:+d}): duplicate positions")
        raise DataError(msg)
    back = np.flatnonzero(same & (_wrap_deg(p.reference_deg[b] - p.reference_deg[a]) < 0))
    if has_reference and back.size:
        i, j = int(a[back[0]]), int(b[back[0]])
        msg = (f"{raw.source}: {raw.where(j)}: the reference angle jumps backwards "
               f"({p.reference_deg[i]:.10g} deg at {raw.where(i)} -> "
               f"{p.reference_deg[j]:.10g} deg) where the indicated angle goes on")
        raise DataError(msg)


# -------------------------------------------------------------------- wide tables

#: the titles of a melted table's deviation, direction and run (no text file has them)
_LONG = ("\x00deviation", "\x00direction", "\x00run")


def _wide_columns(raw: RawTable, names: tuple[str, ...], field: str, mapping: Mapping
                  ) -> list[int]:
    """The columns a wide table's setting names: each name a title (or number), else a
    list of them separated by commas."""
    out: list[int] = []
    for name in names:
        try:
            out.append(_named(raw, name, field, mapping))
        except DataError:
            if "," not in name:
                raise
            out += [_named(raw, piece, field, mapping) for piece in name.split(",")]
    return out


def melt(raw: RawTable, mapping: Mapping) -> tuple[RawTable, Mapping, dict[str, Any]]:
    """A wide table as a long one: a row per row and deviation column of
    ``columns_forward`` (direction +1) and ``columns_reverse`` (-1), the run the column's
    place in its list; the other columns repeated. The deviations are read here, each
    column in its own unit (title, cells or ``deviation_unit``), into arcsec; returns the
    long table, the mapping that maps it, and the columns and unit it says it used."""
    sides = [(+1, "forward", mapping.columns_forward or ()),
             (-1, "reverse", mapping.columns_reverse or ())]
    picked = [(d, run, k) for d, side, names in sides
              for run, k in enumerate(_wide_columns(raw, names, f"columns_{side}", mapping))]
    taken = [k for _, _, k in picked]
    if len(set(taken)) < len(taken):
        msg = f"{raw.source}: `columns_forward` and `columns_reverse` name a column twice"
        raise SettingsError(msg)
    read = {k: values(raw, k, "deviation", mapping) for k in taken}
    n = len(raw)
    keep = [k for k in range(len(raw.titles)) if k not in taken]
    columns: list[list[str] | np.ndarray] = []
    for k in keep:
        col = raw.columns[k]
        columns.append(np.tile(col, len(picked)) if isinstance(col, np.ndarray)
                       else list(col) * len(picked))
    columns += [np.concatenate([read[k][0] for _, _, k in picked]),
                np.repeat([float(d) for d, _, _ in picked], n),
                np.repeat([float(r) for _, r, _ in picked], n)]
    long = RawTable([raw.titles[k] for k in keep] + list(_LONG), columns,
                    np.tile(raw.lines, len(picked)), raw.source, raw.row_word,
                    raw.decimal_comma)
    given = {f.name: getattr(mapping, f.name) for f in fields(mapping)}
    units = sorted({read[k][1] for k in taken})
    linear = [is_length(u) for u in units]
    if any(linear) and not all(linear):
        msg = f"{raw.source}: the deviation columns mix lengths and angles ({', '.join(units)})"
        raise DataError(msg)
    given |= {"columns_forward": None, "columns_reverse": None,
              "deviation_unit": "um" if all(linear) else None,
              "column_deviation": _LONG[0], "column_direction": _LONG[1],
              "column_run": _LONG[2]}
    said = {"columns": {side: ", ".join(raw.titles[k] for d, _, k in picked if d == sign)
                        for sign, side, names in sides if names},
            "unit": ", ".join(units)}
    return long, Mapping(**given), said
