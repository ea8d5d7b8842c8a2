"""A head's raw sin/cos signals from a user's table (enc-interp-check(1), TABLES).

An interferometer's or a scale's quadrature capture, as the instrument exports it: a
column of the cosine and one of the sine [V] (``cos``, ``sin``, ``cosine``, ``sine``,
``I``/``Q``, ``A``/``B``, ``Ua1``/``Ua2``, with a unit ``[V]`` or ``[mV]`` in the title if
any), other columns (time, position) left aside. :func:`signal_readings` turns it into
the signal columns of a readings table (role ``signal``, one head, components ``cos`` and
``sin``) that the Heydemann fit reads, with the signal periods a revolution the curve's
angle needs and the ADC's rails, if known, in their field metadata.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.arrays import arrow_array
from enctools.data.schemas import make_field
from enctools.data.tables import RawTable
from enctools.data.text import printable
from enctools.errors import DataError, SettingsError

#: titles (lower case, without their unit) found as each component
_NAMES = {"cos": {"cos", "cosine", "i", "a", "ua1", "cos_v", "x"},
          "sin": {"sin", "sine", "q", "b", "ua2", "sin_v", "y"}}
#: volt units a title may name, and their size [V]
_VOLTS = {"v": 1.0, "mv": 1e-3, "uv": 1e-6, "µv": 1e-6}
_TITLE = re.compile(r"(.*?)\s*[\[(]\s*([^\])]*?)\s*[\])]\s*")


@dataclass(frozen=True)
class SignalMapping:
    """Which columns of a table are a head's signals; None: found by title.

    column_cos, column_sin : the columns of the cosine and the sine (title or 1-based
        number).
    periods_per_rev : signal periods a revolution of the encoder (the curve's angle).
    head : the head's name in the output.
    """

    column_cos: str | None = None
    column_sin: str | None = None
    periods_per_rev: int | None = None
    head: str = "H1"

    def __post_init__(self) -> None:
        lo, hi = 1, 1 << 32
        if self.periods_per_rev is not None and not lo <= self.periods_per_rev <= hi:
            msg = f"`periods_per_rev` must be in [{lo}, {hi}], not {self.periods_per_rev}"
            raise SettingsError(msg)

    def given(self) -> list[str]:
        """The column settings given, each as its field between backticks."""
        return [f"`{f.name}`" for f in fields(self)
                if f.name.startswith("column_") and getattr(self, f.name) is not None]


def _name_unit(title: str) -> tuple[str, float]:
    """A title's name (lower case) and the size of its volt unit [V] (1: none named)."""
    text = title.strip().lower()
    m = _TITLE.fullmatch(text) if len(text) <= 200 else None
    if m and m.group(2) in _VOLTS:
        return m.group(1).strip(), _VOLTS[m.group(2)]
    return text, 1.0


def _column(raw: RawTable, role: str, mapping: SignalMapping) -> int:
    """The column of component ``role`` (cos, sin): as named, else by its title."""
    name = getattr(mapping, f"column_{role}")
    titles = raw.titles
    if name is not None:
        hits = [k for k, t in enumerate(titles) if t.strip().lower() == name.strip().lower()]
        if len(hits) == 1:
            return hits[0]
        if name.isdigit() and 1 <= int(name) <= len(titles):
            return int(name) - 1
        what = f"`column_{role}` {printable(name)!r}: no such column"
    else:
        hits = [k for k, t in enumerate(titles) if _name_unit(t)[0] in _NAMES[role]]
        if len(hits) == 1:
            return hits[0]
        what = (f"no {role} column found by its title" if not hits else
                f"columns {', '.join(repr(printable(titles[k])) for k in hits)} could each be "
                f"the {role}")
    found = ", ".join(repr(printable(t)) for t in titles)
    msg = (f"{raw.source}: {what}; columns found: {found}; name them with `column_cos` COL "
           "`column_sin` COL")
    raise DataError(msg)


def signal_readings(raw: RawTable, mapping: SignalMapping,
                    rails_v: tuple[float, float] | None = None
                    ) -> tuple[dict[str, Any], pa.Table]:
    """The signal columns [V] of ``mapping.head`` from a table, and the metadata of the
    readings they make (their source and the columns used).

    The columns carry role ``signal``, the head, the component, and the encoder's
    ``periods_per_rev`` when given (the curve's angle: without it, only the fit); the
    ADC's ``rails_v`` (low, high) [V] as ``rail_low_v``/``rail_high_v`` when known.
    Cells not numbers, and a NaN or infinite value, are refused naming the line.
    """
    from enctools.data.tablemap import cells

    if mapping.periods_per_rev is None:
        msg = (f"{raw.source}: a table of signals needs the signal periods a revolution, "
               "`periods_per_rev`, to give its error as an angle (a linear scale's: its "
               "`signal_period`, as a length)")
        raise SettingsError(msg)
    cols = {role: _column(raw, role, mapping) for role in ("cos", "sin")}
    if cols["cos"] == cols["sin"]:
        msg = f"{raw.source}: `column_cos` and `column_sin` name one column"
        raise DataError(msg)
    schema_fields, arrays = [], []
    for role, k in cols.items():
        values, said = cells(raw, k, None)
        if said is not None:
            msg = (f"{raw.source}: column {printable(raw.titles[k])!r} is in {said}; a signal "
                   "is a voltage")
            raise DataError(msg)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            msg = (f"{raw.source}: {raw.where(int(bad[0]))}, column "
                   f"{printable(raw.titles[k])!r}: NaN or infinite")
            raise DataError(msg)
        extra = {} if rails_v is None else {"rail_low_v": repr(float(rails_v[0])),
                                             "rail_high_v": repr(float(rails_v[1]))}
        schema_fields.append(make_field(f"{mapping.head}_{role}", pa.float64(), "V", "signal",
                                        head=mapping.head, component=role,
                                        periods_per_rev=str(mapping.periods_per_rev), **extra))
        arrays.append(arrow_array(values * _name_unit(raw.titles[k])[1], pa.float64()))
    schema = pa.schema(schema_fields)
    meta = {"source": f"table {raw.source}", "history": [],
            "table": {"columns": {r: raw.titles[k] for r, k in cols.items()}}}
    return meta, pa.Table.from_arrays(arrays, schema=schema)
