"""The nightly history as a Delta Lake table (delta-rs through ``deltalake``: no JVM, no
server): one append transaction per night, partitioned by the rig's name as a string.

A history is a folder (the embedded default: nothing to start) or an object-store URI
(``s3://``, ``az://``, ``gs://``) with its credentials from the environment as delta-rs
reads them (``AWS_ACCESS_KEY_ID``, ``AWS_ENDPOINT_URL``, ...). What makes the table safe
to share:

- each night is one commit: its row is in the table whole or not at all; a commit that
  loses the race to another writer's is retried on the next version (Delta's optimistic
  concurrency: the log's next JSON file is written only if absent), so concurrent nights
  lose nothing;
- the run id makes a retried append a no-op: a night whose ``run_id`` is already in its
  rig's partition adds nothing;
- on S3, where a plain put overwrites, the commit is a conditional put (``If-None-Match``:
  delta-rs's ``conditional_put=etag``) unless the environment names a lock
  (``AWS_S3_LOCKING_PROVIDER=dynamodb``) or the store asks otherwise (:func:`storage_options`);
- the schema version is the table property :data:`VERSION_PROPERTY`; a new column is a
  schema evolution of the same table (``schema_mode="merge"``), not a new dataset.

``compact`` rewrites the small files of each rig into few (OPTIMIZE) and removes the
files no version younger than the retention needs (VACUUM, :data:`RETENTION_HOURS`).
"""

from __future__ import annotations

import datetime as _dt
import logging
import os
import random
import time
from typing import Any
from urllib.parse import unquote

import pyarrow as pa

from enctools.errors import DataError, SettingsError

log = logging.getLogger("enctools")

#: the table property holding the history's schema version
VERSION_PROPERTY = "enctools.history.schemaVersion"
#: the schema version this code writes (1: the Hive folders of one Parquet file a night)
SCHEMA_VERSION = "2"
#: how long VACUUM keeps a file no current version needs [h]: a reader that opened an
#: older version (a report running through the night) finds its files for a week
RETENTION_HOURS = 168
#: the least retention ``compact`` takes [h]: a night writes its data files seconds before
#: its commit, and VACUUM must not take them for files of no version
MIN_RETENTION_HOURS = 1.0
#: a rig's partition holding more data files than this after a night's append is
#: compacted by that night (:func:`compact_crowded`): a fleet's table then holds at most
#: rigs x (CROWDED_FILES + 1) files between two ``enc history compact`` runs
CROWDED_FILES = 16
#: a commit that lost the race to another writer's is tried again this many times
COMMIT_TRIES = 60
#: the URI schemes of the object stores delta-rs reaches
REMOTE = ("s3://", "s3a://", "az://", "abfs://", "abfss://", "gs://")
#: glibc's malloc arenas at most, once delta-rs is used (:func:`_fewer_arenas`)
MALLOC_ARENAS = 2


def _fewer_arenas() -> None:
    """Cap glibc's malloc arenas: each of delta-rs's runtime threads would reserve one of
    64 MiB of address space, and a night under a 2 GiB address-space limit (``ulimit -v``)
    then aborted in its first append (2.6 GB of address space; 1.7 GB with two arenas).
    Elsewhere than glibc: nothing."""
    import ctypes
    import sys

    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None)
        libc.mallopt(-8, MALLOC_ARENAS)  # M_ARENA_MAX
    except (OSError, AttributeError):
        pass


_fewer_arenas()


def is_remote(location: str) -> bool:
    """Whether ``location`` names an object store rather than a folder."""
    return location.lower().startswith(REMOTE)


def storage_options(location: str) -> dict[str, str] | None:
    """The delta-rs storage options of ``location``: on S3, commits by conditional put
    (``conditional_put=etag``) unless ``AWS_S3_LOCKING_PROVIDER`` names a lock or
    ``AWS_CONDITIONAL_PUT`` says otherwise; ``ENC_HISTORY_ALLOW_HTTP=1`` allows a plain
    HTTP endpoint (a local S3 server). Everything else from the environment."""
    if not location.lower().startswith(("s3://", "s3a://")):
        return None
    opts: dict[str, str] = {}
    if not os.environ.get("AWS_S3_LOCKING_PROVIDER"):
        opts["conditional_put"] = os.environ.get("AWS_CONDITIONAL_PUT", "etag")
    if os.environ.get("ENC_HISTORY_ALLOW_HTTP", "") not in ("", "0"):
        opts["allow_http"] = "true"
    return opts


