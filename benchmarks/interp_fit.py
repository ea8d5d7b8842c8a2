#!/usr/bin/env python3
"""interp-check on a continuous run, with the compiled kernel and without (issues 18, 35).

Records one continuous run of the sjtu-dual rig at the paper's 3 ms (as benchmarks/bench.py
does) per size (``--revolutions``, default 300 and 2000), then runs ``enc interp-check -q
--reference P1`` on it, read from a pipe, with this checkout's compiled kernel, with its
numpy passes (ENCTOOLS_KERNEL=numpy) and, with ``--before REV``, with the code of a git
revision (its numpy passes), each in turn and the best of ``--repeat``; between them
``cat`` of the same bytes through a pipe of 1 MiB (bench.py's reference for the streaming
filters) and a plain pyarrow ``read_all`` of the same bytes from the same pipe (a Python
that imports pyarrow and reads the whole stream into one table) are timed. CPU seconds
(user + system, the reading thread included) are the figures that hold on a shared
machine; wall seconds are printed too, with the ratios to ``read_all`` and ``cat``, the
CPU per sample (row), the peak memory of the check and of ``read_all`` (GNU time, where
there is one) and the load average of the machine. Every Python runs with its bytecode
cached (as installed), not compiled at each start. First the kernel's costs: its build
(the install's compiler call, timed here), the import of enctools.kernel and ctypes
(``python -X importtime``) and the loading of the library. The kernel's and the numpy
passes' outputs must agree to rounding (1e-12 arcsec).

Usage: interp_fit.py [--revolutions 300,2000] [--before REV] [--repeat 3] [--out bench-out]
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
#: the fit before its speed-ups: the parent of the first of them (the 2026-11-26 code),
#: for ``--before``
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


def check_shell(code: Path, run: Path, out: Path, tmp: Path,
                kernel: str | None = None) -> tuple[str, dict[str, str]]:
    """interp-check of ``run`` by the code in ``code``; ``kernel``: ENCTOOLS_KERNEL's value."""
    env = cached_env(tmp, PYTHONPATH=str(code))
    env.pop("ENCTOOLS_KERNEL", None)
    if kernel is not None:
        env["ENCTOOLS_KERNEL"] = kernel
    peak = [TIME, "-f", "%M", "-o", f"{out}.peak"] if TIME else []
    cmd = " ".join([f"cat {run} |", *peak, PY, "-c", f'"{ENC}"', *CHECK, "-o", str(out)])
    return cmd, env


def read_all_shell(run: Path, tmp: Path) -> tuple[str, dict[str, str]]:
    peak = [TIME, "-f", "%M", "-o", f"{tmp / 'read_all'}.peak"] if TIME else []
    return " ".join([f"cat {run} |", *peak, PY, "-c", f'"{READ_ALL}"']), cached_env(tmp)


#: ``cat`` reading a pipe whose buffer it first sets to 1 MiB, as the filters do
#: (benchmarks/bench.py's reference for the streaming filters)
PIPE_CAT = (f"{PY} -c \"import fcntl,os;fcntl.fcntl(0,getattr(fcntl,'F_SETPIPE_SZ',1031),"
            f"1 << 20);os.execvp('cat',['cat'])\"")


def kernel_costs(tmp: Path) -> dict[str, float | bool]:
    """The kernel's build as the install runs it [s], and the import's cost: ``python -X
    importtime`` of enctools.kernel (its self and cumulative microseconds) and the seconds
    of loading the library (ctypes and dlopen, on first use)."""
    sys.path.insert(0, str(ROOT))
    from enctools import kernel_build

    ok, build_s, _ = kernel_build.build(kernel_build.SOURCE, tmp / "_enckernel.so")
    code = ("import time; import enctools.kernel as k; t = time.perf_counter(); "
            "lib = k.library(); print(time.perf_counter() - t, lib is not None)")
    for _ in range(2):   # the second with the bytecode cached, as installed
        r = subprocess.run([PY, "-X", "importtime", "-c", code], capture_output=True,
                           text=True, check=True, env=cached_env(tmp, PYTHONPATH=str(ROOT)),
                           cwd=tmp)
    load_s, loaded = r.stdout.split()
    self_us = cumulative_us = 0
    for line in r.stderr.splitlines():   # import time: self [us] | cumulative | name
        parts = [p.strip() for p in line.removeprefix("import time:").split("|")]
        if parts[-1] in ("enctools.kernel", "ctypes", "_ctypes", "ctypes._endian"):
            self_us += int(parts[0])
        if parts[-1] == "enctools.kernel":
            cumulative_us = int(parts[1])
    return {"built": ok, "build_s": build_s, "import_self_us": self_us,
            "import_cumulative_us": cumulative_us, "load_s": float(load_s),
            "loaded": loaded == "True"}


def peak_mb(out: Path) -> float | None:
    """The check's peak memory [MB] (maximum resident set) as GNU time wrote it."""
    f = Path(f"{out}.peak")
    return int(f.read_text().split()[-1]) / 1024 if f.exists() else None


def deviations(path: Path) -> np.ndarray:
    """The checked curves and their u, whatever the columns' names."""
    t = pq.read_table(path)
    return np.column_stack([t.column(n).to_numpy() for n in t.column_names])


NAMES = {"kernel": "compiled kernel", "numpy": "numpy passes (`ENCTOOLS_KERNEL=numpy`)",
         "before": "before", "read_all": "`read_all`", "cat": "`cat` (1 MiB pipe)"}


