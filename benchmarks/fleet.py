#!/usr/bin/env python3
"""A fleet's nightly history: 100 rigs x 365 nights, as the Delta table enc-nightly writes
and as the Hive folders of the layout before it, queried fleet-wide and for one rig before
and after ``enc history compact``.

Rows are made for the benchmark (a slow random walk of drift per rig). The table is
appended a night at a time, each night one transaction of one row per rig (one file per
rig and night, as many nights appended by many hosts make), twice: never compacted, and
as enc-nightly leaves it (a rig's partition compacted by the night that passes
``CROWDED_FILES``); the Hive layout is written at once by
``pyarrow.dataset.write_dataset``, one file a night and rig. Then, in one run:

- fleet-wide: the README's DuckDB query (nights since a date, largest drift and nights
  not ok of every rig) over the whole history: on the Hive folders
  (``read_parquet(..., hive_partitioning = true)``) and on each table (DuckDB over
  ``historytable.current_dataset``: the files the table's log lists, the table opened
  within the time);
- one rig: ``read_history(DIR, rig=...)`` and its text, as ``enc report --history
  --history-rig`` does;
- the number of data files of the table's version, before and after ``compact``
  (OPTIMIZE, then VACUUM with the least retention, 1 h: the files OPTIMIZE replaced
  stay on disk until they are an hour old);
- one more night appended by ``append_run`` (its run id checked), before and after.

Times are wall seconds, the best of ``--repeat`` (the machine is shared: the best is the
figure least disturbed, and the load average is printed beside). Prints a Markdown
table; writes OUT/fleet.json.

Usage: fleet.py [--out bench-out] [--rigs 100] [--nights 365] [--repeat 3]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import shutil
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.dataset as ds

from enctools.report import historytable
from enctools.report.history import SCHEMA, read_history
from enctools.report.history_hive import FILE_SCHEMA

ROOT = Path(__file__).resolve().parent.parent
LAST_NIGHT = dt.datetime(2026, 11, 30, 2, 30, tzinfo=dt.UTC)
SINCE = "2026-01-01"
QUERY = """SELECT rig, count(*) AS nights, max(drift_max) AS largest_drift_arcsec,
       count(*) FILTER (WHERE status <> 'ok') AS not_ok
