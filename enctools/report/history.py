"""The nightly history dataset: Parquet files, one file (one row) per run, in Hive
partitions ``rig=NAME/year=YYYY`` (:mod:`.partitions`), so that a fleet of rigs shares
one dataset that DuckDB, Spark or ``pyarrow.dataset`` read as it is.

Safe against two runs at once and against a crash mid-write without a lock: each
run writes its own uniquely named file (UTC time, host, process id, random suffix)
as a hidden temporary file in its partition folder, flushes it to disk, and renames it
into place (``os.replace`` is atomic within a file system). Readers see a run's file
whole or not at all; hidden (``.``, ``_``) files are ignored, and a file that cannot be
read is reported and skipped, never fatal.

Reading one rig (``rig``) opens that rig's folder only, and ``since`` prunes the
year folders before it and filters the rows on ``time``: both are pushed down to
``pyarrow.dataset``, so tabulating one rig costs the same in a fleet of ten rigs or a
thousand.

The layout before partitions (every ``run-*.parquet`` directly in the folder, with its
``rig`` column) is still read, and each such file is moved into its partition by the
next run appended.

Columns (one row per run): ``run_id``, ``time`` (UTC), ``host``, ``rig`` (the partition),
``status`` (ok / drift / error / interrupted: a signal / timeout: the campaign's time
limit), ``exit_code``, figures of the run's main curve [arcsec] (``pp``, ``std``
Bessel, ``mean``, ``max_abs``), drift against the stored calibration [arcsec]
(``drift_pp``, ``drift_max``: largest |current - stored| after removing the mean
offset), ``tolerance``, the campaign command and the whole summary as JSON; and
``year`` (the partition: the UTC year of ``time``) for the engines that read the folders.
"""

from __future__ import annotations

import datetime as _dt
import functools
import itertools
import logging
import os
import re
import secrets
import socket
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.files import write_atomic
from enctools.errors import DataError
from enctools.report.partitions import partition_folder, rig_folder

log = logging.getLogger("enctools")

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
#: the partition columns, from the folder names (``rig=NAME/year=YYYY``)
PARTITIONING = pa.schema([pa.field("rig", pa.string()), pa.field("year", pa.int32())])
#: the columns in each run's file: all but the partitions
FILE_SCHEMA = pa.schema([f for f in SCHEMA if f.name not in PARTITIONING.names])


def new_run_id(now: _dt.datetime | None = None) -> str:
    """A run id unique across hosts and processes: UTC time, host, pid, random."""
    now = now or _dt.datetime.now(_dt.UTC)
    host = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in socket.gethostname())
    return f"{now:%Y%m%dT%H%M%S}.{now.microsecond:06d}Z-{host}-{os.getpid()}-{secrets.token_hex(3)}"


def append_run(folder: str | os.PathLike[str], record: dict[str, Any]) -> Path:
    """Add one run to the history folder (created if needed); return the new file.

    ``record``: values for :data:`SCHEMA`'s columns (missing ones are null; ``rig``
    required; ``time`` a timezone-aware datetime, default now; ``run_id`` default
    :func:`new_run_id`). The file lands in its partition ``rig=NAME/year=YYYY`` and
    appears complete or not at all. Files of the layout before partitions are moved
    into theirs first.
    """
    import pyarrow.parquet as pq

    rec = dict(record)
    rec.setdefault("time", _dt.datetime.now(_dt.UTC))
    rec.setdefault("run_id", new_run_id(rec["time"]))
    rec.setdefault("host", socket.gethostname())
    unknown = set(rec) - set(SCHEMA.names)
    if unknown:
        msg = f"history: unknown column(s) {', '.join(sorted(unknown))}"
        raise DataError(msg)
    d = Path(folder)
    d.mkdir(parents=True, exist_ok=True)
    _remove_stale(d)
    migrate_flat_files(d)
    part = _partition(d, rec.get("rig"), rec["time"])
    part.mkdir(parents=True, exist_ok=True)
    _remove_stale(part)
    table = pa.table({f.name: pa.array([rec.get(f.name)], f.type) for f in FILE_SCHEMA},
                     schema=FILE_SCHEMA)
    final = part / f"run-{rec['run_id']}.parquet"
    write_atomic(final, lambda f: pq.write_table(table, f), durable=True)
    return final