def location_of(history: str | os.PathLike[str]) -> str:
    """The table's location as delta-rs takes it: a URI as given, a folder made absolute."""
    text = os.fspath(history)
    return text if is_remote(text) else os.path.abspath(text)


def is_table(history: str | os.PathLike[str]) -> bool:
    """Whether ``history`` holds a Delta table (a ``_delta_log``)."""
    text = os.fspath(history)
    if not is_remote(text):  # a commit there (a full disk may leave the folder alone)
        try:
            return any(n.endswith((".json", ".parquet")) or n == "_last_checkpoint"
                       for n in os.listdir(os.path.join(text, "_delta_log")))
        except OSError:
            return False
    return open_table(text) is not None


def open_table(history: str | os.PathLike[str]) -> Any:
    """The Delta table at ``history`` (``deltalake.DeltaTable``), or None when there is none."""
    from deltalake import DeltaTable
    from deltalake.exceptions import TableNotFoundError

    where = location_of(history)
    try:
        return DeltaTable(where, storage_options=storage_options(where))
    except TableNotFoundError:
        return None
    except OSError as exc:
        msg = f"`history_dir` {os.fspath(history)}: {exc}"
        raise DataError(msg) from None


def table_schema(schema: pa.Schema) -> pa.Schema:
    """The table's schema: ``schema`` without field metadata (the unit lives in the reader's)."""
    return pa.schema([pa.field(f.name, f.type) for f in schema])


def create_table(history: str | os.PathLike[str], schema: pa.Schema) -> Any:
    """The table at ``history``, made when there is none (version 0, partitioned by
    ``rig``) with its schema version in the properties. Two writers making it at once:
    one makes it, the other opens it."""
    from deltalake import DeltaTable

    where = location_of(history)
    if not is_remote(where):
        os.makedirs(where, exist_ok=True)
    for attempt in range(COMMIT_TRIES):
        if attempt:
            _pause()
        table = open_table(where)
        if table is None:
            try:
                table = DeltaTable.create(where, table_schema(schema), mode="ignore",
                                          partition_by=["rig"], name="enctools nightly history",
                                          storage_options=storage_options(where))
            except Exception as exc:  # noqa: BLE001 - another writer's version 0, or the store's
                if open_table(where) is None:  # not a race: a full disk, no permission
                    raise OSError(0, _first_line(exc), os.fspath(history)) from None
                continue
        if table.metadata().configuration.get(VERSION_PROPERTY) is not None:
            return table
        try:  # a property of no Delta feature: set after create (create checks its names)
            table.alter.set_table_properties({VERSION_PROPERTY: SCHEMA_VERSION},
                                             raise_if_not_exists=False)
        except Exception as exc:  # noqa: BLE001 - a concurrent commit: read again, try again
            log.debug("history: setting the schema version: %s", exc)
            _pause()
    msg = f"`history_dir` {os.fspath(history)}: the table could not be made"
    raise DataError(msg)


def schema_version(table: Any) -> str | None:
    """The history's schema version (:data:`VERSION_PROPERTY`), None when unset."""
    value = table.metadata().configuration.get(VERSION_PROPERTY)
    return None if value is None else str(value)


def _pause() -> None:
    time.sleep(random.uniform(0.01, 0.2))  # spreads the retries


def append_rows(history: str | os.PathLike[str], rows: pa.Table,
                run_ids: list[str] | None = None) -> int:
    """Append ``rows`` (columns of the history's schema, ``rig`` among them) in one
    transaction; those whose ``run_id`` the table holds already are left out (a retried
    night adds nothing). Return the rows added.

    A commit that loses to another writer's is tried again (up to :data:`COMMIT_TRIES`
    times), the run ids checked again each time.
    """
    from deltalake import CommitProperties, write_deltalake
    from deltalake.exceptions import CommitFailedError, DeltaError

    table = create_table(history, rows.schema)
    for _ in range(COMMIT_TRIES):
        fresh = _without_known(table, rows)
        if not fresh.num_rows:
            return 0
        try:
            write_deltalake(table, fresh, mode="append", schema_mode="merge",
                            partition_by=["rig"],
                            commit_properties=CommitProperties(custom_metadata={
                                "enctools.runs": ",".join(run_ids or [])[:4000]}))
            compact_crowded(table, sorted({r for r in fresh.column("rig").to_pylist() if r}))
            return fresh.num_rows
        except CommitFailedError as exc:
            log.debug("history: commit lost to another writer's, again: %s", exc)
            _pause()
            table.update_incremental()
        except DeltaError as exc:  # the store's: a full disk, no permission, a lost connection
            raise OSError(0, _first_line(exc), os.fspath(history)) from None
    msg = (f"`history_dir` {os.fspath(history)}: {COMMIT_TRIES} commits lost to other "
           "writers; the night is not recorded")
    raise DataError(msg)