FROM {source}
WHERE time >= TIMESTAMPTZ '2026-01-01 00:00:00+00'
GROUP BY rig ORDER BY largest_drift_arcsec DESC"""


def rig_name(k: int) -> str:
    return f"{k:04d}"  # digit-only, as many labs number their rigs


def nights(rigs: int, count: int) -> pa.Table:
    """Every rig's ``count`` nights up to LAST_NIGHT, night by night (the rigs of a night
    together); the drift a slow random walk [arcsec] per rig."""
    rng = np.random.default_rng(1)
    when = np.repeat(np.datetime64(LAST_NIGHT.replace(tzinfo=None), "us")
                     - np.arange(count)[::-1] * np.timedelta64(1, "D"), rigs)
    k = np.tile(np.arange(rigs), count)
    drift = np.abs(np.cumsum(rng.normal(0.0, 0.01, (count, rigs)), axis=0)).ravel()
    bad = drift > 0.5
    n = rigs * count
    cols = {"run_id": [f"{t}Z-bench-{r}" for t, r in zip(when.astype(str), k, strict=True)],
            "time": pa.array(when, pa.timestamp("us")).cast(pa.timestamp("us", tz="UTC")),
            "host": [f"host-{r % 7}" for r in k], "rig": [rig_name(r) for r in k],
            "status": np.where(bad, "drift", "ok"), "exit_code": bad.astype(np.int32),
            "pp": 5.0 + drift, "std": np.full(n, 1.2), "mean": np.zeros(n),
            "max_abs": np.full(n, 2.7), "drift_pp": 2 * drift, "drift_max": drift,
            "tolerance": np.full(n, 0.5),
            "campaign": ['enc acquire --rig "$RIG" --mode steps | enc points'] * n,
            "summary_json": ["{}"] * n}
    return pa.table({f.name: pa.array(cols[f.name], f.type) for f in SCHEMA},
                    schema=historytable.table_schema(SCHEMA))


def build_table(root: Path, rows: pa.Table, rigs: int, crowded: bool) -> None:
    """The table of a transaction a night, a file per rig (written here without the run-id
    check of each night, whose cost :func:`one_night` gives): as enc-nightly leaves it,
    each rig's partition compacted when it passes ``CROWDED_FILES`` (``crowded``), or
    never compacted (a table of a writer that does not)."""
    from deltalake import write_deltalake

    table = historytable.create_table(root, SCHEMA)
    names = [rig_name(k) for k in range(rigs)]
    for start in range(0, rows.num_rows, rigs):
        write_deltalake(table, rows.slice(start, rigs), mode="append", partition_by=["rig"])
        if crowded:
            historytable.compact_crowded(table, names)


def one_night(root: Path, rig: str) -> float:
    """The wall time [s] of one more night of ``rig`` appended as enc-nightly does
    (its run id checked against the rig's partition, then the commit)."""
    from enctools.report.history import append_run

    t0 = time.perf_counter()
    append_run(root, {"rig": rig, "status": "ok", "time": LAST_NIGHT + dt.timedelta(days=1)})
    return time.perf_counter() - t0


def build_hive(root: Path, rows: pa.Table) -> None:
    """The layout before the table: a Parquet file a night in rig=NAME/year=YYYY."""
    years = pa.array(rows.column("time").to_numpy().astype("datetime64[Y]").astype(int)
                     + 1970, pa.int32())
    table = rows.select(FILE_SCHEMA.names).cast(FILE_SCHEMA) \
        .append_column("rig", rows.column("rig")).append_column("year", years)
    ds.write_dataset(table, root, format="parquet", partitioning=ds.partitioning(
        pa.schema([pa.field("rig", pa.string()), pa.field("year", pa.int32())]),
        flavor="hive"), max_rows_per_file=1, max_rows_per_group=1,
        basename_template="run-{i}.parquet", existing_data_behavior="overwrite_or_ignore")


def best(fn: Callable[[], object], repeat: int) -> float:
    """The least wall time [s] of ``repeat`` calls of ``fn``."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def jobs(tables: dict[str, Path], hive: Path, rigs: int, count: int
         ) -> dict[str, Callable[[], object]]:
    """The queries timed: fleet-wide and one rig, on the Hive folders and each table."""
    import duckdb

    rig = rig_name(rigs // 2)
    todo: dict[str, Callable[[], object]] = {}

    def fleet_hive() -> None:
        sql = QUERY.format(source=f"read_parquet('{hive}/*/*/*.parquet', "
                                  "hive_partitioning = true, "
                                  "hive_types = {'rig': VARCHAR, 'year': INTEGER})")
        assert len(duckdb.sql(sql).fetchall()) == rigs

    def fleet_table(where: Path) -> None:
        history = historytable.current_dataset(  # noqa: F841 - named in the SQL
            historytable.open_table(where))
        assert len(duckdb.sql(QUERY.format(source="history")).fetchall()) == rigs

    def one_rig(where: Path) -> None:
        assert len(read_history(where, rig=rig).text_lines()) >= count + 2

    todo["fleet-wide, Hive folders"] = fleet_hive
    todo["one rig, Hive folders"] = lambda: one_rig(hive)
    for name, where in tables.items():
        todo[f"fleet-wide, {name}"] = lambda where=where: fleet_table(where)
        todo[f"one rig, {name}"] = lambda where=where: one_rig(where)
    return todo


def files(root: Path) -> int:
    return sum(1 for _ in root.rglob("*.parquet"))


def load() -> str:
    """The load average over 1, 5 and 15 minutes (the machine is shared)."""
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def timed(what: str, fn: Callable[[], object], res: dict) -> None:
    t0 = time.perf_counter()
    fn()
    res["build_s"][what] = time.perf_counter() - t0
    print(f"fleet: {what} built in {res['build_s'][what]:.1f} s (load {load()})",
          file=sys.stderr)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(ROOT / "bench-out"))
    ap.add_argument("--rigs", type=int, default=100)
    ap.add_argument("--nights", type=int, default=365)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    out = Path(a.out)
    raw, nightly, hive = out / "fleet-table", out / "fleet-nightly", out / "fleet-hive"
    for root in (raw, nightly, hive):
        shutil.rmtree(root, ignore_errors=True)
    rows = nights(a.rigs, a.nights)
    res: dict = {"rigs": a.rigs, "nights": a.nights, "rows": rows.num_rows, "build_s": {},
                 "crowded_files": historytable.CROWDED_FILES, "load": {"start": load()}}
    timed("hive", lambda: build_hive(hive, rows), res)
    timed("table", lambda: build_table(raw, rows, a.rigs, crowded=False), res)
    timed("nightly", lambda: build_table(nightly, rows, a.rigs, crowded=True), res)
    todo = jobs({"table": raw, "nightly": nightly}, hive, a.rigs, a.nights)
    res["files"] = {"hive": files(hive), "table before": historytable.file_count(raw),
                    "nightly": historytable.file_count(nightly)}
    res["before"] = {what: best(fn, a.repeat) for what, fn in todo.items()}
    res["load"]["before"] = load()
    res["append_s"] = {"before": one_night(raw, rig_name(0)),
                       "nightly": one_night(nightly, rig_name(0))}
    t0 = time.perf_counter()
    res["compact"] = historytable.compact(raw, historytable.MIN_RETENTION_HOURS)
    res["compact_s"] = time.perf_counter() - t0
    res["files"]["table after"] = historytable.file_count(raw)
    res["after"] = {what: best(fn, a.repeat) for what, fn in todo.items()
                    if what.endswith(", table")}
    res["load"]["after"] = load()
    res["append_s"]["after"] = one_night(raw, rig_name(1))
    for root in (raw, nightly, hive):
        shutil.rmtree(root, ignore_errors=True)
    (out / "fleet.json").write_text(json.dumps(res, indent=1))
    print(markdown(res))


def markdown(res: dict) -> str:
    """The figures as the README's table."""
    b, f = res["before"], res["files"]
    out = [f"| {res['rigs']} rigs x {res['nights']} nights [s] | Hive folders | table, "
           f"never compacted | table, as the nights leave it | table compacted | "
           "compacted / Hive |", "|---|---:|---:|---:|---:|---:|"]
    for what in ("fleet-wide", "one rig"):
        hive, after = b[f"{what}, Hive folders"], res["after"][f"{what}, table"]
        out.append(f"| {what} | {hive:.3f} | {b[f'{what}, table']:.3f} | "
                   f"{b[f'{what}, nightly']:.3f} | {after:.3f} | {after / hive:.4f} |")
    out.append(f"| data files | {f['hive']} | {f['table before']} | {f['nightly']} | "
               f"{f['table after']} | |")
    a = res["append_s"]
    out.append(f"| a night appended (enc-nightly) | | {a['before']:.3f} | {a['nightly']:.3f} | "
               f"{a['after']:.3f} | |")
    out.append(f"| load average (1, 5, 15 min) | | {res['load']['before']} | | "
               f"{res['load']['after']} | |")
    return "\n".join(out)


if __name__ == "__main__":
    main()
