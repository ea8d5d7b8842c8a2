"""The runs of a nightly history as read (:class:`History`): its schema, and the text,
records and batches that ``enc report`` and ``enc history show`` make of it, whichever
layout they were read from (:mod:`.history`, :mod:`.history_hive`)."""

from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.report.numbers import fmt_each

SCHEMA = pa.schema([
    pa.field("run_id", pa.string()),
    pa.field("time", pa.timestamp("us", tz="UTC")),
    pa.field("host", pa.string()),
    pa.field("rig", pa.string()),
    pa.field("status", pa.string()),
    pa.field("exit_code", pa.int32()),
    pa.field("pp", pa.float64(), metadata={"unit": "arcsec"}),
    pa.field("std", pa.float64(), metadata={"unit": "arcsec"}),
    pa.field("mean", pa.float64(), metadata={"unit": "arcsec"}),
    pa.field("max_abs", pa.float64(), metadata={"unit": "arcsec"}),
    pa.field("drift_pp", pa.float64(), metadata={"unit": "arcsec"}),
    pa.field("drift_max", pa.float64(), metadata={"unit": "arcsec"}),
    pa.field("tolerance", pa.float64(), metadata={"unit": "arcsec"}),
    pa.field("campaign", pa.string()),
    pa.field("summary_json", pa.string()),
])


#: the width of a figure's column in the text (0.003100 and -12.35 fit; a longer one
#: widens its row)
_WIDTH = 9
#: the rows above which a history is read batch by batch rather than whole (when its
#: files are in time order, each sorted and none overlapping the next: the layout's)
STREAM_ROWS = 100_000
#: the rows of one batch read [rows]
BATCH_ROWS = 65_536


@dataclass
class History:
    """The runs of a history folder, oldest first.

    Held whole (``_table``) or, for a large history whose files are in time order, as the
    ordered file fragments read batch by batch (:meth:`batches`): memory then grows with
    a batch, not with the runs. ``scale``: the factor from arcsec to ``unit``.
    """

    folder: str
    _table: pa.Table | None
    skipped: list[str] = field(default_factory=list)
    unit: str = "arcsec"  # of the figures (enc report --unit shows another)
    rig: str | None = None               # the rig read (None: every rig)
    since: _dt.datetime | None = None    # the earliest run read (None: every run)
    scale: float = 1.0                   # arcsec -> unit
    _fragments: list[Any] = field(default_factory=list)  # (fragment, schema, filter) in order
    _runs: int = 0

    @property
    def runs(self) -> int:
        return self._table.num_rows if self._table is not None else self._runs

    @property
    def table(self) -> pa.Table:
        """Every run read whole (memory in proportion to the runs)."""
        return pa.Table.from_batches(list(self.batches()), schema=SCHEMA_IN(self.unit))

    def batches(self, columns: list[str] | None = None) -> Any:
        """The runs oldest first as record batches of ``columns`` (default: all), their
        arcsec figures in ``unit``."""
        names = columns or SCHEMA.names
        if self._table is not None:
            for b in self._table.select(names).to_batches(BATCH_ROWS):
                yield _scaled(b, self.scale, self.unit)
            return
        for fragment, schema, wanted in self._fragments:
            for b in fragment.to_batches(schema=schema, filter=wanted, columns=names,
                                         batch_size=BATCH_ROWS, batch_readahead=1,
                                         fragment_readahead=1, use_threads=False):
                if b.num_rows:
                    # per column: RecordBatch.cast is pyarrow 16's, this runs on 14
                    yield _scaled(pa.record_batch([b.column(n).cast(SCHEMA.field(n).type)
                                                   for n in names],
                                                  schema=pa.schema([SCHEMA.field(n)
                                                                    for n in names])),
                                  self.scale, self.unit)

    def column(self, name: str) -> np.ndarray:
        return self.table.column(name).to_numpy(zero_copy_only=False)

    def times(self) -> np.ndarray:
        """Run times as numpy datetime64 [us] (UTC, naive)."""
        return self.table.column("time").cast(pa.timestamp("us")).to_numpy(
            zero_copy_only=False)

    def to_records(self) -> list[dict[str, Any]]:
        return [r for b in self.batches([n for n in SCHEMA.names if n != "summary_json"])
                for r in _records(b)]

    def filters_text(self) -> str:
        """The rig and date read, as " (rig NAME, since TIME)", or nothing for every run."""
        said = ([f"rig {self.rig}"] if self.rig is not None else []) + \
            ([f"since {self.since:%Y-%m-%dT%H:%M:%SZ}"] if self.since is not None else [])
        return f" ({', '.join(said)})" if said else ""

    def text_lines(self) -> list[str]:
        return list(self.iter_text_lines())

    def iter_text_lines(self) -> Any:
        """The text of the history line by line, read batch by batch."""
        yield (f"history {self.folder}{self.filters_text()}: {self.runs} run(s)"
               + (f", {len(self.skipped)} unreadable file(s) skipped" if self.skipped else ""))
        if not self.runs:
            return
        w = _WIDTH
        yield (f"  {'time (UTC)':<20} {'rig':<12} {'status':<11} {'p-p':>{w}} {'s':>{w}} "
               f"{'drift':>{w}} {'tol':>{w}}  [{self.unit}]")

        count, last, largest = 0, 0.0, -np.inf
        for b in self.batches(["time", "rig", "status", "pp", "std", "drift_max", "tolerance"]):
            yield from _text_rows(b, self.unit)
            drift = b.column("drift_max").to_numpy(zero_copy_only=False).astype(np.float64)
            drift = drift[np.isfinite(drift)]
            if drift.size:
                count, last = count + drift.size, float(drift[-1])
                largest = max(largest, float(drift.max()))
        if count >= 2:
            mark = '"' if self.unit == "arcsec" else f" {self.unit}"
            last_text, largest_text = fmt_each([last, largest], self.unit)
            yield (f"  drift: last {last_text}{mark}, largest {largest_text}{mark} "
                   f"over {count} runs")