def _write_rows(rows: pa.Table, where: Any) -> None:
    import pyarrow.parquet as pq

    pq.write_table(rows, where)


def _partition(d: Path, rig: Any, time: _dt.datetime) -> Path:
    """The partition folder of a run of ``rig`` at ``time`` (its UTC year)."""
    try:
        return partition_folder(d, str(rig or ""), time.astimezone(_dt.UTC).year)
    except ValueError as exc:
        msg = f"history: {exc}"
        raise DataError(msg) from None


def migrate_flat_files(d: Path) -> int:
    """Move the runs of the layout before partitions (``DIR/run-*.parquet`` with a
    ``rig`` column) into their partitions; return how many files were moved.

    Each is written whole in its partition before the old file is removed, so a reader
    meanwhile sees the run once or twice (:func:`read_history` keeps one), never not at
    all. A file that cannot be read or placed stays where it is, and is still read.
    """
    import pyarrow.parquet as pq

    moved = 0
    for p in sorted(d.glob("run-*.parquet")):
        try:
            t = pq.read_table(p)
            rigs = set(t.column("rig").to_pylist())
            times = t.column("time").cast(pa.timestamp("us", tz="UTC")).to_pylist()
            years = {x.year for x in times if x is not None}
            if len(rigs) != 1 or len(years) != 1 or None in times:
                continue
            part = _partition(d, rigs.pop(), times[0])
            rows = pa.table({f.name: (t.column(f.name).cast(f.type) if f.name in t.schema.names
                                      else pa.nulls(t.num_rows, f.type))
                             for f in FILE_SCHEMA}, schema=FILE_SCHEMA)
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError, OSError, KeyError, DataError):
            continue
        part.mkdir(parents=True, exist_ok=True)
        write_atomic(part / p.name, functools.partial(_write_rows, rows), durable=True)
        p.unlink(missing_ok=True)
        moved += 1
    if moved:
        log.info("history: moved %d run file(s) into the rig=/year= partitions", moved)
    return moved


_TEMPORARY = re.compile(r"\.run-.*\.parquet\.(\d+)@([A-Za-z0-9._-]+)\.[A-Za-z0-9_]+\.tmp")


