#!/usr/bin/env python3
"""interp-check on a continuous run, before and after the fit's speed-ups (issues 18, 35).

Records one continuous run of the sjtu-dual rig at the paper's 3 ms (as benchmarks/bench.py
does), then runs ``enc interp-check -q --reference P1`` on it, read from a pipe, with this
checkout's code and with the code of a git revision (default: the fit before its
speed-ups), each in turn and the best of ``--repeat``; between them ``cat`` of the same
bytes into /dev/null and a plain pyarrow ``read_all`` of the same bytes from the same
pipe (a Python that imports pyarrow and reads the whole stream into one table) are
timed. CPU seconds (user + system, the reading thread included) are the figures that
hold on a shared machine; wall seconds are printed too, with the ratios to ``read_all``
and ``cat``, the CPU per sample (row), the peak memory of the check and of ``read_all``
(GNU time, where there is one) and the load average of the machine. Every Python runs
with its bytecode cached (as installed), not compiled at each start. Both outputs must
agree to rounding (1e-12 arcsec).

Usage: interp_fit.py [--revolutions 200] [--before REV] [--repeat 3] [--out bench-out]
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
import pyarrow.parquet as pq

ROOT = Path(__file__).resolve().parent.parent
PY = sys.executable
#: the fit before its speed-ups: the parent of the first of them (the 2026-11-26 code)
BEFORE = "ec875cc~1"
RUN = ["acquire", "--rig", "sjtu-dual", "--interval", "0.003", "-q"]
CHECK = ["interp-check", "-q", "--reference", "P1", "--force"]
ENC = "import sys; sys.argv[0] = 'enc'; from enctools.cli.main import main; main()"


def cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(shell: str, env: dict[str, str], cwd: Path) -> tuple[float, float]:
    """(CPU, wall) seconds of a shell pipeline run in ``cwd`` (not this checkout: for
    ``python -c`` the current folder comes before PYTHONPATH)."""
    c0, t0 = cpu_children(), time.perf_counter()
    subprocess.run(["/bin/bash", "-o", "pipefail", "-c", shell], env=env, check=True, cwd=cwd)
    return cpu_children() - c0, time.perf_counter() - t0


#: GNU time, for the peak memory of the check (None: not measured)
TIME = "/usr/bin/time" if Path("/usr/bin/time").exists() else None


#: a plain read of the whole stream from stdin into one table
READ_ALL = ("import sys, pyarrow as pa, pyarrow.ipc; "
            "pa.ipc.open_stream(sys.stdin.buffer).read_all()")


def cached_env(tmp: Path, **extra: str) -> dict[str, str]:
    """The environment of a timed Python: its bytecode written once and read after (as
    installed), in ``tmp``, whatever PYTHONDONTWRITEBYTECODE the caller has."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    return env | {"PYTHONPYCACHEPREFIX": str(tmp / "pycache")} | extra


def check_shell(code: Path, run: Path, out: Path, tmp: Path) -> tuple[str, dict[str, str]]:
    env = cached_env(tmp, PYTHONPATH=str(code))
    peak = [TIME, "-f", "%M", "-o", f"{out}.peak"] if TIME else []
    cmd = " ".join([f"cat {run} |", *peak, PY, "-c", f'"{ENC}"', *CHECK, "-o", str(out)])
    return cmd, env


def read_all_shell(run: Path, tmp: Path) -> tuple[str, dict[str, str]]:
    peak = [TIME, "-f", "%M", "-o", f"{tmp / 'read_all'}.peak"] if TIME else []
    return " ".join([f"cat {run} |", *peak, PY, "-c", f'"{READ_ALL}"']), cached_env(tmp)


def peak_mb(out: Path) -> float | None:
    """The check's peak memory [MB] (maximum resident set) as GNU time wrote it."""
    f = Path(f"{out}.peak")
    return int(f.read_text().split()[-1]) / 1024 if f.exists() else None


def deviations(path: Path) -> np.ndarray:
    """The checked curves and their u, whatever the columns' names."""
    t = pq.read_table(path)
    return np.column_stack([t.column(n).to_numpy() for n in t.column_names])


