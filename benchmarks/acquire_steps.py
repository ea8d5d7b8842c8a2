#!/usr/bin/env python3
"""Sweeps, step runs and closure runs on the simulated rigs, before and after the
simulator's speed-ups (issue 18, item 4).

Runs ``enc acquire --mode sweep|steps|closure`` with this checkout's code and with the code
of a git revision (default: the simulator before its truth was summed as one matrix
product per block of angles), each in turn and the best of ``--repeat``; a tiny continuous
acquisition (10 samples) of each code is timed with them, and subtracted to give the
figures after start-up. CPU seconds (user + system) are the figures that hold on a shared
machine. The readings are compared column by column with those of the code of ``--same-as``
(the rigs' settings have changed since the speed-ups' parent, so its readings differ):
"identical" is every column equal (NaN where the other has NaN).

Usage: acquire_steps.py [--before REV] [--same-as REV] [--repeat 3] [--out bench-out]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.ipc

ROOT = Path(__file__).resolve().parent.parent
PY = sys.executable
#: the simulator before its speed-ups: the parent of the first of them (a Series at a few
#: angles summed as one matrix product, 76aa01b)
BEFORE = "76aa01b~1"
ENC = "import sys; sys.argv[0] = 'enc'; from enctools.cli.main import main; main()"
RUNS = {
    "sweep, sjtu-dual (255 positions)": ["--rig", "sjtu-dual", "--mode", "sweep"],
    "steps, ciomp-23bit (24 positions)": ["--rig", "ciomp-23bit", "--mode", "steps"],
    # a run as ISO 230-2 asks for: every position five times, approached from both sides
    "steps, ciomp-23bit, 72 positions x 5 runs, both ways (720 positions)":
        ["--rig", "ciomp-23bit", "--mode", "steps", "--count", "72", "--runs", "5",
         "--bidirectional"],
    "closure, ciomp-23bit (576 positions)": ["--rig", "ciomp-23bit", "--mode", "closure"],
}
TINY = ["--rig", "sjtu-dual", "--revolutions", "0.0005"]


def cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def acquire(code: Path, args: list[str], out: Path) -> tuple[float, float] | None:
    """(CPU, wall) seconds of one ``enc acquire`` with ``code`` first on the path, or None
    when that code refuses the run (a mode it does not have)."""
    env = dict(os.environ, PYTHONPATH=str(code))
    c0, t0 = cpu_children(), time.perf_counter()
    r = subprocess.run([PY, "-c", ENC, "acquire", *args, "-q", "--force", "-o", str(out)],
                       env=env, cwd=out.parent, capture_output=True)
    if r.returncode != 0:
        return None
    return cpu_children() - c0, time.perf_counter() - t0


def unpack(rev: str, d: Path) -> Path:
    """The code (enctools, schemas) of commit ``rev`` in folder ``d``."""
    d.mkdir()
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "enctools", "schemas"],
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(d)], input=archive, check=True)
    return d


def same_readings(a: Path, b: Path) -> bool:
    """Whether two acquisitions hold the same columns with the same values."""
    ta, tb = (pa.ipc.open_stream(p.read_bytes()).read_all() for p in (a, b))
    if ta.column_names != tb.column_names or ta.num_rows != tb.num_rows:
        return False
    for name in ta.column_names:
        x, y = ta.column(name).to_numpy(), tb.column(name).to_numpy()
        nan = x.dtype.kind == "f"
        if not np.array_equal(x, y, equal_nan=nan):
            return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", default=BEFORE)
    ap.add_argument("--same-as", default="4b8b35f",
                    help="the commit whose readings these must equal")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "bench-out"))
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    res: dict[str, dict] = {}
    with tempfile.TemporaryDirectory(prefix="acquire-steps-") as tmp:
        d = Path(tmp)
        before, same_as = unpack(a.before, d / "before"), unpack(a.same_as, d / "same-as")
        codes = {"after": ROOT, "before": before}
        jobs = {"tiny": TINY, **RUNS}
        best: dict[tuple[str, str], tuple[float, float] | None] = {}
        for _ in range(a.repeat):
            for label, args in jobs.items():
                for name, code in codes.items():
                    t = acquire(code, args, d / f"{name}.arrows")
                    k = (label, name)
                    best[k] = None if t is None else min(best.get(k) or t, t)
                if label != "tiny" and label not in res:  # once: the simulator is seeded
                    ok = acquire(same_as, args, d / "same-as.arrows") is not None
                    res[label] = {"identical": ok and same_readings(d / "after.arrows",
                                                                    d / "same-as.arrows")
                                  if ok else None}
        for label in RUNS:
            row = res[label]
            for name in codes:
                t, tiny = best[(label, name)], best[("tiny", name)]
                if t is not None and tiny is not None:
                    row[name] = {"cpu_s": t[0], "wall_s": t[1],
                                 "cpu_after_startup_s": t[0] - tiny[0]}
    (out / "acquire_steps.json").write_text(json.dumps(
        {"before": a.before, "same_as": a.same_as, "runs": res}, indent=1))
    print(f"| `enc acquire` | CPU s | before ({a.before}): CPU s | before / after (CPU) | "
          "after start-up: CPU s | before: after start-up | before / after, after start-up "
          f"| readings as {a.same_as}'s |")
    print("|---|---:|---:|---:|---:|---:|---:|---|")
    for label, row in res.items():
        new, old = row["after"], row.get("before")
        same = {True: "identical", False: "DIFFERENT", None: "(no such mode)"}[row["identical"]]
        if old is None:
            print(f"| {label} | {new['cpu_s']:.2f} | (no such mode) | | "
                  f"{new['cpu_after_startup_s']:.2f} | | | {same} |")
            continue
        work, work_before = new["cpu_after_startup_s"], old["cpu_after_startup_s"]
        speed_up = f"{work_before / work:.2f}" if work > 0.02 else "(start-up only)"
        print(f"| {label} | {new['cpu_s']:.2f} | {old['cpu_s']:.2f} | "
              f"{old['cpu_s'] / new['cpu_s']:.2f} | {work:.2f} | {work_before:.2f} | "
              f"{speed_up} | {same} |")


if __name__ == "__main__":
    main()
