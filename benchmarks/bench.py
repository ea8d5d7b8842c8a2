#!/usr/bin/env python3
"""enctools benchmarks: throughput, peak memory and start-up cost of every command.

Run with ``make bench``. Prints a Markdown table (for the README) and writes
``bench-out/bench.json``. Every figure is measured in one run on one machine, and the
ones that matter are ratios to a reference measured in the same run (raw ``cat``
throughput over the same bytes, a bare ``python -c pass``), so a busy or slow machine
changes the absolute numbers more than the ratios.

Usage: bench.py [--revolutions 20,200,2000] [--out bench-out] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent
ENC = str(BIN / "enc")
HEADS = 9  # sjtu-dual

#: filter name -> arguments; a filter whose command is not installed is skipped
FILTERS: dict[str, list[str]] = {
    "average-heads": ["average-heads"],
    "compare": ["compare", "--device", "H1,H2,H3,H4", "--ref", "P1,P2"],
    "selfcal": ["selfcal", "--method", "esa", "--ref", "H1", "--heads", "H5,H6,H7"],
    "info": ["info"],
}


def available(command: str) -> bool:
    r = subprocess.run([ENC, command, "--help"], capture_output=True)
    return r.returncode == 0


def timed(shell: str, repeat: int = 1) -> dict[str, float]:
    """Run a bash pipeline; the last stage's peak RSS comes from GNU time in the pipeline."""
    times = []
    peak = 0.0
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = subprocess.run(["bash", "-o", "pipefail", "-c", shell], capture_output=True)
        times.append(time.perf_counter() - t0)
        if r.returncode != 0:
            raise RuntimeError(f"{shell}: {r.stderr.decode()[-500:]}")
        for line in r.stderr.decode().splitlines():
            if line.startswith("PEAK_KB "):
                peak = max(peak, float(line.split()[1]))
    return {"seconds": min(times), "median": statistics.median(times), "peak_mb": peak / 1024}


def gnu_time() -> str:
    return "/usr/bin/time -f 'PEAK_KB %M'"


def startup(repeat: int) -> dict[str, float]:
    py = sys.executable
    base = timed(f"{py} -c pass", repeat)["seconds"]
    click_ = timed(f"{py} -c 'import click'", repeat)["seconds"]
    np_pa = timed(f"{py} -c 'import numpy, pyarrow'", repeat)["seconds"]
    help_ = timed(f"{ENC} --help > /dev/null", repeat)["seconds"]
    out = {"python -c pass": base, "python -c 'import click'": click_,
           "python -c 'import numpy, pyarrow'": np_pa, "enc --help": help_,
           "enc --help / import click": help_ / click_}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--revolutions", default="20,200,2000")
    ap.add_argument("--out", default=str(ROOT / "bench-out"))
    ap.add_argument("--quick", action="store_true", help="20 and 200 revolutions, one repeat")
    args = ap.parse_args()
    revs = [20, 200] if args.quick else [int(r) for r in args.revolutions.split(",")]
    repeat = 1 if args.quick else 3
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results: dict[str, object] = {
        "date": time.strftime("%Y-%m-%d"),
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
                   f"Python {platform.python_version()}",
        "startup": startup(5),
        "runs": [],
    }
    filters = {k: v for k, v in FILTERS.items() if available(v[0])}
    for n in revs:
        data = out / f"raw-{n}.arrows"
        acq = timed(f"{gnu_time()} {ENC} acquire --rig sjtu-dual --revolutions {n} -o {data} --force")
        samples = n * 20_000
        row: dict[str, object] = {"revolutions": n, "samples": samples,
                                  "acquire": {"head_samples_per_s": samples * HEADS / acq["seconds"],
                                              "peak_mb": acq["peak_mb"]}}
        cat = timed(f"cat {data} | cat > /dev/null", repeat)
        row["cat_bytes_per_s"] = data.stat().st_size / cat["seconds"]
        for name, argv in filters.items():
            m = timed(f"cat {data} | {gnu_time()} {ENC} {' '.join(argv)} > /dev/null", repeat)
            row[name] = {"head_samples_per_s": samples * HEADS / m["seconds"],
                         "ratio_to_cat": cat["seconds"] / m["seconds"], "peak_mb": m["peak_mb"]}
        results["runs"].append(row)
        data.unlink()
        print(f"bench: {n} revolutions done", file=sys.stderr)
    (out / "bench.json").write_text(json.dumps(results, indent=2))
    print(markdown(results))


def markdown(res: dict) -> str:
    lines = [f"Measured {res['date']} on {res['machine']} (`make bench`).", ""]
    lines += ["| command | revolutions | head-samples/s | vs `cat` | peak memory |",
              "|---|---:|---:|---:|---:|"]
    for run in res["runs"]:
        for name, m in run.items():
            if isinstance(m, dict):
                ratio = f"{m['ratio_to_cat']:.2f}" if "ratio_to_cat" in m else ""
                lines.append(f"| {name} | {run['revolutions']} | {m['head_samples_per_s']:.3g} | "
                             f"{ratio} | {m['peak_mb']:.0f} MB |")
    s = res["startup"]
    lines += ["", "| start-up | seconds |", "|---|---:|"]
    lines += [f"| {k} | {v:.3f} |" for k, v in s.items()]
    return "\n".join(lines)


if __name__ == "__main__":
    if not shutil.which("bash"):
        sys.exit("bench: needs bash")
    main()