def table(res: dict) -> str:
    """The Markdown table of a run: each command's CPU and wall seconds, its ratios to
    ``read_all`` (CPU, wall) and ``cat`` (wall), CPU per sample, peak memory; the load."""
    cpu, wall, peaks, n = res["cpu_s"], res["wall_s"], res["peak_mb"], res["samples"]
    lines = [f"| interp-check, continuous run, {res['revolutions']} r | CPU s | wall s | "
             "CPU vs before | CPU vs `read_all` | wall vs `read_all` | wall vs `cat` | "
             "CPU per sample [us] | peak memory |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for k in ("before", "after", "read_all", "cat"):
        peak = peaks.get(k)
        lines.append(
            f"| {k if k != 'read_all' else '`read_all`'} | {cpu[k]:.2f} | {wall[k]:.2f} | "
            f"{cpu[k] / cpu['before']:.2f} | {cpu[k] / cpu['read_all']:.2f} | "
            f"{wall[k] / wall['read_all']:.2f} | {wall[k] / wall['cat']:.1f} | "
            f"{cpu[k] / n * 1e6:.3f} | {'' if peak is None else f'{peak:.0f} MB'} |")
    loads = "; ".join(" ".join(f"{x:.1f}" for x in la) for la in res["load_average"])
    lines.append(f"\nload average (1, 5, 15 min) at the start and the end: {loads} "
                 f"({os.cpu_count()} cores)")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--revolutions", type=int, default=200)
    ap.add_argument("--before", default=BEFORE)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "bench-out"))
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="interp-fit-") as tmp:
        d = Path(tmp)
        before = d / "before"
        before.mkdir()
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", a.before, "enctools",
                                  "schemas"], check=True, capture_output=True).stdout
        subprocess.run(["tar", "-x", "-C", str(before)], input=archive, check=True)
        run = d / "run.arrows"
        subprocess.run([PY, "-c", ENC, *RUN, "--revolutions", str(a.revolutions), "-o",
                        str(run)], check=True, env=dict(os.environ, PYTHONPATH=str(ROOT)),
                       cwd=d)
        best: dict[str, tuple[float, float]] = {}
        peaks: dict[str, float | None] = {}
        load = [os.getloadavg()]
        for _ in range(a.repeat):
            for name, code in (("after", ROOT), ("before", before)):
                cmd, env = check_shell(code, run, d / f"{name}.parquet", d)
                t = timed(cmd, env, d)
                best[name] = min(best.get(name, t), t)
                peaks[name] = peak_mb(d / f"{name}.parquet")
                c = timed(f"cat {run} > /dev/null", dict(os.environ), d)
                best["cat"] = min(best.get("cat", c), c)
                cmd, env = read_all_shell(run, d)
                r = timed(cmd, env, d)
                best["read_all"] = min(best.get("read_all", r), r)
                peaks["read_all"] = peak_mb(d / "read_all")
        load.append(os.getloadavg())
        diff = float(np.max(np.abs(deviations(d / "after.parquet")
                                   - deviations(d / "before.parquet"))))
        size = run.stat().st_size
        with pa.memory_map(str(run)) as f:     # the samples (rows), without reading them in
            samples = sum(b.num_rows for b in pa.ipc.open_stream(f))
    res = {"revolutions": a.revolutions, "bytes": size, "before": a.before,
           "samples": samples, "cpu_s": {k: v[0] for k, v in best.items()},
           "wall_s": {k: v[1] for k, v in best.items()}, "peak_mb": peaks,
           "load_average": load, "max_abs_diff_arcsec": diff}
    (out / "interp_fit.json").write_text(json.dumps(res, indent=1))
    print(table(res))
    print(f"\nlargest difference of the curves and their u: {diff:.2g} arcsec")
    if not diff < 1e-12:
        sys.exit(f"interp_fit: the results differ by {diff:.3g} arcsec")


if __name__ == "__main__":
    main()
