"""Limits on what an input FILE can make enctools allocate or loop over, in one place.

Every stream or table a command reads is checked against these before the work that
depends on them starts; a value beyond a limit is a one-line
:class:`~enctools.errors.DataError` (exit 2) naming the value and the limit. The
numbers are stated in man/enc-streams.5 (section LIMITS); change both together.

Rig files and command options have limits of their own (data/rig.py, cli/options.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import pyarrow as pa

from enctools.units import ANGLE_UNITS, DEG, LENGTH_UNITS, factor, is_length

# ------------------------------------------------------------------ the header

#: bytes of the JSON metadata of a stream header (key ``enctools``) [byte]
MAX_METADATA_BYTES = 16 << 20
#: nesting depth of the JSON metadata (objects and arrays inside each other) [levels]
MAX_METADATA_DEPTH = 64
#: columns of a stream [columns]
MAX_COLUMNS = 4096
#: characters of one field-metadata value (a head's ``encoder``, a ``unit``) [characters]
MAX_FIELD_TEXT = 4096

# ------------------------------------------------------------------ rows and bytes

#: rows of a stream that a command holds whole in memory (latency, points, fit-rbf,
#: compare, report): some 40 bytes a row for a few columns, under 500 MB [rows]
MAX_TABLE_ROWS = 5_000_000
#: rows of any stream, even one read batch by batch (about a day at 10 kHz) [rows]
MAX_STREAM_ROWS = 1_000_000_000
#: bytes of a Parquet, Arrow file or HDF5 stream arriving on a pipe, which is held in
#: memory to be read (it needs seeking; Arrow IPC streams are read as they come) [byte]
MAX_PIPE_BUFFER_BYTES = 256 << 20
#: rows of one Parquet row group [rows]
MAX_ROW_GROUP_ROWS = 4 << 20
#: bytes of one Parquet row group decoded, as its footer gives them: 4 Mi rows of 8
#: float64 columns [byte]
MAX_ROW_GROUP_BYTES = 256 << 20
#: bytes of a Parquet column chunk read at a time: the decoder reads a row group's
#: column chunks this much at a time, a page at a time, not each whole (which held a
#: few times the row group's decoded bytes) [byte]
PARQUET_READ_BYTES = 1 << 20
#: bytes of one batch a stream is read in, and of one Parquet row group written: fewer
#: rows than :data:`~enctools.data.streams.BATCH_ROWS` when the rows are wide (thousands of
#: head columns) [byte]
BATCH_BYTES = 8 << 20


def batch_rows(schema: pa.Schema, most: int) -> int:
    """Rows of a batch of ``schema`` within :data:`BATCH_BYTES` (at most ``most``): a
    column of variable width counted as 16 bytes a row [rows]."""
    width = 0
    for field in schema:
        try:
            width += max(field.type.bit_width // 8, 1)
        except ValueError:  # strings, lists: no fixed width
            width += 16
    return max(1, min(most, BATCH_BYTES // max(width, 1)))


def check_row_group(group: Any, source: str) -> None:
    """DataError unless the row group (pyarrow's RowGroupMetaData) is within the rows
    and decoded bytes a command reads of one (the Parquet decoder's time and pages)."""
    from enctools.errors import DataError

    for value, most, what in ((group.num_rows, MAX_ROW_GROUP_ROWS, "rows"),
                              (group.total_byte_size, MAX_ROW_GROUP_BYTES, "bytes decoded")):
        if value > most:
            msg = (f"{source}: a Parquet row group of {value} {what}; at most {most} are "
                   "read (rewrite it with smaller row groups)")
            raise DataError(msg)


#: bytes of one HDF5 chunk once decoded (read whole by libhdf5) [byte]
MAX_HDF5_CHUNK_BYTES = 16 << 20
#: decoded bytes of an HDF5 column per byte it takes in the file, plus
#: :data:`HDF5_EXPANSION_SLACK`: refuses a file whose columns are mostly fill value
#: or compressed beyond what real readings compress to [ratio]
MAX_HDF5_EXPANSION = 1000
#: decoded bytes every HDF5 column may hold whatever its size in the file [byte]
HDF5_EXPANSION_SLACK = 1 << 20

#: rows of a model stream (RBF centres or harmonics), each evaluated at every address
#: of a correction table [rows]
MAX_MODEL_TERMS = 10_000

# ------------------------------------------------------------------ text tables

#: bytes of one field of a CSV or TSV table (a points table's line, a string) [byte]
MAX_CSV_FIELD_BYTES = 128 << 10
#: bytes of a CSV points table read without a sidecar (read whole) [byte]
MAX_CSV_BYTES = 256 << 20
#: bytes of one line of a CSV or TSV stream (read with its sidecar, block by block) [byte]
MAX_CSV_LINE_BYTES = 1 << 20

# ------------------------------------------------------------------ values

#: largest count a head column may hold in magnitude (2^62: differences of two counts
#: and sums of a few heads stay within int64, and counts * 2 pi / counts_per_rev
#: stays exact enough in float64) [count]
MAX_ABS_COUNT = 1 << 62
#: largest magnitude of a deviation, autocollimator reading or model weight: a
#: full turn (1 296 000 arcsec) [arcsec]
MAX_ABS_ARCSEC = 1_296_000.0
#: largest magnitude of an angle in a stream (a position, a grid angle, a target):
#: a million turns [deg]
MAX_ABS_DEG = 360e6
#: the same in radians [rad]
MAX_ABS_RAD = MAX_ABS_DEG * DEG
#: largest magnitude of a time [s] (t of readings: some 30 years)
MAX_ABS_SECONDS = 1e9
#: largest magnitude of a displacement (a probe reading, a radial error) [m]
MAX_ABS_METRES = 1.0
#: a linear axis's positions and deviations [m] (a points stream in mm and um)
MAX_ABS_LENGTH_M = 100.0
#: largest magnitude of a raw quadrature signal sample (and of an ADC's rail) [V]
MAX_ABS_VOLTS = 1e12

#: the values each column of a kind may hold, by column name or by role: (min, max,
#: unit), both inclusive; infinities are refused too, and NaN but in the columns of
#: :data:`NAN_ALLOWED` (a deviation curve marks its empty angle bins with NaN).
#: Checked batch by batch as a stream is read and as one is written (data/streams.py).
VALUE_RANGES: dict[str, dict[str, tuple[float, float, str]]] = {
    "readings": {
        "t": (-MAX_ABS_SECONDS, MAX_ABS_SECONDS, "s"),
        "head": (-MAX_ABS_COUNT, MAX_ABS_COUNT, "count"),
        "autocollimator": (-MAX_ABS_ARCSEC, MAX_ABS_ARCSEC, "arcsec"),
        "probe": (-MAX_ABS_METRES, MAX_ABS_METRES, "m"),
        "signal": (-MAX_ABS_VOLTS, MAX_ABS_VOLTS, "V"),
        "target": (-MAX_ABS_RAD, MAX_ABS_RAD, "rad"),
    },
    "deviations": {
        "theta": (-MAX_ABS_RAD, MAX_ABS_RAD, "rad"),
        "deviation": (-MAX_ABS_ARCSEC, MAX_ABS_ARCSEC, "arcsec"),
        "radial": (-MAX_ABS_METRES * 1e9, MAX_ABS_METRES * 1e9, "nm"),
    },
    "points": {
        "position": (-MAX_ABS_RAD, MAX_ABS_RAD, "rad"),
        "deviation": (-MAX_ABS_ARCSEC, MAX_ABS_ARCSEC, "arcsec"),
        "reference": (-MAX_ABS_RAD, MAX_ABS_RAD, "rad"),
    },
    "model": {
        "centre": (-MAX_ABS_RAD, MAX_ABS_RAD, "rad"),
        "weight": (-MAX_ABS_ARCSEC, MAX_ABS_ARCSEC, "arcsec"),
        "weight_sin": (-MAX_ABS_ARCSEC, MAX_ABS_ARCSEC, "arcsec"),
    },
}


# ------------------------------------------------------------------ field metadata


@dataclass(frozen=True)
class Range:
    """The values a field-metadata key may take: ``type`` int, float or text; ``min``
    and ``max`` inclusive, in ``unit``; ``choices`` for text with a fixed set."""

    type: str
    min: float = -math.inf
    max: float = math.inf
    unit: str = ""
    choices: tuple[str, ...] = ()

    def describe(self) -> str:
        if self.choices:
            return " or ".join(self.choices)
        if self.type == "text":
            return f"text of at most {MAX_FIELD_TEXT} characters"
        what = "an integer" if self.type == "int" else "a number"
        unit = f" {self.unit}" if self.unit else ""
        return f"{what} in [{_num(self.min)}, {_num(self.max)}]{unit}"


def _num(x: float) -> str:
    return f"{int(x)}" if float(x).is_integer() and abs(x) < 1e19 else f"{x:g}"


#: the field-metadata keys of each role (schemas/*.json names which a role requires)
#: and the values they may take; keys not named here are kept as text.
FIELD_RANGES: dict[str, dict[str, Range]] = {
    "head": {
        "encoder": Range("text"),
        "alpha_deg": Range("float", -360.0, 360.0, "deg"),
        "counts_per_rev": Range("int", 16, 1 << 40, "count"),
        "periods_per_rev": Range("int", 1, 1 << 32, "period"),
        "interpolation": Range("int", 1, 1 << 32, "count/period"),
        "radius_m": Range("float", 1e-4, 100.0, "m"),
        "zero_count": Range("int", -(1 << 40), 1 << 40, "count"),
    },
    "probe": {
        "arm_m": Range("float", 0.0, 100.0, "m"),  # 0: refused by the method that needs it
        "side": Range("int", -1, 1, ""),
    },
    "uncertainty": {  # an expanded uncertainty's U = k u: Student's k at dof, its coverage
        "dof": Range("float", 1.0, math.inf, ""),
        "k": Range("float", 1.0, 1000.0, ""),
        "coverage": Range("float", 0.5, 0.9999, ""),
    },
    "signal": {
        "head": Range("text"),
        "component": Range("text", choices=("cos", "sin")),
        # the ADC's rails of the channel (optional): the bound of a signal sample
        "rail_low_v": Range("float", -MAX_ABS_VOLTS, MAX_ABS_VOLTS, "V"),
        "rail_high_v": Range("float", -MAX_ABS_VOLTS, MAX_ABS_VOLTS, "V"),
        # a head without a counts column (a user's table of signals): its periods a turn
        "periods_per_rev": Range("int", 1, 1 << 32, "period"),
        # a linear scale's signal period (optional): its error in nm (enc interp-check)
        "signal_period_nm": Range("float", 1.0, 1e9, "nm"),
    },
}

#: (kind, column name or role) whose NaN values mean "no value" rather than a fault
#: (a sweep's autocollimator has no face in view, a probe reading may be missing)
NAN_ALLOWED = {("deviations", "deviation"), ("deviations", "radial"),
               ("readings", "autocollimator"), ("readings", "probe")}


def value_checks(kind: str, schema: Any) -> list[tuple[str, float, float, str, bool]]:
    """The columns of a stream whose values :data:`VALUE_RANGES` bounds: (name, min, max,
    unit, NaN allowed), by column name first, else by the role in its field metadata."""
    ranges = VALUE_RANGES.get(kind, {})
    out = []
    for f in schema:
        role = (f.metadata or {}).get(b"role", b"").decode()
        key = f.name if f.name in ranges else role
        if key in ranges:
            lo, hi, unit = ranges[key]
            have = (f.metadata or {}).get(b"unit", b"").decode()
            if have != unit and have in ANGLE_UNITS and unit in ANGLE_UNITS:
                # an older schema's angle (points v1: deg): the same bound in its unit
                k = factor(unit, have)
                lo, hi, unit = lo * k, hi * k, have
            elif is_length(have) and unit in ANGLE_UNITS:
                # a linear axis's position [mm] or deviation [um] (points v4)
                hi = MAX_ABS_LENGTH_M / LENGTH_UNITS[have]
                lo, unit = -hi, have
            out.append((f.name, lo, hi, unit, (kind, key) in NAN_ALLOWED))
    return out


def check_missing(batch: Any, source: str) -> None:
    """No value of a record batch (or a table) missing: a null is refused in every column
    (a stream marks a missing reading with NaN, in the columns that allow one); a
    DataError naming the column and the count."""
    from enctools.errors import DataError

    for name, col in zip(batch.schema.names, batch.columns, strict=True):
        if col.null_count:
            msg = (f"{source}: column {name!r} has {col.null_count} missing value(s) (null); "
                   "a stream marks a missing reading with NaN where its column allows one "
                   "(enc-streams(5), LIMITS)")
            raise DataError(msg)


#: integer values of a column from which Arrow's min_max checks them: fewer are not worth
#: importing pyarrow.compute for (some 30 ms at start-up)
_MIN_ARROW_CHECK = 1 << 15


def _ints_within(chunks: list[Any], lo: float, hi: float) -> bool:
    """Whether integer arrays lie within [lo, hi] (compared as float64, as numpy compares
    them): Arrow's min_max, one pass where numpy's int64 min and max take two slow ones."""
    import pyarrow.compute as pc

    for chunk in chunks:
        extremes = pc.min_max(chunk)
        low, high = extremes["min"].as_py(), extremes["max"].as_py()
        if low is None or not (float(low) >= lo and float(high) <= hi):
            return False
    return True


def check_batch(batch: Any, checks: list[tuple[str, float, float, str, bool]],
                source: str) -> None:
    """Every bounded column of a record batch (or a table) finite and in its range
    (DataError naming the column, the value and the range)."""
    import numpy as np

    from enctools.errors import DataError

    for name, lo, hi, unit, nan_ok in checks:
        col = batch.column(name)
        if col.null_count or len(col) == 0:
            continue
        chunks = getattr(col, "chunks", [col])  # a table's column: its batches' arrays
        if (pa.types.is_integer(col.type) and len(col) >= _MIN_ARROW_CHECK
                and _ints_within(chunks, lo, hi)):
            continue
        a = (chunks[0].to_numpy(zero_copy_only=False) if len(chunks) == 1 else
             np.concatenate([c.to_numpy(zero_copy_only=False) for c in chunks]))
        if a.dtype.kind not in "iuf":
            continue
        if nan_ok and a.dtype.kind == "f":
            a = a[~np.isnan(a)]
            if a.size == 0:
                continue
        if a.min() >= lo and a.max() <= hi:  # NaN fails both
            continue
        bad = a[~((a >= lo) & (a <= hi))][0]
        shown = "NaN" if np.isnan(bad) else str(bad)
        msg = (f"{source}: column {name!r} holds {shown} {unit}; values must be finite and "
               f"within [{_num(lo)}, {_num(hi)}] {unit} (enc-streams(5), LIMITS)").replace(
                   " ;", ";")
        raise DataError(msg)
