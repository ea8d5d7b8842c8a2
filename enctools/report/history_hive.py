"""The nightly history of schema version 1, read only: Parquet files, one file (one row)
per run, in Hive partitions ``rig=NAME/year=YYYY`` (:mod:`.partitions`), and the layout
before those (every ``run-*.parquet`` directly in the folder, with its ``rig`` column).

``enc report`` still reads such a folder, and ``enc history migrate`` copies it
into a Delta table (:mod:`.historytable`) with every row kept. Reading one rig
(``rig``) opens that rig's folder only, and ``since`` prunes the year folders before it
and filters the rows on ``time``: both are pushed down to ``pyarrow.dataset``. A file
that cannot be read is reported and skipped, never fatal.
"""

from __future__ import annotations

import datetime as _dt
import itertools
import logging
import os
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.errors import DataError
from enctools.report import historyrows
from enctools.report.historyrows import SCHEMA, History
from enctools.report.partitions import rig_folder

log = logging.getLogger("enctools")

#: the partition columns, from the folder names (``rig=NAME/year=YYYY``)
PARTITIONING = pa.schema([pa.field("rig", pa.string()), pa.field("year", pa.int32())])
#: the columns in each run's file: all but the partitions
FILE_SCHEMA = pa.schema([f for f in SCHEMA if f.name not in PARTITIONING.names])


def is_hive(folder: str | os.PathLike[str]) -> bool:
    """Whether ``folder`` holds runs of the Hive layout (or the flat one before it)."""
    d = Path(folder)
    return d.is_dir() and (any(p.is_dir() for p in d.glob("rig=*"))
                           or any(d.glob("run-*.parquet")))


def read_hive(folder: str | os.PathLike[str], rig: str | None = None,
              since: _dt.datetime | None = None) -> History:
    """The runs of a history folder of the Hive layout, sorted by time: all, or those of
    ``rig`` at or after ``since`` (timezone-aware; a naive one is taken as UTC).

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
        if ordered is not None and ordered[1] > historyrows.STREAM_ROWS:
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