def compact_crowded(table: Any, rigs: list[str]) -> list[str]:
    """OPTIMIZE the partitions of ``rigs`` that hold more than :data:`CROWDED_FILES` data
    files, each into one file (one commit a rig). Return the rigs compacted.

    A night appends a file to its rig's partition, and a query opens each file (36,500
    nights of 100 rigs: 16 s fleet-wide, 0.3 s compacted): so the night that passes the
    count rewrites its rig's few kilobytes (some 0.2 s) and the table stays small without
    ``enc history compact``; the files replaced stay on disk until that command's VACUUM.
    The night is recorded before: a compaction that fails (another writer's compaction of
    the same files first) is told and leaves the history as it was.
    """
    import pyarrow.compute as pc
    from deltalake.exceptions import CommitFailedError

    done: list[str] = []
    try:
        table.update_incremental()
        held = _arrow_table(table.get_add_actions(flatten=True)).column("partition.rig")
        for rig in rigs:
            if (pc.sum(pc.equal(held, rig)).as_py() or 0) > CROWDED_FILES:
                table.optimize.compact(partition_filters=[("rig", "=", rig)])
                done.append(rig)
    except CommitFailedError as exc:
        log.debug("history: compaction lost to another writer's: %s", _first_line(exc))
    except Exception as exc:  # noqa: BLE001 - the night is recorded; the files stay as they were
        log.warning("history: the rig's files could not be compacted: %s", _first_line(exc))
    return done


def current_dataset(table: Any, rig: str | None = None,
                    since: _dt.datetime | None = None) -> Any:
    """The table's current version as a ``pyarrow.dataset``: of one ``rig``'s files alone
    (None: every rig), less the files whose runs all precede ``since`` (by the log's
    statistics), chosen from the log before a file is opened.

    In a folder, pyarrow opens the files the log lists itself, each fragment told its rig:
    deltalake's own dataset reads through a file system written in Python and makes its
    fragments one by one (72 s for 36,500 files, where this takes 1 s). On an object store,
    or a table needing a reader feature this does not handle, deltalake's own dataset.
    """
    import pyarrow.compute as pc
    import pyarrow.dataset as ds
    import pyarrow.fs as pafs

    root = _local_root(table)
    if root is None:
        return _deltalake_dataset(table, rig)
    adds = _arrow_table(table.get_add_actions(flatten=True))
    if rig is not None:
        adds = adds.filter(pc.equal(adds.column("partition.rig"), rig))
    if since is not None and "max.time" in adds.schema.names:  # the log's max is in ms
        latest = pc.add(adds.column("max.time").cast(pa.timestamp("us", tz="UTC")),
                        pa.scalar(_dt.timedelta(milliseconds=1)))
        adds = adds.filter(pc.invert(pc.fill_null(pc.less(
            latest, pa.scalar(since, pa.timestamp("us", tz="UTC"))), False)))
    schema = pa.schema(table.schema().to_arrow())
    said: dict[Any, Any] = {}  # one expression a rig, not a file (25 us each to make)
    for value in adds.column("partition.rig").unique().to_pylist():
        said[value] = (ds.field("rig") == value) if value is not None \
            else ~ds.field("rig").is_valid()
    return ds.FileSystemDataset.from_paths(
        [os.path.join(root, unquote(p)) for p in adds.column("path").to_pylist()],
        schema=schema, format=ds.ParquetFileFormat(), filesystem=pafs.LocalFileSystem(),
        partitions=[said[v] for v in adds.column("partition.rig").to_pylist()])


def _local_root(table: Any) -> str | None:
    """The folder of ``table`` when pyarrow can read its files itself, else None: not a
    folder, reader features (deletion vectors, column mapping), a path not relative."""
    from urllib.parse import urlparse
    from urllib.request import url2pathname

    uri = str(table.table_uri)
    protocol = table.protocol()
    if not uri.startswith("file://") or protocol.min_reader_version > 1 \
            or protocol.reader_features or table.metadata().partition_columns != ["rig"]:
        return None
    return url2pathname(urlparse(uri).path)


def _deltalake_dataset(table: Any, rig: str | None) -> Any:
    import warnings

    if rig is None:
        return table.to_pyarrow_dataset()
    with warnings.catch_warnings():  # newer releases would have a predicate: same files
        warnings.simplefilter("ignore", DeprecationWarning)
        return table.to_pyarrow_dataset(partitions=[("rig", "=", rig)])


