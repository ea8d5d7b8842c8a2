"""Tables as users have them, read as named columns (enc-points(1), TABLES).

- Text: CSV, TSV or columns separated by blanks; ``#`` comment lines and blank lines
  skipped; the first other line is the header when any of its fields is not a number
  (any titles), else the columns are named ``1``, ``2``, ... The delimiter is the
  header line's: a tab, else a comma, else a semicolon, else blanks.
- Binary: a Parquet, Arrow (file or stream) or HDF5 table without enctools metadata
  (HDF5: one-dimensional datasets of one length at the top or in the only group, or
  one compound dataset).

A column's unit may be in its title (``angle [deg]``, ``error (urad)``, ``position_deg``)
and each text cell may carry one (``12.5 deg``): :func:`title_unit`, :func:`cell_unit`.
:mod:`enctools.data.tablemap` maps the columns to calibration points. Cells stay text
here (binary columns: numbers) so that the mapping names the line of a bad one.
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from enctools.data import extent, limits, pipes
from enctools.data.text import first_line, printable
from enctools.errors import DataError
from enctools.units import COLUMN_UNITS

#: the units a column may be in: the angle units of enctools.units and counts
UNITS = COLUMN_UNITS
#: how units are spelt in titles and cells (lower case) -> the unit
ALIASES = {"deg": "deg", "degree": "deg", "degrees": "deg", "°": "deg",
           "rad": "rad", "radian": "rad", "radians": "rad",
           "arcsec": "arcsec", "arcsecond": "arcsec", "arcseconds": "arcsec", '"': "arcsec",
           "″": "arcsec", "asec": "arcsec",
           "arcmin": "arcmin", "arcminute": "arcmin", "arcminutes": "arcmin", "′": "arcmin",
           "''": "arcsec", "”": "arcsec", "′′": "arcsec", "’’": "arcsec",
           "'": "arcmin", "’": "arcmin", "º": "deg", "˚": "deg",
           "urad": "urad", "µrad": "urad", "μrad": "urad", "microrad": "urad",
           "mrad": "mrad", "milliradian": "mrad", "milliradians": "mrad",
           "counts": "counts", "count": "counts", "cnt": "counts", "lsb": "counts"}
#: lengths, as a linear axis's table gives its positions and deviations: recognised so
#: that they are refused, never read as an angle (enc-points(1), TABLES)
LENGTHS = {"nm": "nm", "nanometre": "nm", "nanometer": "nm", "um": "um", "µm": "um",
           "μm": "um", "micron": "um", "microns": "um", "micrometre": "um",
           "micrometer": "um", "mm": "mm", "millimetre": "mm", "millimeter": "mm"}
ALIASES |= LENGTHS
#: characters of a title or cell read for a unit (longer: a name, or not a number); bounds
#: the regular expressions' work on a hostile line
_LONGEST = 200
_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?"
                     r"|nan|inf|infinity))\s*(.*?)\s*$", re.IGNORECASE)
#: a sexagesimal angle as papers print it: 12°30′15.5″, −0°00′01.2″, 30′15″ (each part a
#: number and its unit, the units in decreasing order)
_PART = re.compile(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*([^\d\s.]+)")
_SEXAGESIMAL = ("deg", "arcmin", "arcsec")
#: what a pasted cell spells otherwise than Python reads it: the minus signs and dashes
#: a PDF gives for "-", and the spaces between a number and its unit
_PASTED = str.maketrans({"\u2212": "-", "\u2013": "-", "\u2012": "-", "\ufe63": "-",
                         "\uff0d": "-", "\u00a0": " ", "\u2009": " ", "\u202f": " ",
                         "\u2007": " "})


@dataclass
class RawTable:
    """A table's columns by title, in file order.

    titles : the column titles (``1``, ``2``, ... without a header line).
    columns : one per title: text cells (a text table) or numbers (a binary one).
    lines : the line of each row in the file (text, 1-based) or its row number (binary).
    source : the file, for messages; ``row_word``: ``line`` or ``row``.
    decimal_comma : whether a text cell's comma is its decimal mark (``1,25``).
    """

    titles: list[str]
    columns: list[list[str] | np.ndarray]
    lines: np.ndarray
    source: str
    row_word: str = "line"
    decimal_comma: bool = False

    def where(self, i: int) -> str:
        """Row ``i`` (0-based) as the file counts it: ``line 12`` or ``row 12``."""
        return f"{self.row_word} {int(self.lines[i])}"

    def __len__(self) -> int:
        return int(self.lines.size)


def title_unit(title: str) -> tuple[str, str | None]:
    """A title's name and the unit it names, if any: ``Reference Angle [degree]`` ->
    (``reference angle``, ``deg``); ``position_deg`` -> (``position``, ``deg``)."""
    text = title.strip().lower()
    if len(text) > _LONGEST:
        return text, None
    m = re.fullmatch(r"(.*?)\s*[\[(]\s*([^\])]*?)\s*[\])]", text)
    if m and m.group(2) in ALIASES:
        return m.group(1).strip(), ALIASES[m.group(2)]
    m = re.fullmatch(r"(.*?)[ _/]+([^ _/]+)", text)
    if m and m.group(2) in ALIASES and m.group(1):
        return m.group(1).strip(), ALIASES[m.group(2)]
    return text, None


def cell_unit(cell: str, decimal_comma: bool = False) -> tuple[float, str | None] | None:
    """A text cell's number and the unit written after it (None: no unit); None when
    the cell is not a number, with or without one of :data:`ALIASES` after it.

    Read as pasted from a paper: a Unicode minus or dash for the sign, a no-break or thin
    space before the unit, primes and degree signs (``1.2″``, ``−0.5′``), a sexagesimal
    angle (``12°30′15.5″``: its value in the unit of its first part); with
    ``decimal_comma``, ``1,25`` is 1.25.
    """
    if len(cell) > _LONGEST:
        return None
    text = cell.translate(_PASTED)
    if decimal_comma:
        text = text.replace(",", ".")
    m = _NUMBER.fullmatch(text)
    if m is None:
        return None
    unit = m.group(2).lower()
    if not unit or unit in ALIASES:
        return float(m.group(1)), (ALIASES[unit] if unit else None)
    return _sexagesimal(text)


def _sexagesimal(text: str) -> tuple[float, str] | None:
    """``[-]D°M′S″`` (or M′S″, D°M′) in the unit of its first part; None if it is not one."""
    body = text.strip()
    sign = -1.0 if body.startswith("-") else 1.0
    body = body.lstrip("+-")
    parts, end = [], 0
    for m in _PART.finditer(body):
        if m.start() != end:
            return None
        unit = ALIASES.get(m.group(2).lower())
        if unit not in _SEXAGESIMAL:
            return None
        parts.append((float(m.group(1)), _SEXAGESIMAL.index(unit)))
        end = m.end()
    if len(parts) < 2 or body[end:].strip():
        return None
    orders = [o for _, o in parts]
    if orders != sorted(set(orders)) or any(v >= 60 for v, _ in parts[1:]):
        return None
    first = orders[0]
    value = sum(v / 60.0 ** (o - first) for v, o in parts)
    return sign * value, _SEXAGESIMAL[first]


# ---------------------------------------------------------------------------- text


def read_text(path: str, decimal_comma: bool = False) -> RawTable:
    """A text table (CSV, TSV or blank-separated; ``#`` comments) as cells by column;
    with ``decimal_comma`` a comma is a number's decimal mark, never a delimiter."""
    return parse_text(_text(path), path, decimal_comma)


def parse_text(text: str, path: str, decimal_comma: bool = False) -> RawTable:
    """The table of a text already read from ``path`` (named in messages)."""
    numbered = [(k + 1, ln) for k, ln in enumerate(text.splitlines())
                if ln.strip() and not ln.lstrip().startswith("#")]
    if not numbered:
        msg = f"{path}: no points (the file is empty or only comments)"
        raise DataError(msg)
    if len(numbered) > limits.MAX_TABLE_ROWS:
        msg = f"{path}: {len(numbered)} lines; at most {limits.MAX_TABLE_ROWS} rows are read"
        raise DataError(msg)
    longest = max(numbered, key=lambda t: len(t[1]))
    if len(longest[1]) > limits.MAX_CSV_FIELD_BYTES:
        msg = (f"{path}: line {longest[0]} has {len(longest[1])} characters; a table line "
               f"is at most {limits.MAX_CSV_FIELD_BYTES}")
        raise DataError(msg)
    rows = _split([ln for _, ln in numbered], path, decimal_comma)
    if len(rows) != len(numbered):
        msg = f"{path}: a quoted field holds a line end (a table has one row a line)"
        raise DataError(msg)
    has_header = any(cell_unit(c, decimal_comma) is None for c in rows[0])
    titles = [c.strip() for c in rows[0]] if has_header else \
        [str(k + 1) for k in range(len(rows[0]))]
    data, lines = (rows[1:], numbered[1:]) if has_header else (rows, numbered)
    if not data:
        msg = f"{path}: no points after the header line"
        raise DataError(msg)
    if len(set(titles)) < len(titles):
        twice = next(t for t in titles if titles.count(t) > 1)
        msg = f"{path}: two columns are titled {printable(twice)!r}"
        raise DataError(msg)
    for (line, _), row in zip(lines, data):
        if len(row) != len(titles):
            msg = f"{path}: line {line} has {len(row)} fields, the header {len(titles)}"
            raise DataError(msg)
    columns: list[list[str] | np.ndarray] = [list(c) for c in zip(*data)]
    return RawTable(titles, columns, np.array([n for n, _ in lines]), path,
                    decimal_comma=decimal_comma)


def _text(path: str) -> str:
    p = Path(path)
    try:
        size = p.stat().st_size
        if size > limits.MAX_CSV_BYTES:
            msg = f"{path}: a table of {size} bytes; at most {limits.MAX_CSV_BYTES} are read"
            raise DataError(msg)
        return p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        msg = f"{path}: no such file"
        raise DataError(msg) from None
    except (OSError, UnicodeDecodeError) as exc:
        msg = (f"{path}: neither an Arrow, Parquet or HDF5 stream nor a text table "
               f"({first_line(exc)})")
        raise DataError(msg) from None


def _split(lines: list[str], path: str, decimal_comma: bool = False) -> list[list[str]]:
    """The fields of each line, by the header line's delimiter (a tab, a comma, a
    semicolon; with ``decimal_comma`` never a comma)."""
    head = lines[0]
    delimiters = ("\t", ";") if decimal_comma else ("\t", ",", ";")
    delimiter = next((d for d in delimiters if d in head), None)
    if delimiter is None:
        return [ln.split() for ln in lines]
    try:
        return [[f.strip() for f in r] for r in csv.reader(io.StringIO("\n".join(lines)),
                                                           delimiter=delimiter)]
    except csv.Error as exc:
        msg = f"{path}: not a CSV table ({exc})"
        raise DataError(msg) from None


# -------------------------------------------------------------------------- binary


def is_plain(path: str, fmt: str) -> bool:
    """Whether a Parquet, Arrow or HDF5 file holds a table without enctools metadata
    (False when it cannot be read: opening it as a stream says why)."""
    from enctools.data.header import META_KEY

    try:
        if fmt == "hdf5":
            import h5py

            from enctools.data.h5io import members

            with h5py.File(path, "r") as h5:
                return not any(isinstance(v, h5py.Group) and "kind" in v.attrs
                               for v in members(h5, path).values())
        schema = _arrow_schema(path, fmt)
    except Exception:  # noqa: BLE001 - any decoder failure: not a plain table
        return False
    return META_KEY not in (schema.metadata or {})


def _arrow_schema(path: str, fmt: str) -> Any:
    import pyarrow as pa

    from enctools.data.native import native_file  # any name the file system takes

    if fmt == "parquet":  # pyarrow.parquet only then: it imports the file systems and ssl
        import pyarrow.parquet as pq

        return pq.read_schema(native_file(path))
    with native_file(path) as f:
        reader = pa.ipc.open_file(f) if fmt == "arrow" else pa.ipc.open_stream(f)
        return reader.schema


def read_binary(path: str, fmt: str) -> RawTable:
    """A plain Parquet, Arrow or HDF5 table (:func:`is_plain`) as numbers by column."""
    try:
        named = _hdf5_columns(path) if fmt == "hdf5" else _arrow_columns(path, fmt)
    except DataError:
        raise
    except Exception as exc:  # noqa: BLE001 - a decoder's failure on a damaged file
        msg = f"{path}: truncated or corrupt {fmt} table ({first_line(exc)})"
        raise DataError(msg) from None
    if not named:
        msg = f"{path}: the {fmt} table has no columns"
        raise DataError(msg)
    lengths = {len(v) for v in named.values()}
    if len(lengths) > 1:
        msg = f"{path}: the {fmt} table's columns have different lengths"
        raise DataError(msg)
    n = lengths.pop()
    if n == 0:
        msg = f"{path}: the {fmt} table has no rows"
        raise DataError(msg)
    return RawTable(list(named), list(named.values()), np.arange(1, n + 1), path, "row")


def _check_rows(path: str, rows: int) -> None:
    if rows > limits.MAX_TABLE_ROWS:
        msg = f"{path}: {rows} rows; at most {limits.MAX_TABLE_ROWS} are read"
        raise DataError(msg)


def _arrow_columns(path: str, fmt: str) -> dict[str, np.ndarray]:
    import pyarrow as pa

    from enctools.data.native import native_file

    if fmt == "parquet":
        import pyarrow.parquet as pq

        with native_file(path) as f:
            metadata = pq.ParquetFile(f).metadata
        _check_rows(path, metadata.num_rows)
        with open(path, "rb") as raw:
            extent.check_parquet(raw, metadata, path)
        with native_file(path) as f:
            table = pq.read_table(f, use_threads=False)
    else:
        with native_file(path) as f:
            if fmt == "arrow":
                with open(path, "rb") as raw:
                    extent.check_arrow_file(raw, path)
                table = pa.ipc.open_file(f).read_all()
            else:
                reader = pa.ipc.open_stream(f)
                table = pa.Table.from_batches(list(pipes.one_stream(reader, f, path)),
                                              schema=reader.schema)
    _check_rows(path, table.num_rows)
    return {name: _numbers(table.column(name).to_numpy(zero_copy_only=False))
            for name in table.column_names if not name.startswith("__index_level_")}


def _numbers(values: np.ndarray) -> np.ndarray:
    """A binary column as float64 where it is numeric (else as it is: refused if mapped)."""
    return values.astype(np.float64) if values.dtype.kind in "iuf" else values


def _hdf5_columns(path: str) -> dict[str, np.ndarray]:
    import h5py

    from enctools.data.h5io import members

    with open(path, "rb") as raw:
        extent.check_hdf5(raw, path)
    with h5py.File(path, "r") as h5:
        top = members(h5, path)
        groups = [v for v in top.values() if isinstance(v, h5py.Group)]
        where = members(groups[0], path) if len(groups) == 1 and not any(
            isinstance(v, h5py.Dataset) for v in top.values()) else top
        sets = {k: v for k, v in where.items() if isinstance(v, h5py.Dataset)}
        compound = [v for v in sets.values() if v.dtype.names and len(v.shape) == 1]
        if len(compound) == 1:
            _check_rows(path, compound[0].shape[0])
            data = compound[0][()]
            return {str(n): _numbers(np.asarray(data[n])) for n in data.dtype.names}
        out = {}
        for k, v in sets.items():
            if len(v.shape) == 1 and not v.dtype.names:
                _check_rows(path, v.shape[0])
                out[str(k)] = _numbers(np.asarray(v[()]))
        return out
