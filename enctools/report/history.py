"""The nightly history dataset: a folder of Parquet files, one file (one row) per run.

Safe against two runs at once and against a crash mid-write without a lock: each
run writes its own uniquely named file (UTC time, host, process id, random suffix)
as a hidden temporary file in the folder, flushes it to disk, and renames it into
place (``os.replace`` is atomic within a file system). Readers see a run's file
whole or not at all; hidden (``.``) and temporary files are ignored, and a file that
cannot be read is reported and skipped, never fatal. The folder is a Parquet dataset
(``pyarrow.dataset.dataset(DIR)`` reads it too).

Columns (one row per run): ``run_id``, ``time`` (UTC), ``host``, ``rig``, ``status``
(ok / drift / error), ``exit_code``, figures of the run's main curve [arcsec]
(``pp``, ``std`` Bessel, ``mean``, ``max_abs``), drift against the stored calibration
[arcsec] (``drift_pp``, ``drift_max``: largest |current - stored| after removing the
mean offset), ``tolerance``, the campaign command and the whole summary as JSON.
"""

from __future__ import annotations

import datetime as _dt
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

def new_run_id(now: _dt.datetime | None = None) -> str:
    """A run id unique across hosts and processes: UTC time, host, pid, random."""
    now = now or _dt.datetime.now(_dt.UTC)
    host = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in socket.gethostname())
    return f"{now:%Y%m%dT%H%M%S}.{now.microsecond:06d}Z-{host}-{os.getpid()}-{secrets.token_hex(3)}"


def append_run(folder: str | os.PathLike[str], record: dict[str, Any]) -> Path:
    """Add one run to the history folder (created if needed); return the new file.

    ``record``: values for :data:`SCHEMA`'s columns (missing ones are null; ``time``
    a timezone-aware datetime, default now; ``run_id`` default :func:`new_run_id`).
    The file appears complete or not at all.
    """
    import pyarrow.parquet as pq

    d = Path(folder)
    d.mkdir(parents=True, exist_ok=True)
    rec = dict(record)
    rec.setdefault("time", _dt.datetime.now(_dt.UTC))
    rec.setdefault("run_id", new_run_id(rec["time"]))
    rec.setdefault("host", socket.gethostname())
    unknown = set(rec) - set(SCHEMA.names)
    if unknown:
        msg = f"history: unknown column(s) {', '.join(sorted(unknown))}"
        raise DataError(msg)
    table = pa.table({f.name: pa.array([rec.get(f.name)], f.type) for f in SCHEMA},
                     schema=SCHEMA)
    _remove_stale(d)
    final = d / f"run-{rec['run_id']}.parquet"
    write_atomic(final, lambda f: pq.write_table(table, f), durable=True, mode=0o644)
    return final


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

    def text_lines(self) -> list[str]:
        lines = [f"history {self.folder}: {self.runs} run(s)"
                 + (f", {len(self.skipped)} unreadable file(s) skipped" if self.skipped else "")]
        if not self.runs:
            return lines
        lines.append(f"  {'time (UTC)':<20} {'rig':<12} {'status':<7} {'p-p':>7} {'s':>7} "
                     f"{'drift':>7} {'tol':>7}  [{self.unit}]")
        for r in self.to_records():
            def g(v: Any) -> str:
                return "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) \
                    else f"{v:.3f}"
            lines.append(f"  {r['time'] or '-':<20} {(r['rig'] or '-'):<12} "
                         f"{(r['status'] or '-'):<7} {g(r['pp']):>7} {g(r['std']):>7} "
                         f"{g(r['drift_max']):>7} {g(r['tolerance']):>7}")
        drift = [v for v in self.column("drift_max") if v is not None and np.isfinite(v)]
        if len(drift) >= 2:
            mark = '"' if self.unit == "arcsec" else f" {self.unit}"
            lines.append(f"  drift: last {drift[-1]:.3f}{mark}, largest {max(drift):.3f}{mark} "
                         f"over {len(drift)} runs")
        return lines


def read_history(folder: str | os.PathLike[str]) -> History:
    """Every complete run file of a history folder, sorted by time.

    A missing folder is an error (exit 2); unreadable files are skipped with a warning.
    """
    import pyarrow.parquet as pq

    d = Path(folder)
    if not d.is_dir():
        msg = f"--history {folder}: no such folder"
        raise DataError(msg)
    tables, skipped = [], []
    for p in sorted(d.glob("run-*.parquet")):
        try:
            t = pq.read_table(p)
            tables.append(t.select([n for n in SCHEMA.names if n in t.schema.names])
                          .cast(pa.schema([f for f in SCHEMA if f.name in t.schema.names])))
        except (pa.ArrowInvalid, OSError, ValueError, KeyError) as exc:
            skipped.append(p.name)
            log.warning("history: skipping unreadable %s (%s)", p.name, str(exc)[:120])
    if tables:
        full = pa.concat_tables(tables, promote_options="default")
        missing = [f for f in SCHEMA if f.name not in full.schema.names]
        for f in missing:
            full = full.append_column(f, pa.nulls(full.num_rows, f.type))
        full = full.select(SCHEMA.names).sort_by("time")
    else:
        full = SCHEMA.empty_table()
    return History(str(folder), full, skipped)