def _arrow_table(data: Any) -> pa.Table:
    """``data`` (deltalake's arro3 table or batch, through the Arrow C stream) in pyarrow."""
    if isinstance(data, pa.Table):
        return data
    if hasattr(data, "__arrow_c_stream__"):
        reader = pa.RecordBatchReader._import_from_c_capsule(data.__arrow_c_stream__())
        return reader.read_all()
    return pa.Table.from_batches([pa.record_batch(data)])


def _first_line(exc: BaseException) -> str:
    """An error of delta-rs as one line (its messages may hold the causes' lines)."""
    text = " ".join(str(exc).split())
    return text[:300] or type(exc).__name__


def _without_known(table: Any, rows: pa.Table) -> pa.Table:
    """``rows`` less those whose ``run_id`` the table holds in their rig's partition."""
    import pyarrow.compute as pc
    import pyarrow.dataset as ds

    rigs = sorted({r for r in rows.column("rig").to_pylist() if r is not None})
    if not rigs or table.version() < 0:
        return rows
    dataset = current_dataset(table, rigs[0] if len(rigs) == 1 else None)
    known = dataset.to_table(columns=["run_id"], filter=ds.field("rig").isin(rigs)
                             & ds.field("run_id").isin(rows.column("run_id")))
    if not known.num_rows:
        return rows
    return rows.filter(pc.invert(pc.is_in(rows.column("run_id"),
                                          value_set=known.column("run_id"))))


def read_rows(history: str | os.PathLike[str], columns: list[str], rig: str | None,
              since: _dt.datetime | None) -> pa.Table:
    """The rows of ``columns`` of ``rig`` at or after ``since`` (both pushed down: one
    rig's partition is read alone, files before ``since`` skipped by their statistics),
    one per run id, in no order. A history without a table: an error."""
    import pyarrow.compute as pc
    import pyarrow.dataset as ds

    table = open_table(history)
    if table is None:
        msg = f"`history_dir` {os.fspath(history)}: no history table there"
        raise DataError(msg)
    dataset = current_dataset(table, rig, since)
    wanted = ds.scalar(True)
    if rig is not None:
        wanted = ds.field("rig") == rig
    if since is not None:
        wanted = wanted & (ds.field("time") >= pa.scalar(since, pa.timestamp("us", tz="UTC")))
    have = [c for c in columns if c in dataset.schema.names]
    rows = dataset.to_table(columns=have, filter=wanted)
    if rows.num_rows and "run_id" in have:  # a night appended twice by an older writer: once
        first = pc.equal(pc.index_in(rows.column("run_id"), value_set=pc.unique(
            rows.column("run_id"))), pa.array(range(rows.num_rows)))
        if not pc.all(first).as_py():
            _, keep = _first_of_each(rows.column("run_id"))
            rows = rows.take(keep)
    return rows


def _first_of_each(ids: Any) -> tuple[list[Any], list[int]]:
    seen: dict[Any, int] = {}
    for i, v in enumerate(ids.to_pylist()):
        seen.setdefault(v, i)
    return list(seen), sorted(seen.values())


def compact(history: str | os.PathLike[str], retention_hours: float = RETENTION_HOURS
            ) -> dict[str, int]:
    """OPTIMIZE (each rig's small files rewritten into few) then VACUUM (the files no
    version younger than ``retention_hours`` [h] needs, removed), then a checkpoint of
    the version left (a reader opening the table reads it, not each commit since the
    last checkpoint: 1.2 s to open 36,500 nights compacted, 0.1 s with it). Return the
    counts: files before and after, files added and removed by OPTIMIZE, files vacuumed."""
    table = open_table(history)
    if table is None:
        msg = f"`history_dir` {os.fspath(history)}: no history table there"
        raise DataError(msg)
    if not retention_hours >= MIN_RETENTION_HOURS:
        msg = f"`retention_hours` must be >= {MIN_RETENTION_HOURS:g}, not {retention_hours}"
        raise SettingsError(msg)
    before = len(table.file_uris())
    metrics = table.optimize.compact()
    gone = table.vacuum(retention_hours=int(retention_hours), dry_run=False,
                        enforce_retention_duration=False)
    table.create_checkpoint()
    return {"files_before": before, "files_after": len(table.file_uris()),
            "files_added": int(metrics.get("numFilesAdded", 0)),
            "files_removed": int(metrics.get("numFilesRemoved", 0)),
            "files_vacuumed": len(gone)}


def file_count(history: str | os.PathLike[str]) -> int:
    """The data files of the table's current version."""
    table = open_table(history)
    return 0 if table is None else len(table.file_uris())
