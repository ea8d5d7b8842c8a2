#!/usr/bin/env python3
"""enc fit-rbf's default search on dense tables: seconds and peak memory against one plain
fit of the same size, and how soon a signal ends a long fit.

For each size N (default 16384, 50000, 100000 and 1,000,000 points: positions uniform over
the turn, three harmonics and 0.2" of noise, as a Parquet table) this runs
``enc fit-rbf TABLE -q -o model.parquet`` with this checkout's code and, with
``--before REV``, with the code of a git revision (``git archive``; default none: the
figures of the code before the blocks are in the README), each in a child waited for
with ``wait4`` (its peak resident memory and CPU seconds). One plain fit, the chosen
network at its spread and smoothing over the same points (``rbf.fit_smoothed``: one
SVD of the whole design, as the default search did once a spread), is timed the same way
where its design fits in memory (N x 256 words at most 1 GB), and the search's ratio to
it printed. ``--signal`` sends SIGTERM to a fit of the largest size once it has run
``--after`` seconds and prints how long it took to end and its exit status (143 expected,
no output file). Wall seconds depend on the machine's load (printed); CPU seconds less.

Usage: fit_rbf.py [--sizes 16384,50000,100000,1000000] [--before REV] [--signal]
                  [--out bench-out]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PY = sys.executable
ENC = "import sys; sys.argv[0] = 'enc'; from enctools.cli.main import main; main()"
MAKE = """
import sys
import numpy as np, pyarrow as pa, pyarrow.parquet as pq
n, out = int(sys.argv[1]), sys.argv[2]
rng = np.random.default_rng(n)
x = np.sort(rng.uniform(0.0, 360.0, n))
r = np.deg2rad(x)
y = 1.5 * np.sin(r + 0.3) + 0.8 * np.sin(2 * r + 1.1) + 0.3 * np.sin(24 * r) + rng.normal(0, 0.2, n)
pq.write_table(pa.table({"position_deg": x, "deviation_arcsec": y}), out)
"""
PLAIN = """
import json, sys
import numpy as np, pyarrow.parquet as pq
from enctools.models.rbf import fit_smoothed
t = pq.read_table(sys.argv[1])
fit_smoothed(t["position_deg"].to_numpy(), t["deviation_arcsec"].to_numpy(),
             float(sys.argv[2]), float(sys.argv[3]))
"""


def child(argv: list[str], env: dict[str, str], cwd: Path,
          stop_after: float | None = None) -> dict[str, float]:
    """Run argv; its wall and CPU seconds, peak memory [MB] and exit status (and with
    ``stop_after``: SIGTERM then, and the seconds from the signal to its end)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, env=env, cwd=cwd, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    sent = None
    if stop_after is not None:
        time.sleep(stop_after)
        sent = time.perf_counter()
        proc.send_signal(signal.SIGTERM)
    _, status, usage = os.wait4(proc.pid, 0)
    end = time.perf_counter()
    proc.returncode = os.waitstatus_to_exitcode(status)
    out = {"seconds": end - t0, "cpu_seconds": usage.ru_utime + usage.ru_stime,
           "peak_mb": usage.ru_maxrss / 1024, "exit": proc.returncode}
    if sent is not None:
        out["seconds_to_end"] = end - sent
    return out


def code_env(code: Path) -> dict[str, str]:
    return dict(os.environ, PYTHONPATH=str(code), OPENBLAS_NUM_THREADS="1")


def snapshot(rev: str, into: Path) -> Path:
    """The code of a git revision (enctools/ and schemas/) in ``into``."""
    into.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "archive", rev, "enctools", "schemas"], cwd=ROOT,
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return into


def measure(code: Path, table: Path, work: Path, n: int) -> dict[str, object]:
    out = work / f"model-{n}.parquet"
    row: dict[str, object] = {"search": child([PY, "-c", ENC, "fit-rbf", str(table), "-q", "-o",
                                               str(out), "--force"], code_env(code), work)}
    if out.exists() and n * 256 * 8 <= 1 << 30:
        import pyarrow.parquet as pq

        meta = json.loads(pq.read_schema(out).metadata[b"enctools"])["model"]
        row["plain"] = child([PY, "-c", PLAIN, str(table), str(meta["spread_deg"]),
                              str(meta["selection"]["smoothing"])], code_env(code), work)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", default="16384,50000,100000,1000000")
    ap.add_argument("--before", default=None, help="a git revision to measure too")
    ap.add_argument("--signal", action="store_true", help="time SIGTERM on the largest size")
    ap.add_argument("--after", type=float, default=8.0, help="seconds before the signal")
    ap.add_argument("--out", default="bench-out")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    outdir = Path(args.out)
    outdir.mkdir(parents=True, exist_ok=True)
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores", flush=True)
    results: dict[str, object] = {"load": os.getloadavg()[0], "sizes": {}}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        codes = {"after": ROOT}
        if args.before:
            codes["before"] = snapshot(args.before, work / "before")
        print("| points | code | search [s] | search [CPU s] | peak [MB] | one plain fit "
              "[CPU s] | plain peak [MB] | ratio (CPU) |\n|---:|---|---:|---:|---:|---:|---:|---:|")
        for n in sizes:
            table = work / f"points-{n}.parquet"
            subprocess.run([PY, "-c", MAKE, str(n), str(table)], check=True)
            for label, code in codes.items():
                row = measure(code, table, work, n)
                results["sizes"].setdefault(str(n), {})[label] = row  # type: ignore[union-attr]
                s, p = row["search"], row.get("plain")
                plain = (f"{p['cpu_seconds']:.2f} | {p['peak_mb']:.0f} | "  # type: ignore[index]
                         f"{s['cpu_seconds'] / p['cpu_seconds']:.1f}" if p else "- | - | -")  # type: ignore[index]
                print(f"| {n} | {label} | {s['seconds']:.2f} | {s['cpu_seconds']:.2f} | "  # type: ignore[index]
                      f"{s['peak_mb']:.0f} | {plain} |", flush=True)  # type: ignore[index]
        if args.signal:
            n = max(sizes)
            out = work / "stopped.parquet"
            r = child([PY, "-c", ENC, "fit-rbf", str(work / f"points-{n}.parquet"), "-q", "-o",
                       str(out)], code_env(ROOT), work, stop_after=args.after)
            r["output_left"] = out.exists()
            results["sigterm"] = r
            print(f"\nSIGTERM after {args.after:g} s of a fit of {n} points: ended "
                  f"{r['seconds_to_end']:.2f} s later, exit {r['exit']}, output left: "
                  f"{r['output_left']}")
    (outdir / "fit_rbf.json").write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
