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


@dataclass
class History:
    """The runs of a history folder, oldest first."""

    folder: str
    table: pa.Table
    skipped: list[str] = field(default_factory=list)
    unit: str = "arcsec"  # of the figures (enc report --unit shows another)
    rig: str | None = None               # the rig read (None: every rig)
    since: _dt.datetime | None = None    # the earliest run read (None: every run)

    @property
    def runs(self) -> int:
        return self.table.num_rows

    def column(self, name: str) -> np.ndarray:
        return self.table.column(name).to_numpy(zero_copy_only=False)

    def times(self) -> np.ndarray:
        """Run times as numpy datetime64 [us] (UTC, naive)."""
        return self.table.column("time").cast(pa.timestamp("us")).to_numpy(
            zero_copy_only=False)

    def to_records(self) -> list[dict[str, Any]]:
        rows = self.table.drop_columns(["summary_json"]).to_pylist()
        for r in rows:
            r["time"] = r["time"].strftime("%Y-%m-%dT%H:%M:%SZ") if r["time"] else None
        return rows

    def filters_text(self) -> str:
        """The rig and date read, as " (rig NAME, since TIME)", or nothing for every run."""
        said = ([f"rig {self.rig}"] if self.rig is not None else []) + \
            ([f"since {self.since:%Y-%m-%dT%H:%M:%SZ}"] if self.since is not None else [])
        return f" ({', '.join(said)})" if said else ""

    def text_lines(self) -> list[str]:
        lines = [f"history {self.folder}{self.filters_text()}: {self.runs} run(s)"
                 + (f", {len(self.skipped)} unreadable file(s) skipped" if self.skipped else "")]
        if not self.runs:
            return lines
        lines.append(f"  {'time (UTC)':<20} {'rig':<12} {'status':<11} {'p-p':>7} {'s':>7} "
                     f"{'drift':>7} {'tol':>7}  [{self.unit}]")
        for r in self.to_records():
            def g(v: Any) -> str:
                return "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) \
                    else f"{v:.3f}"
            lines.append(f"  {r['time'] or '-':<20} {(r['rig'] or '-'):<12} "
                         f"{(r['status'] or '-'):<11} {g(r['pp']):>7} {g(r['std']):>7} "
                         f"{g(r['drift_max']):>7} {g(r['tolerance']):>7}")
        drift = [v for v in self.column("drift_max") if v is not None and np.isfinite(v)]
        if len(drift) >= 2:
            mark = '"' if self.unit == "arcsec" else f" {self.unit}"
            lines.append(f"  drift: last {drift[-1]:.3f}{mark}, largest {max(drift):.3f}{mark} "
                         f"over {len(drift)} runs")
        return lines


def read_history(folder: str | os.PathLike[str], rig: str | None = None,
                 since: _dt.datetime | None = None) -> History:
    """The runs of a history folder, sorted by time: all, or those of ``rig`` at or
    after ``since`` (timezone-aware; a naive one is taken as UTC).

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
    parts = _read_partitions(d, rig, since, skipped)
    if flat is not None:
        ids = parts.column("run_id")
        import pyarrow.compute as pc
        flat = flat.filter(_wanted(rig, since, with_year=False))
        flat = flat.filter(pc.invert(pc.is_in(flat.column("run_id"), value_set=ids)))
        parts = pa.concat_tables([parts, flat.cast(SCHEMA)])
    return History(str(folder), parts.sort_by("time"), skipped, rig=rig, since=since)


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


def _read_partitions(d: Path, rig: str | None, since: _dt.datetime | None,
                     skipped: list[str]) -> pa.Table:
    """The partitioned runs, filtered by the dataset scan; one rig: its folder only."""
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
        return SCHEMA.empty_table()
    schema = pa.unify_schemas([FILE_SCHEMA, PARTITIONING])
    parts = [ds.dataset(str(p), format="parquet", schema=schema, partition_base_dir=str(d),
                        partitioning=ds.partitioning(PARTITIONING, flavor="hive"))
             for p in folders]
    dataset = parts[0] if len(parts) == 1 else ds.dataset(parts, schema=schema)
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