def _remove_stale(d: Path, age_s: float = 86400.0) -> None:
    """Remove the temporary files of runs killed mid-write (``kill -9``, a power cut):
    at once when the process that wrote one no longer runs on this host, else after a day
    (another host's, or a name that records no writer)."""
    import time

    from enctools.data.files import process_gone
    now = time.time()
    for p in d.glob(".run-*.tmp"):
        m = _TEMPORARY.fullmatch(p.name)
        try:
            if (m is not None and process_gone(int(m.group(1)), m.group(2))) \
                    or now - p.stat().st_mtime > age_s:
                p.unlink()
                log.info("history: removed %s, left by a run that was killed", p.name)
        except OSError:
            pass


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
        yield (f"  {'time (UTC)':<20} {'rig':<12} {'status':<11} {'p-p':>7} {'s':>7} "
               f"{'drift':>7} {'tol':>7}  [{self.unit}]")

        count, last, largest = 0, 0.0, -np.inf
        for b in self.batches(["time", "rig", "status", "pp", "std", "drift_max", "tolerance"]):
            yield from _text_rows(b)
            drift = b.column("drift_max").to_numpy(zero_copy_only=False).astype(np.float64)
            drift = drift[np.isfinite(drift)]
            if drift.size:
                count, last = count + drift.size, float(drift[-1])
                largest = max(largest, float(drift.max()))
        if count >= 2:
            mark = '"' if self.unit == "arcsec" else f" {self.unit}"
            yield (f"  drift: last {last:.3f}{mark}, largest {largest:.3f}{mark} "
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


def _figures(column: Any) -> list[str]:
    """A column of figures with 3 decimals, "-" for a missing or non-finite one."""
    v = column.to_numpy(zero_copy_only=False).astype(np.float64)
    ok = np.isfinite(v)
    out = np.full(v.size, "-", dtype=object)
    out[ok] = np.char.mod("%.3f", v[ok]).astype(object)
    return [str(x) for x in out]


def _text_rows(b: pa.RecordBatch) -> list[str]:
    """The text lines of a batch of runs (time, rig, status, p-p, s, drift, tolerance)."""
    import pyarrow.compute as pc

    seconds = b.column("time").cast(pa.timestamp("s", tz="UTC"), safe=False)
    times = _texts(pc.strftime(seconds, format="%Y-%m-%dT%H:%M:%SZ"))
    cols = zip(times, _texts(b.column("rig")), _texts(b.column("status")),
               *(_figures(b.column(n)) for n in ("pp", "std", "drift_max", "tolerance")),
               strict=True)
    return [f"  {t:<20} {r:<12} {s:<11} {pp:>7} {sd:>7} {d:>7} {tol:>7}"
            for t, r, s, pp, sd, d, tol in cols]


def _records(batch: pa.RecordBatch) -> list[dict[str, Any]]:
    rows = batch.to_pylist()
    if "time" in batch.schema.names:
        for r in rows:
            r["time"] = r["time"].strftime("%Y-%m-%dT%H:%M:%SZ") if r["time"] else None
    return rows


def read_history(folder: str | os.PathLike[str], rig: str | None = None,
                 since: _dt.datetime | None = None) -> History:
    """The runs of a history folder, sorted by time: all, or those of ``rig`` at or
    after ``since`` (timezone-aware; a naive one is taken as UTC).

    Only the ``time`` column is read to order the files; a large history whose files
    are each in time order and follow one another is then read batch by batch as the
    report goes (:class:`History`), else whole and sorted.
    A missing folder is an error (exit 2); unreadable files are skipped with a warning.
    """
    d = Path(folder)
    if not d.is_dir():
        msg = f"`history_dir` {folder}: no such folder"
        raise DataError(msg)
    if since is not None and since.tzinfo is None:
        since = since.replace(tzinfo=_dt.UTC)
    skipped: list[str] = []
    flat = _read_flat(d, skipped)  # first: a file moved meanwhile is in a partition then
    if flat is None:
        probed: list[str] = []
        ordered = _ordered_fragments(d, rig, since, probed)
        if ordered is not None and ordered[1] > STREAM_ROWS:
            for said in probed:  # name NUL why: a name holds no NUL
                log.warning("history: skipping unreadable %s (%s)", *said.split("\0", 1))
            skipped = [said.split("\0", 1)[0] for said in probed]
            return History(str(folder), None, skipped, rig=rig, since=since,
                           _fragments=ordered[0], _runs=ordered[1])
    parts = _read_partitions(d, rig, since, skipped)
    if flat is not None:
        ids = parts.column("run_id")
        import pyarrow.compute as pc
        flat = flat.filter(_wanted(rig, since, with_year=False))
        flat = flat.filter(pc.invert(pc.is_in(flat.column("run_id"), value_set=ids)))
        parts = pa.concat_tables([parts, flat.cast(SCHEMA)])
    return History(str(folder), parts.sort_by("time"), skipped, rig=rig, since=since)


def _ordered_fragments(d: Path, rig: str | None, since: _dt.datetime | None,
                       skipped: list[str]) -> tuple[list[Any], int] | None:
    """The files of the runs wanted in time order, with the count of their runs, when each
    file's runs are in time order and each file's last is no later than the next one's
    first (the layout's: a file a run); else None. Reads the ``time`` column alone;
    unreadable files are named in ``skipped``."""
    dataset = _dataset(d, rig)
    if dataset is None:
        return [], 0
    wanted = _wanted(rig, since)
    spans = []
    for fragment in _row_groups(dataset, wanted, d, skipped):
        try:
            t = fragment.to_table(schema=dataset.schema, filter=wanted, columns=["time"])
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError, OSError) as exc:
            skipped.append(f"{os.path.relpath(fragment.path, d)}\0{str(exc)[:120]}")
            continue
        if not t.num_rows:
            continue
        us = t.column("time").cast(pa.timestamp("us", tz="UTC")).cast(pa.int64())
        if us.null_count:
            return None
        v = us.to_numpy()
        if v.size > 1 and not bool(np.all(v[1:] >= v[:-1])):
            return None
        spans.append((int(v[0]), int(v[-1]), v.size, fragment))
    spans.sort(key=lambda x: (x[0], x[1]))
    if any(a[1] > b[0] for a, b in itertools.pairwise(spans)):
        return None
    return [(f, dataset.schema, wanted) for *_, f in spans], sum(x[2] for x in spans)


