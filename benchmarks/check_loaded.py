#!/usr/bin/env python3
"""How long ``make check`` takes on a quiet machine and on a loaded one (wall and CPU).

"Loaded" here means: competitors this script starts itself, each a Python process
spinning in a loop (CPU-bound, no memory, no I/O, the same scheduling priority as the
tests, in this script's session), ``--per-core`` of them per core: by default one per
core and two per core. On two cores with two per core, four competitors share the
machine with ``make check``'s processes; Linux shares the CPU among the runnable
processes of a session (autogroup scheduling puts a session's processes in one group),
so each of the suite's processes gets about two cores / (4 + its running processes).
Work in other sessions or containers takes its own share beside that: the load average
is printed at the start and the end of every condition (the one-minute average lags a
change of load by about a minute).

Each condition times ``make check`` (the Makefile's own command, its choice of workers
included) ``--repeat`` times, quiet first then loaded, and keeps the run of least wall
time: its wall seconds, and the CPU seconds (user + system) of make and of every process
it waited for. ``--repo`` times another checkout's ``make check`` (e.g. a ``git
archive`` of main unpacked in /tmp) with this tree's virtual environment, so that
before and after are timed in one run with the same libraries; ``--make-args`` passes
variables to make (``CHECK_WORKERS=0``).

Not a test: ``make bench`` does not run it by default; run it by hand.

Usage: check_loaded.py [--repo DIR] [--per-core 0,1,2] [--repeat 2] [--make-args ARGS]
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent
SPIN = "while True:\n    pass\n"


def cpu_of_children() -> float:
    """CPU seconds (user + system) of the children this process has waited for."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def start_competitors(n: int) -> list[subprocess.Popen]:
    """``n`` processes spinning on a core each, started in a process group of their own."""
    return [subprocess.Popen([sys.executable, "-c", SPIN], process_group=0)
            for _ in range(n)]


def stop_competitors(procs: list[subprocess.Popen]) -> None:
    """Stop the competitors this script started (by their own process ids)."""
    for p in procs:
        if p.poll() is None:
            os.kill(p.pid, signal.SIGKILL)
    for p in procs:
        p.wait()


def make_check(repo: Path, venv: Path, make_args: list[str]) -> tuple[float, float, str]:
    """One ``make check`` in ``repo``: wall seconds, CPU seconds, its summary line and the
    workers it used. The venv's install steps are taken as done (``-o``)."""
    venv_args = [] if venv == repo / ".venv" else \
        [f"VENV={venv}", "-o", f"{venv}/.installed-test", "-o", f"{venv}/.installed"]
    cmd = ["make", "--no-print-directory", "-C", str(repo), *venv_args, "check", *make_args]
    cpu, wall = cpu_of_children(), time.perf_counter()
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall, cpu = time.perf_counter() - wall, cpu_of_children() - cpu
    if r.returncode != 0:
        sys.exit(f"check_loaded: make check failed ({r.returncode}):\n{r.stdout[-3000:]}")
    summary = [ln for ln in r.stdout.splitlines() if re.search(r"\d+ passed", ln)]
    workers = [ln for ln in r.stdout.splitlines() if ln.startswith("workers")]
    said = (summary[-1].strip("= ") if summary else "?") + \
        (f"; {workers[-1]}" if workers else "")
    return wall, cpu, said


def condition(repo: Path, venv: Path, competitors: int, repeat: int,
              make_args: list[str]) -> dict:
    """``make check`` ``repeat`` times beside ``competitors`` spinning processes: the run
    of least wall time, and the load averages at the start and the end."""
    procs = start_competitors(competitors)
    try:
        time.sleep(1.0 if competitors else 0.0)  # the competitors running before we start
        load0 = os.getloadavg()[0]
        runs = [make_check(repo, venv, make_args) for _ in range(repeat)]
        load1 = os.getloadavg()[0]
    finally:
        stop_competitors(procs)
    wall, cpu, said = min(runs)
    return {"competitors": competitors, "wall": wall, "cpu": cpu, "said": said,
            "walls": [r[0] for r in runs], "load": (load0, load1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repo", type=Path, default=HERE, help="the checkout to time")
    ap.add_argument("--venv", type=Path, default=HERE / ".venv",
                    help="the virtual environment (this tree's by default)")
    ap.add_argument("--per-core", default="0,1,2",
                    help="competitors per core, one condition each (0: quiet)")
    ap.add_argument("--repeat", type=int, default=2, help="runs per condition (best kept)")
    ap.add_argument("--make-args", default="", help="variables for make, e.g. CHECK_WORKERS=0")
    a = ap.parse_args()
    cores = os.cpu_count() or 1
    repo, venv = a.repo.resolve(), a.venv.resolve()
    print(f"make check in {repo.name}, {cores} cores, best of {a.repeat}; load average at the "
          f"start (1, 5, 15 min): {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print("| competitors | wall s | CPU s | all walls s | load average start-end | result |")
    print("|---:|---:|---:|---|---|---|")
    for k in (int(x) for x in a.per_core.split(",")):
        c = condition(repo, venv, k * cores, a.repeat, shlex.split(a.make_args))
        print(f"| {c['competitors']} ({k}/core) | {c['wall']:.1f} | {c['cpu']:.1f} | "
              f"{', '.join(f'{w:.1f}' for w in c['walls'])} | "
              f"{c['load'][0]:.2f}-{c['load'][1]:.2f} | {c['said']} |", flush=True)


if __name__ == "__main__":
    main()
