"""The nightly history: one row per night, in a Delta Lake table (:mod:`.historytable`)
partitioned by the rig's name, in a folder or on an object store, that DuckDB, Spark,
polars and ``pyarrow.dataset`` read; and the :class:`History` (:mod:`.historyrows`) that
``enc report`` and ``enc history show`` tabulate and plot.

Reading one rig (``rig``) reads that rig's partition only, and ``since`` filters the rows
on ``time`` in the scan: both are pushed down, so tabulating one rig costs about the same
in a fleet of ten rigs or a thousand. A folder of the layout before the table (schema
version 1: Hive folders ``rig=NAME/year=YYYY`` of one Parquet file a night,
:mod:`.history_hive`) is still read, never written: ``enc history migrate`` makes a
table of it.

Columns (one row per run): ``run_id``, ``time`` (UTC), ``host``, ``rig`` (the partition:
the rig file's ``name``), ``status`` (ok / drift / error / interrupted: a signal /
timeout: the campaign's time limit), ``exit_code``, figures of the run's main curve
[arcsec] (``pp``, ``std`` Bessel, ``mean``, ``max_abs``), drift against the stored
calibration [arcsec] (``drift_pp``, ``drift_max``: largest |current - stored| after
removing the mean offset), ``tolerance``, the campaign command and the whole summary as
JSON.
"""

from __future__ import annotations

import datetime as _dt
import logging
import os
import secrets
import socket
from typing import Any

import pyarrow as pa

from enctools.errors import DataError
from enctools.report.historyrows import (  # noqa: F401 - where the readers find them
    BATCH_ROWS,
    SCHEMA,
    SCHEMA_IN,
    STREAM_ROWS,
    History,
)

log = logging.getLogger("enctools")

def new_run_id(now: _dt.datetime | None = None) -> str:
    """A run id unique across hosts and processes: UTC time, host, pid, random."""
    now = now or _dt.datetime.now(_dt.UTC)
    host = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in socket.gethostname())
    return f"{now:%Y%m%dT%H%M%S}.{now.microsecond:06d}Z-{host}-{os.getpid()}-{secrets.token_hex(3)}"


def append_run(history: str | os.PathLike[str], record: dict[str, Any]) -> int:
    """Add one night to the history table (made if needed) in one transaction; return the
    rows added: 1, or 0 when a night of the same ``run_id`` is there already (a retry).

    ``record``: values for :data:`SCHEMA`'s columns (missing ones are null; ``rig``
    required, not empty; ``time`` a timezone-aware datetime, default now; ``run_id``
    default :func:`new_run_id`). A folder holding a history of the layout before the
    table is refused: ``enc history migrate`` makes a table of it.
    """
    from enctools.report import historytable

    rec = dict(record)
    rec.setdefault("time", _dt.datetime.now(_dt.UTC))
    rec.setdefault("run_id", new_run_id(rec["time"]))
    rec.setdefault("host", socket.gethostname())
    unknown = set(rec) - set(SCHEMA.names)
    if unknown:
        msg = f"history: unknown column(s) {', '.join(sorted(unknown))}"
        raise DataError(msg)
    if not rec.get("rig"):
        msg = "history: a run needs its rig's name"
        raise DataError(msg)
    refuse_hive(history)
    row = pa.table({f.name: pa.array([rec.get(f.name)], f.type) for f in SCHEMA},
                   schema=historytable.table_schema(SCHEMA))
    return historytable.append_rows(history, row, [str(rec["run_id"])])


def refuse_hive(history: str | os.PathLike[str]) -> None:
    """A folder of the layout before the table (and no table) is not written to."""
    from enctools.report import historytable

    if historytable.is_remote(os.fspath(history)) or historytable.is_table(history):
        return
    from enctools.report.history_hive import is_hive

    if is_hive(history):
        msg = (f"`history_dir` {os.fspath(history)} holds a history of the layout before "
               "the table (rig=NAME/year=YYYY folders); make a table of it with "
               "`enc history migrate` and use that")
        raise DataError(msg)