def SCHEMA_IN(unit: str) -> pa.Schema:
    """:data:`SCHEMA` with its arcsec figures said to be in ``unit``."""
    return pa.schema([f.with_metadata({"unit": unit}) if f.metadata else f for f in SCHEMA])


def _scaled(batch: pa.RecordBatch, k: float, unit: str) -> pa.RecordBatch:
    """``batch`` with its arcsec columns (by their field metadata) times ``k``, in ``unit``."""
    if unit == "arcsec" and k == 1.0:
        return batch
    arrays, fields = [], []
    for f, col in zip(batch.schema, batch.columns, strict=True):
        if f.metadata and f.metadata.get(b"unit") == b"arcsec":
            col = pa.array(col.to_numpy(zero_copy_only=False).astype(np.float64) * k, f.type)
            f = f.with_metadata({"unit": unit})
        arrays.append(col)
        fields.append(f)
    return pa.RecordBatch.from_arrays(arrays, schema=pa.schema(fields))


def _texts(column: Any) -> list[str]:
    """A column of strings as they show in the text: "-" for a null or empty one."""
    return [v or "-" for v in column.to_pylist()]


def _figures(column: Any, unit: str) -> list[str]:
    """A column of figures [``unit``] by the report's one rule (enc-report(1) NUMBERS: four
    significant digits of each, a run carrying no U; the HTML's strings), "-" for a
    missing or non-finite one."""
    return fmt_each(column.to_numpy(zero_copy_only=False), unit, "-")


def _text_rows(b: pa.RecordBatch, unit: str) -> list[str]:
    """The text lines of a batch of runs (time, rig, status, p-p, s, drift, tolerance
    [``unit``])."""
    import pyarrow.compute as pc

    seconds = b.column("time").cast(pa.timestamp("s", tz="UTC"), safe=False)
    times = _texts(pc.strftime(seconds, format="%Y-%m-%dT%H:%M:%SZ"))
    cols = zip(times, _texts(b.column("rig")), _texts(b.column("status")),
               *(_figures(b.column(n), unit) for n in ("pp", "std", "drift_max", "tolerance")),
               strict=True)
    w = _WIDTH
    return [f"  {t:<20} {r:<12} {s:<11} {pp:>{w}} {sd:>{w}} {d:>{w}} {tol:>{w}}"
            for t, r, s, pp, sd, d, tol in cols]


def _records(batch: pa.RecordBatch) -> list[dict[str, Any]]:
    rows = batch.to_pylist()
    if "time" in batch.schema.names:
        for r in rows:
            r["time"] = r["time"].strftime("%Y-%m-%dT%H:%M:%SZ") if r["time"] else None
    return rows
