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
            from enctools.report.history_hive import read_hive

            return read_hive(text, rig, since)
    rows = historytable.read_rows(text, SCHEMA.names, rig, since)
    return History(text, conform(rows).sort_by("time"), [], rig=rig, since=since)


def conform(rows: pa.Table) -> pa.Table:
    """``rows`` with :data:`SCHEMA`'s columns in its order and types (a missing one null;
    a column a later version added is left out)."""
    cols = [rows.column(f.name).cast(f.type) if f.name in rows.schema.names
            else pa.nulls(rows.num_rows, f.type) for f in SCHEMA]
    return pa.Table.from_arrays(cols, schema=SCHEMA)