def read_history(history: str | os.PathLike[str], rig: str | None = None,
                 since: _dt.datetime | None = None) -> History:
    """The runs of a history, sorted by time: all, or those of ``rig`` at or after
    ``since`` (timezone-aware; a naive one is taken as UTC), pushed down to the scan.

    A Delta table (a folder or a URI), or a folder of the layout before it (read as it
    is). A missing folder is an error (exit 2).
    """
    from enctools.report import historytable

    if since is not None and since.tzinfo is None:
        since = since.replace(tzinfo=_dt.UTC)
    text = os.fspath(history)
    if not historytable.is_remote(text):
        if not os.path.isdir(text):
            msg = f"`history_dir` {text}: no such folder"
            raise DataError(msg)
        if not historytable.is_table(text):
            from enctools.report.history_hive import is_hive, read_hive

            if not is_hive(text):
                refuse_stray(text)
            return read_hive(text, rig, since)
    rows = historytable.read_rows(text, SCHEMA.names, rig, since)
    return History(text, conform(rows).sort_by("time"), [], rig=rig, since=since)


#: the Parquet files looked for below a folder that is no history, and how deep [folders]
STRAY_LOOK, STRAY_DEPTH = 1000, 3


def refuse_stray(folder: str) -> None:
    """A folder holding neither a table nor the layout before it but Parquet files is
    refused, naming what is there (read, it would show no runs): a partition of a table
    (a ``_delta_log`` above), files in ``NAME=VALUE`` folders or with the history's
    columns (the layout before the table: ``enc history migrate``), or other files."""
    found = _parquet_below(folder)
    if not found:
        return
    msg = (f"`history_dir` {folder}: no history table there (no _delta_log) but "
           f"{len(found)}{'+' if len(found) >= STRAY_LOOK else ''} Parquet file(s), "
           f"{found[0]} first")
    above = _table_above(folder)
    if above is not None:
        msg += f"; it is a partition of the table {above}: give that"
    elif _looks_hive(folder, found):
        root = os.path.dirname(os.path.abspath(folder)) \
            if os.path.basename(os.path.abspath(folder)).startswith("rig=") else folder
        msg += ("; a history of the layout before the table? `enc history migrate` "
                f"makes a table of it (OLD: the folder of its rig=NAME folders, {root})")
    else:
        msg += "; not a nightly history"
    raise DataError(msg)


def _parquet_below(folder: str) -> list[str]:
    """The first :data:`STRAY_LOOK` ``*.parquet`` files in ``folder`` and
    :data:`STRAY_DEPTH` folders below it, relative to it, in name order."""
    found: list[str] = []
    for here, dirs, names in os.walk(folder):
        rel = os.path.relpath(here, folder)
        dirs.sort()
        if rel.count(os.sep) + (rel != ".") >= STRAY_DEPTH:
            dirs.clear()
        found += [os.path.normpath(os.path.join(rel, n)) for n in sorted(names)
                  if n.endswith(".parquet")]
        if len(found) >= STRAY_LOOK:
            break
    return found[:STRAY_LOOK]


def _table_above(folder: str) -> str | None:
    """The table (a folder with ``_delta_log``) ``folder`` lies in, two levels up at most."""
    up = os.path.abspath(folder)
    for _ in range(2):
        up = os.path.dirname(up)
        if os.path.isdir(os.path.join(up, "_delta_log")):
            return up
    return None


def _looks_hive(folder: str, found: list[str]) -> bool:
    """Whether ``found`` lie in ``NAME=VALUE`` folders, or the first holds the history's
    ``run_id`` and ``time`` (the layout before the table, given one level too deep)."""
    import pyarrow.parquet as pq

    if os.path.basename(os.path.abspath(folder)).startswith("rig=") or any(
            "=" in part for f in found for part in f.split(os.sep)[:-1]):
        return True
    try:
        names = pq.read_schema(os.path.join(folder, found[0])).names
    except (OSError, pa.ArrowInvalid):
        return False
    return "run_id" in names and "time" in names


def conform(rows: pa.Table) -> pa.Table:
    """``rows`` with :data:`SCHEMA`'s columns in its order and types (a missing one null;
    a column a later version added is left out)."""
    cols = [rows.column(f.name).cast(f.type) if f.name in rows.schema.names
            else pa.nulls(rows.num_rows, f.type) for f in SCHEMA]
    return pa.Table.from_arrays(cols, schema=SCHEMA)
