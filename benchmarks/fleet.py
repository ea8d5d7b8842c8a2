#!/usr/bin/env python3
"""A fleet's nightly history: the time to tabulate one rig's drift as the fleet grows.

Builds the history dataset of 10, 30 and 100 rigs x 365 nights, each in a folder of its own
(one Parquet file per night in the ``rig=NAME/year=YYYY`` partitions that ``enc-nightly``
writes; written here at once by ``pyarrow.dataset.write_dataset``, one row a file, without
the fsync each night makes), and times on each, the three fleets in turn (a machine busy
for a while slows them alike) and the best of five:

- one rig (``read_history(DIR, rig=...)`` and its table, as ``enc report --history DIR
  --rig NAME`` does), and the same since a date (the year before is pruned);
- one rig by a scan of the whole dataset with the filter applied there
  (``pyarrow.dataset.dataset(DIR, partitioning="hive").to_table(filter=...)``): what the
  partitions save, since that scan lists every rig's files;
- ``enc report --history DIR --history-rig NAME`` as a command (start-up included).

Times are CPU seconds (threads and child processes included): on a machine shared with
other work they hold where wall times do not.

The ratios to the 10-rig fleet are the result: flat (about 1) for one rig, growing with
the fleet for the whole-dataset scan. Prints a Markdown table; writes OUT/fleet.json.

Usage: fleet.py [--out bench-out] [--rigs 10,30,100] [--nights 365]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import resource
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.dataset as ds

from enctools.report.history import FILE_SCHEMA, read_history
from enctools.report.partitions import partition_folder

ROOT = Path(__file__).resolve().parent.parent
ENC = str(Path(sys.executable).parent / "enc")
LAST_NIGHT = dt.datetime(2026, 11, 30, 2, 30, tzinfo=dt.UTC)
SINCE = "2026-11-01"  # the last 30 nights: the 2025 folder is not read


def rig_name(k: int) -> str:
    return f"table-{k:03d}"


def add_rigs(root: Path, first: int, last: int, nights: int) -> None:
    """Rigs ``first`` .. ``last - 1``, ``nights`` nights each up to LAST_NIGHT, one file a
    night in its partition; the drift a slow random walk [arcsec] per rig."""
    rng = np.random.default_rng(first)
    n = (last - first) * nights
    when = np.tile(np.datetime64(LAST_NIGHT.replace(tzinfo=None), "us")
                   - np.arange(nights)[::-1] * np.timedelta64(1, "D"), last - first)
    k = np.repeat(np.arange(first, last), nights)
    drift = np.abs(np.cumsum(rng.normal(0.0, 0.01, (last - first, nights)), axis=1)).ravel()
    bad = drift > 0.5
    cols = {"run_id": [f"{t}Z-bench-{r}" for t, r in zip(when.astype(str), k, strict=True)],
            "time": pa.array(when, pa.timestamp("us")).cast(pa.timestamp("us", tz="UTC")),
            "host": [f"host-{r % 7}" for r in k], "status": np.where(bad, "drift", "ok"),
            "exit_code": bad.astype(np.int32), "pp": 5.0 + drift, "std": np.full(n, 1.2),
            "mean": np.zeros(n), "max_abs": np.full(n, 2.7), "drift_pp": 2 * drift,
            "drift_max": drift, "tolerance": np.full(n, 0.5),
            "campaign": ['enc acquire --rig "$RIG" --mode steps | enc points'] * n,
            "summary_json": ["{}"] * n}
    table = pa.table({f.name: pa.array(cols[f.name], f.type) for f in FILE_SCHEMA},
                     schema=FILE_SCHEMA)
    table = table.append_column("rig", pa.array([rig_name(r) for r in k])) \
        .append_column("year", pa.array(when.astype("datetime64[Y]").astype(int) + 1970,
                                        pa.int32()))
    # the folders enc-nightly writes to (a bench rig's name needs no encoding)
    assert partition_folder(root, rig_name(first), 2026).parent.name == f"rig={rig_name(first)}"
    ds.write_dataset(table, root, format="parquet", partitioning=ds.partitioning(
        pa.schema([table.schema.field("rig"), table.schema.field("year")]), flavor="hive"),
        max_rows_per_file=1, max_rows_per_group=1,
        basename_template=f"run-{first}-{{i}}.parquet",
        existing_data_behavior="overwrite_or_ignore")


def cpu_seconds(fn: Callable[[], object]) -> float:
    """The CPU time [s] of one call of ``fn()``: this process's, its threads and the
    children it waited for included (a machine shared with other work changes the wall
    time far more)."""
    def cpu() -> float:
        me, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF,
                                                     resource.RUSAGE_CHILDREN))
        return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime

    t0 = cpu()
    fn()
    return cpu() - t0


def jobs(root: Path, rigs: int) -> dict[str, Callable[[], object]]:
    """What is timed at one fleet size, for a rig in the middle of the fleet."""
    rig = rig_name(rigs // 2)
    since = dt.datetime.fromisoformat(SINCE).replace(tzinfo=dt.UTC)

    def one_rig() -> None:
        assert len(read_history(root, rig=rig).text_lines()) > 300

    def one_rig_since() -> None:
        assert 30 <= read_history(root, rig=rig, since=since).runs <= 31

    def whole_scan() -> None:
        t = ds.dataset(root, format="parquet", partitioning="hive") \
            .to_table(filter=ds.field("rig") == rig)
        assert t.num_rows > 300

    def command() -> None:
        subprocess.run([ENC, "report", "--history", str(root), "--history-rig", rig], check=True,
                       stdout=subprocess.DEVNULL)

    return {"one rig": one_rig, "one rig since": one_rig_since,
            "whole-dataset scan": whole_scan, "enc report --history-rig": command}


def measure(roots: dict[int, Path], repeat: int = 5) -> dict[str, dict[str, float]]:
    """The least CPU time [s] of ``repeat`` turns of every job on every fleet, the fleets
    in turn within each turn."""
    todo = {n: jobs(root, n) for n, root in roots.items()}
    best: dict[str, dict[str, float]] = {str(n): {} for n in roots}
    for _ in range(repeat):
        for n, each in todo.items():
            for what, fn in each.items():
                t = cpu_seconds(fn)
                best[str(n)][what] = min(best[str(n)].get(what, t), t)
    return best


def markdown(res: dict) -> str:
    sizes = res["rigs"]
    base = res["times"][str(sizes[0])]
    head = " | ".join(f"{n} rigs [CPU s]" for n in sizes)
    ratio = " | ".join(f"{n}/{sizes[0]}" for n in sizes[1:])
    out = [f"| one rig of a fleet, {res['nights']} nights each | {head} | {ratio} |",
           "|---|" + "---:|" * (2 * len(sizes) - 1)]
    for what in base:
        t = [res["times"][str(n)][what] for n in sizes]
        out.append(f"| {what} | " + " | ".join(f"{x:.3f}" for x in t) + " | "
                   + " | ".join(f"{x / t[0]:.2f}" for x in t[1:]) + " |")
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=str(ROOT / "bench-out"))
    ap.add_argument("--rigs", default="10,30,100")
    ap.add_argument("--nights", type=int, default=365)
    a = ap.parse_args()
    sizes = sorted(int(x) for x in a.rigs.split(","))
    out = Path(a.out)
    roots = {n: out / f"fleet-history-{n}" for n in sizes}
    res: dict = {"rigs": sizes, "nights": a.nights, "build_s": {}}
    for n, root in roots.items():
        shutil.rmtree(root, ignore_errors=True)
        t0 = time.perf_counter()
        add_rigs(root, 0, n, a.nights)
        res["build_s"][str(n)] = time.perf_counter() - t0
        print(f"fleet: {n} rigs built", file=sys.stderr)
    res["times"] = measure(roots)
    for root in roots.values():
        shutil.rmtree(root, ignore_errors=True)
    (out / "fleet.json").write_text(json.dumps(res, indent=1))
    print(markdown(res))


if __name__ == "__main__":
    main()