def table(res: dict) -> str:
    """The Markdown table of one size: each command's CPU and wall seconds, its ratios to
    the numpy passes (CPU), to ``read_all`` (CPU, wall) and ``cat`` (wall), CPU per sample,
    peak memory; the load."""
    cpu, wall, peaks, n = res["cpu_s"], res["wall_s"], res["peak_mb"], res["samples"]
    lines = [f"| interp-check, continuous run, {res['revolutions']} r | CPU s | wall s | "
             "CPU vs numpy | CPU vs `read_all` | wall vs `read_all` | wall vs `cat` | "
             "CPU per sample [us] | peak memory |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for k in [k for k in NAMES if k in cpu]:
        peak = peaks.get(k)
        lines.append(
            f"| {NAMES[k]} | {cpu[k]:.2f} | {wall[k]:.2f} | "
            f"{cpu[k] / cpu['numpy']:.2f} | {cpu[k] / cpu['read_all']:.2f} | "
            f"{wall[k] / wall['read_all']:.2f} | {wall[k] / wall['cat']:.2f} | "
            f"{cpu[k] / n * 1e6:.3f} | {'' if peak is None else f'{peak:.0f} MB'} |")
    loads = "; ".join(" ".join(f"{x:.1f}" for x in la) for la in res["load_average"])
    lines.append(f"\nload average (1, 5, 15 min) at the start and the end: {loads} "
                 f"({os.cpu_count()} cores); largest difference of the curves and their u, "
                 f"kernel against numpy: {res['max_abs_diff_arcsec']:.2g} arcsec")
    return "\n".join(lines)


def costs_line(c: dict) -> str:
    """The kernel's build and import costs, as one line."""
    return (f"kernel: built {'yes' if c['built'] else 'NO'} in {c['build_s']:.2f} s (the "
            f"install's compiler call); import of enctools.kernel and ctypes "
            f"{c['import_self_us'] / 1e3:.1f} ms (python -X importtime, self), loading the "
            f"library {c['load_s'] * 1e3:.2f} ms ({'loaded' if c['loaded'] else 'NOT loaded'})")


def measure(revolutions: int, before: Path | None, repeat: int, d: Path) -> dict:
    """One size: the check with the kernel, with the numpy passes (and the code before),
    ``cat`` and ``read_all`` of the same bytes, in turn, the best of ``repeat``."""
    run = d / f"run{revolutions}.arrows"
    subprocess.run([PY, "-c", ENC, *RUN, "--revolutions", str(revolutions), "-o", str(run)],
                   check=True, env=dict(os.environ, PYTHONPATH=str(ROOT)), cwd=d)
    cpu: dict[str, float] = {}
    wall: dict[str, float] = {}

    def keep(name: str, t: tuple[float, float]) -> None:   # the best CPU and the best wall
        cpu[name] = min(cpu.get(name, t[0]), t[0])
        wall[name] = min(wall.get(name, t[1]), t[1])

    peaks: dict[str, float | None] = {}
    load = [os.getloadavg()]
    checks = [("kernel", ROOT, None), ("numpy", ROOT, "numpy")]
    if before is not None:
        checks.append(("before", before, "numpy"))
    for _ in range(repeat):
        for name, code, kernel in checks:
            cmd, env = check_shell(code, run, d / f"{name}.parquet", d, kernel)
            keep(name, timed(cmd, env, d))
            peaks[name] = peak_mb(d / f"{name}.parquet")
            keep("cat", timed(f"cat {run} | {PIPE_CAT} > /dev/null", dict(os.environ), d))
            cmd, env = read_all_shell(run, d)
            keep("read_all", timed(cmd, env, d))
            peaks["read_all"] = peak_mb(d / "read_all")
    load.append(os.getloadavg())
    diff = float(np.max(np.abs(deviations(d / "kernel.parquet")
                               - deviations(d / "numpy.parquet"))))
    diff_before = None if before is None else float(np.max(np.abs(
        deviations(d / "kernel.parquet") - deviations(d / "before.parquet"))))
    size = run.stat().st_size
    with pa.memory_map(str(run)) as f:     # the samples (rows), without reading them in
        samples = sum(b.num_rows for b in pa.ipc.open_stream(f))
    run.unlink()
    return {"revolutions": revolutions, "bytes": size, "samples": samples,
            "cpu_s": cpu, "wall_s": wall, "peak_mb": peaks,
            "load_average": load, "max_abs_diff_arcsec": diff,
            "max_abs_diff_before_arcsec": diff_before}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--revolutions", default="300,2000")
    ap.add_argument("--before", default="", help="also the code of this revision ('': none)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=str(ROOT / "bench-out"))
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    results: dict[str, object] = {"before": a.before or None, "sizes": []}
    with tempfile.TemporaryDirectory(prefix="interp-fit-") as tmp:
        d = Path(tmp)
        before = None
        if a.before:
            before = d / "before"
            before.mkdir()
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", a.before, "enctools",
                                      "schemas"], check=True, capture_output=True).stdout
            subprocess.run(["tar", "-x", "-C", str(before)], input=archive, check=True)
        costs = kernel_costs(d)
        results["kernel"] = costs
        print(costs_line(costs))
        for n in (int(r) for r in a.revolutions.split(",")):
            res = measure(n, before, a.repeat, d)
            results["sizes"].append(res)  # type: ignore[attr-defined]
            (out / "interp_fit.json").write_text(json.dumps(results, indent=1))
            print("\n" + table(res))
            if not res["max_abs_diff_arcsec"] < 1e-12:
                sys.exit(f"interp_fit: kernel and numpy differ by {res['max_abs_diff_arcsec']:.3g}")


if __name__ == "__main__":
    main()