def _wanted(rig: str | None, since: _dt.datetime | None, with_year: bool = True) -> Any:
    """The filter of ``rig`` and ``since`` as a dataset expression (None: every run)."""
    import pyarrow.dataset as ds

    wanted = None
    if rig is not None:
        wanted = ds.field("rig") == rig
    if since is not None:
        after = ds.field("time") >= pa.scalar(since, pa.timestamp("us", tz="UTC"))
        if with_year:  # prunes the year folders before it
            after = (ds.field("year") >= since.astimezone(_dt.UTC).year) & after
        wanted = after if wanted is None else wanted & after
    return wanted if wanted is not None else ds.scalar(True)


def _row_groups(dataset: Any, wanted: Any, d: Path, skipped: list[str]) -> Any:
    """The row groups of the dataset's files (each read on its own: memory of one)."""
    for fragment in dataset.get_fragments(filter=wanted):
        try:
            yield from fragment.split_by_row_group(filter=wanted, schema=dataset.schema)
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError, OSError) as exc:
            skipped.append(f"{os.path.relpath(fragment.path, d)}\0{str(exc)[:120]}")


def _dataset(d: Path, rig: str | None) -> Any:
    """The partitioned runs as a dataset (one rig: its folder only), or None."""
    import pyarrow.dataset as ds

    if rig is not None:
        try:
            folders = [d / rig_folder(rig)]
        except ValueError:
            folders = []
    else:  # every rig=... folder; files directly in DIR are of the layout before
        folders = sorted(p for p in d.glob("rig=*") if p.is_dir())
    folders = [p for p in folders if p.is_dir()]
    if not folders:
        return None
    schema = pa.unify_schemas([FILE_SCHEMA, PARTITIONING])
    parts = [ds.dataset(str(p), format="parquet", schema=schema, partition_base_dir=str(d),
                        partitioning=ds.partitioning(PARTITIONING, flavor="hive"))
             for p in folders]
    return parts[0] if len(parts) == 1 else ds.dataset(parts, schema=schema)


def _read_partitions(d: Path, rig: str | None, since: _dt.datetime | None,
                     skipped: list[str]) -> pa.Table:
    """The partitioned runs, filtered by the dataset scan; one rig: its folder only."""
    dataset = _dataset(d, rig)
    if dataset is None:
        return SCHEMA.empty_table()
    wanted = _wanted(rig, since)
    try:
        table = dataset.to_table(filter=wanted, columns=SCHEMA.names)
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError, OSError):
        table = _read_fragments(dataset, wanted, d, skipped)
    return table.select(SCHEMA.names).cast(SCHEMA)


def _read_fragments(dataset: Any, wanted: Any, d: Path, skipped: list[str]) -> pa.Table:
    """The scan again one file at a time, skipping (and naming) those that fail."""
    tables = []
    for fragment in dataset.get_fragments(filter=wanted):
        try:
            tables.append(fragment.to_table(schema=dataset.schema, filter=wanted,
                                            columns=SCHEMA.names))
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError, OSError) as exc:
            name = os.path.relpath(fragment.path, d)
            skipped.append(name)
            log.warning("history: skipping unreadable %s (%s)", name, str(exc)[:120])
    return pa.concat_tables(tables) if tables else SCHEMA.empty_table()


def _read_flat(d: Path, skipped: list[str]) -> pa.Table | None:
    """The runs of the layout before partitions (``DIR/run-*.parquet``), or None."""
    import pyarrow.parquet as pq

    tables = []
    for p in sorted(d.glob("run-*.parquet")):
        try:
            t = pq.read_table(p)
            tables.append(t.select([n for n in SCHEMA.names if n in t.schema.names])
                          .cast(pa.schema([f for f in SCHEMA if f.name in t.schema.names])))
        except FileNotFoundError:
            continue  # moved into its partition meanwhile
        except (pa.ArrowInvalid, OSError, ValueError, KeyError) as exc:
            skipped.append(p.name)
            log.warning("history: skipping unreadable %s (%s)", p.name, str(exc)[:120])
    if not tables:
        return None
    full = pa.concat_tables(tables, promote_options="default")
    for f in SCHEMA:
        if f.name not in full.schema.names:
            full = full.append_column(f, pa.nulls(full.num_rows, f.type))
    return full.select(SCHEMA.names)
