#!/usr/bin/env python3
"""enctools benchmarks: throughput, peak memory and start-up cost of every command.

Run with ``make bench``. Prints a Markdown table (for the README) and writes
``bench-out/bench.json``. Every figure is measured in one run on one machine, and the
ones that matter are ratios to a reference measured in the same run (raw ``cat``
throughput over the same bytes, a bare ``python -c pass``), each reference timed in
turn with what it is compared to and the best of three taken, so a busy or slow
machine changes the absolute numbers more than the ratios.

"Before" figures come from the code of another commit (``--before``, main by default),
unpacked into the output folder and run with the same Python and libraries, timed in
turn with the code of this tree: the ratio after / before is of one run.

Usage: bench.py [--revolutions 20,200,2000] [--out bench-out] [--quick] [--before REV]
                [--only filters] [--filters selfcal,interp-check] [--variants]

``--only filters`` measures start-up and the filter rows alone; ``--filters`` chooses which
filters; ``--variants`` adds each chosen filter run with ``ENCTOOLS_KERNEL=numpy`` and, with
``--before``, run by the before code, timed in turn with the rest.
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
    "compare": ["compare", "-q", "--device", "H1,H2,H3,H4", "--reference", "P1,P2"],
    "selfcal": ["selfcal", "--method", "esa", "--ref-head", "H1", "--heads", "H5,H6,H7"],
    "info": ["info"],
    # streams a continuous run: a trend per 0.5 deg window, sums of the fit only
    # (at the 3 ms of RUN, P2 is stroboscopic: skipped with a warning)
    "interp-check": ["interp-check", "-q", "--reference", "P1"],
}
#: a filter row's command prefix (``env VAR=value``), for the variants of --variants
PREFIX: dict[str, str] = {}
#: exit statuses that count as a measured run (besides 0)
ACCEPT: dict[str, tuple[int, ...]] = {}
#: the pipe buffer the filters ask for (enctools.data.pipes.PIPE_BUFFER) and the default
PIPE_BUFFERS = {"1 MiB": 1 << 20, "64 KiB": 0}
#: the runs the filters read: sjtu-dual at the paper's 3 ms (not the rig's 5.05 ms), so that
#: the figures stay comparable with earlier measurements (the README's table)
RUN = "acquire --rig sjtu-dual --interval 0.003"
SAMPLES_PER_REV = 20_000  # 1 r/min every 3 ms


def pipe_cat(size: int) -> str:
    """``cat`` reading a pipe whose buffer it first sets to ``size`` bytes (0: as created)."""
    code = ("import fcntl,os,sys;n=int(sys.argv[1]);"
            "n and fcntl.fcntl(0,getattr(fcntl,'F_SETPIPE_SZ',1031),n);"
            "os.execvp('cat',['cat'])")
    return f"{sys.executable} -S -c \"{code}\" {size}"


def available(command: str) -> bool:
    r = subprocess.run([ENC, command, "--help"], capture_output=True)
    return r.returncode == 0


def timed(shell: str, repeat: int = 1, accept: tuple[int, ...] = (0,)) -> dict[str, float]:
    """Run a bash pipeline; the last stage's peak RSS comes from GNU time in the pipeline."""
    import resource

    times, cpus = [], []
    peak = 0.0
    status = 0
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        r = subprocess.run(["bash", "-c", shell], capture_output=True)
        times.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        if r.returncode not in accept:
            raise RuntimeError(f"{shell}: {r.stderr.decode()[-500:]}")
        status = r.returncode
        for line in r.stderr.decode().splitlines():
            if line.startswith("PEAK_KB "):
                peak = max(peak, float(line.split()[1]))
    return {"seconds": min(times), "median": statistics.median(times), "peak_mb": peak / 1024,
            "status": status, "cpu_seconds": min(cpus)}


def gnu_time() -> str:
    return "/usr/bin/time -f 'PEAK_KB %M'"


def cpu_model() -> str:
    """The CPU's model name as the kernel reports it (/proc/cpuinfo), else platform's."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def memory_gib() -> float:
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                return int(line.split()[1]) / (1 << 20)
    except OSError:
        pass
    return float("nan")


#: the libraries whose versions the figures depend on
LIBRARIES = ("numpy", "pyarrow", "scipy", "matplotlib", "h5py", "click")


def machine(bytecode_env: str | None) -> dict[str, object]:
    """What the figures were measured on: CPU model, cores, memory, Python, libraries and
    how compiled bytecode was handled (``bytecode_env``: the caller's
    PYTHONDONTWRITEBYTECODE, which the bench unsets for its own runs)."""
    from importlib.metadata import PackageNotFoundError, version

    libs = {}
    for name in LIBRARIES:
        try:
            libs[name] = version(name)
        except PackageNotFoundError:
            libs[name] = None
    return {"cpu": cpu_model(), "cores": os.cpu_count(), "memory_gib": round(memory_gib(), 1),
            "python": platform.python_version(), "libraries": libs,
            "bytecode": ("cached (PYTHONPYCACHEPREFIX in the output folder); the caller had "
                         f"PYTHONDONTWRITEBYTECODE={bytecode_env}" if bytecode_env else
                         "cached (PYTHONPYCACHEPREFIX in the output folder)")}


def before_tree(rev: str, out: Path) -> dict[str, str] | None:
    """The code of commit ``rev`` unpacked into ``out/before`` (None when git cannot):
    the environment that runs ``enc`` on it (PYTHONPATH ahead of this tree's install)."""
    d = out / "before"
    shutil.rmtree(d, ignore_errors=True)
    d.mkdir(parents=True)
    r = subprocess.run(f"git -C {ROOT} archive {rev} enctools schemas | tar -x -C {d}", shell=True,
                       capture_output=True)
    if r.returncode != 0:
        print(f"bench: no before figures ({rev}: {r.stderr.decode().strip()[:200]})",
              file=sys.stderr)
        return None
    _build_kernel(d / "enctools")
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", rev],
                            capture_output=True, text=True).stdout.strip()
    return {"PYTHONPATH": str(d), "rev": rev, "commit": commit}


def _build_kernel(package: Path) -> None:
    """The before code's compiled kernel, built as its install would (when it has one): its
    filters then run as installed, not on the numpy passes."""
    source = package / "_kernel.c"
    if not source.exists():
        return
    import importlib.util

    spec = importlib.util.spec_from_file_location("before_kernel_build",
                                                  package / "kernel_build.py")
    if spec is None or spec.loader is None:
        return
    how = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(how)
    ok, _, message = how.build(source, package / "_enckernel.so")
    if not ok:
        print(f"bench: the before code's kernel was not built ({message[:200]})",
              file=sys.stderr)


def with_env(env: dict[str, str] | None, shell: str) -> str:
    """``shell`` run with the before tree ahead on the path (as given when env is None)."""
    return shell if env is None else f"PYTHONPATH={env['PYTHONPATH']} {shell}"


def startup(repeat: int) -> dict[str, float]:
    """``enc --help`` against bare Python and ``import click`` (wall seconds; the ratio of CPU
    seconds, timed in turn: see :func:`interleaved`)."""
    py = sys.executable
    t = interleaved({"python -c pass": f"{py} -c pass",
                     "python -c 'import click'": f"{py} -c 'import click'",
                     "python -c 'import numpy, pyarrow'": f"{py} -c 'import numpy, pyarrow'",
                     "enc --help": f"{ENC} --help > /dev/null"}, repeat)
    out = {k: v[0] for k, v in t.items()}
    out["enc --help / import click"] = t["enc --help"][1] / t["python -c 'import click'"][1]
    return out


#: a run of each command on a tiny input ({d}: a folder of inputs made by tiny_inputs)
TINY_RUNS: dict[str, str] = {
    "acquire": "acquire --rig sjtu-dual --revolutions 0.0005 -q",
    "average-heads": "average-heads {d}/r001.arrows",
    "selfcal": "selfcal {d}/r2.arrows",
    "design": "design --angles 0,90,200 -q",
    "compare": "compare {d}/r2.arrows --device H1,H2,H3,H4 --reference P1,P2 -q",
    "interp-check": "interp-check {d}/r001.arrows --reference P1 -q",
    "fit-rbf": "fit-rbf {d}/points.arrows --spread 15 -q",
    "make-rom": "make-rom {d}/model.arrows --bits 10 -q{allow}",
    "latency": "latency --bits 23 --delay 1e-6",
    "points": "points {table1}",
    "closure": "closure {d}/closure.arrows -q",
    "correct": "correct {d}/points.arrows --table {d}/table.mif -q",
    "report": "report {d}/points.arrows",
    "info": "info {d}/tiny.arrows",
    "rig": "rig check sjtu-dual",
}


def overrides(env: dict[str, str] | None) -> str:
    """make-rom's options that write the table-1 model at any size, where the code (this
    one, or the before tree of ``env``) has them: its 24 points cannot tell it from noise
    (enc-fit-rbf(1), GAIN) and a 10-bit LSB rounds it to zeros. The bench times the
    writing, not that decision."""
    r = subprocess.run(with_env(env, f"{ENC} make-rom --help"), shell=True,
                       capture_output=True, text=True, check=False)
    return " --allow-no-gain --allow-coarse" if "--allow-no-gain" in r.stdout else ""


def tiny_inputs(d: Path) -> None:
    """The small inputs of TINY_RUNS: 10 rows, 0.01 and 2.2 revolutions, table 1 points, a
    model and its 1024-entry table, a closure run (the smallest: 24 settings of 24 faces)."""
    table1 = ROOT / "tests" / "data" / "seed001_table1.csv"
    for cmd in (f"acquire --rig sjtu-dual --revolutions 0.0005 -o {d}/tiny.arrows",
                f"acquire --rig sjtu-dual --revolutions 0.01 -o {d}/r001.arrows",
                f"acquire --rig sjtu-dual --revolutions 2.2 --interval 0.01 -o {d}/r2.arrows",
                f"points {table1} -o {d}/points.arrows",
                f"fit-rbf {d}/points.arrows -q -o {d}/model.arrows",
                f"make-rom {d}/model.arrows --bits 10 -q -o {d}/table.mif{overrides(None)}",
                f"acquire --rig ciomp-23bit --mode closure -q -o {d}/closure.arrows"):
        timed(f"{ENC} {cmd} --force")


def cpu_timed(shell: str) -> tuple[float, float]:
    """Wall and CPU (user + system, of the whole process tree) seconds of one bash command."""
    import resource

    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    r = subprocess.run(["bash", "-c", shell], capture_output=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        raise RuntimeError(f"{shell}: {r.stderr.decode()[-500:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def interleaved(shells: dict[str, str], repeat: int) -> dict[str, tuple[float, float]]:
    """The fastest (wall, CPU) seconds of ``repeat`` runs of each command, run in turn (a, b,
    c, a, b, c, ...), so a machine busy for a while slows references and commands alike.
    The ratios use CPU seconds: start-up is CPU work, and CPU time barely changes when
    other processes share the cores, where wall time does."""
    best = {k: (float("inf"), float("inf")) for k in shells}
    for _ in range(repeat):
        for k, shell in shells.items():
            wall, cpu = cpu_timed(shell)
            best[k] = (min(best[k][0], wall), min(best[k][1], cpu))
    return best


def command_startup(out: Path, repeat: int,
                    before: dict[str, str] | None = None) -> dict[str, dict]:
    """Every command's fixed cost: ``enc CMD --help`` and a run on a tiny input.

    Ratios: --help to ``python -c pass`` and ``import click``; the run to ``import
    numpy, pyarrow`` (what any command that reads a stream must load), and the same
    run of the ``before`` code. Each command is timed in turn with its references
    (:func:`interleaved`).
    """
    from enctools.cli.main import COMMANDS

    d = out / "tiny"
    d.mkdir(exist_ok=True)
    tiny_inputs(d)
    table1 = ROOT / "tests" / "data" / "seed001_table1.csv"
    py = sys.executable
    refs = {"pass": f"{py} -c pass", "click": f"{py} -c 'import click'",
            "numpy, pyarrow": f"{py} -c 'import numpy, pyarrow'"}
    rows: dict[str, dict] = {}
    for name in COMMANDS:
        if not available(name):
            continue
        shells = dict(refs, help=f"{ENC} {name} --help > /dev/null")
        if name in TINY_RUNS:
            args = TINY_RUNS[name].format(d=d, table1=table1, allow=overrides(None))
            shells["tiny"] = f"{ENC} {args} > /dev/null"  # timed as the references: no GNU time
            if before is not None and _has_command(before, name):
                args = TINY_RUNS[name].format(d=d, table1=table1, allow=overrides(before))
                shells["tiny before"] = with_env(before, f"{ENC} {args} > /dev/null")
        t = interleaved(shells, repeat)
        cpu = {k: v[1] for k, v in t.items()}
        row = {"help_seconds": t["help"][0], "help_cpu_seconds": cpu["help"],
               "help_vs_pass": cpu["help"] / cpu["pass"], "help_vs_click": cpu["help"] / cpu["click"],
               "references": {k: {"seconds": t[k][0], "cpu_seconds": cpu[k]} for k in refs}}
        if "tiny" in t:
            peak = timed(f"{gnu_time()} {ENC} {args} > /dev/null")["peak_mb"]
            row |= {"tiny_run": f"enc {TINY_RUNS[name].format(d='D', table1='table1.csv', allow='')}",
                    "tiny_seconds": t["tiny"][0], "tiny_cpu_seconds": cpu["tiny"],
                    "tiny_vs_numpy_pyarrow": cpu["tiny"] / cpu["numpy, pyarrow"],
                    "tiny_peak_mb": peak}
            if "tiny before" in t:
                row |= {"tiny_before_cpu_seconds": cpu["tiny before"],
                        "tiny_before_vs_numpy_pyarrow": cpu["tiny before"] / cpu["numpy, pyarrow"]}
        rows[name] = row
    shutil.rmtree(d)
    return rows


def _has_command(before: dict[str, str], name: str) -> bool:
    """Whether the ``before`` code has the command (enc closure, say, came later)."""
    return subprocess.run(["bash", "-c", with_env(before, f"{ENC} {name} --help")],
                          capture_output=True).returncode == 0


#: make-rom rows: every memory table format (its file's extension), at 2^20 and 2^26 entries,
#: from the RBF model of seed 001 table 1
ROM_FORMATS = (("bin", "bin"), ("mif", "mif"), ("coe", "coe"), ("mem", "mem"), ("ihex", "hex"),
               ("csv", "csv"))
ROM_BITS = (20, 26)


def fresh_cpu(shells: dict[str, str], outputs: dict[str, Path], repeat: int,
              printed: tuple[str, ...] = (), times: dict[str, int] | None = None
              ) -> dict[str, tuple[float, ...]]:
    """As :func:`interleaved` (the fastest of ``repeat`` runs in turn, wall and CPU seconds),
    each command's output file removed before it runs: replacing a file frees its pages in
    the kernel, work that neither a table's writing nor ``dd``'s is. A command in ``printed``
    prints its own CPU seconds, one figure a line; they follow its wall and CPU seconds.
    ``times``: runs of a command in each turn (default 1)."""
    best: dict[str, list[float]] = {}
    turn = [(name, cmd) for name, cmd in shells.items() for _ in range((times or {}).get(name, 1))]
    for _ in range(repeat):
        for k, shell in turn:
            for f in outputs.values():
                f.unlink(missing_ok=True)
            if k in printed:
                t0 = time.perf_counter()
                r = subprocess.run(["bash", "-c", shell], capture_output=True, text=True)
                if r.returncode != 0:
                    raise RuntimeError(f"{shell}: {r.stderr[-500:]}")
                got = [time.perf_counter() - t0, float("nan"),
                       *(float(x) for x in r.stdout.split())]
            else:
                got = list(cpu_timed(shell))
            best[k] = [min(a, b) for a, b in zip(best.get(k, got), got, strict=True)]
    return {k: tuple(v) for k, v in best.items()}


def make_rom_rows(out: Path, repeat: int, quick: bool,
                  before: dict[str, str] | None = None) -> list[dict]:
    """make-rom of the table-1 RBF model into 2^20 and 2^26 entries in every memory table
    format: the whole command and the table's writer alone (benchmarks/rom_writer.py, from
    the binary table), each timed in turn with ``dd`` writing as many bytes into the same
    folder and with the ``before`` code; ratios of CPU seconds. Peak memory of both codes;
    the writer's ``--verify`` (reading back) once."""
    d = out / "rom"
    d.mkdir(exist_ok=True)
    table1 = ROOT / "tests" / "data" / "seed001_table1.csv"
    timed(f"{ENC} fit-rbf {table1} -q -o {d}/model.arrows --force")
    rows = []
    for bits in ROM_BITS:
        if quick and bits > 20:
            continue
        image = d / f"image{bits}.bin"
        timed(f"{ENC} make-rom {d}/model.arrows --bits {bits} -q -o {image} --force"
              f"{overrides(None)}")
        for fmt, ext in ROM_FORMATS:
            rows.append(_make_rom_row(d, bits, fmt, ext, image, repeat, before))
    shutil.rmtree(d)
    return rows


def _make_rom_row(d: Path, bits: int, fmt: str, ext: str, image: Path, repeat: int,
                  before: dict[str, str] | None) -> dict:
    """One format at one size: the whole command, the writer alone, --verify, peak memory."""
    target, kept, dd_out = d / f"table.{ext}", d / f"before.{ext}", d / "dd.out"
    # --force: a CSV table's sidecar stays when the table is removed between the runs
    run = f"{ENC} make-rom {d}/model.arrows --bits {bits} -q --force -o {target}{overrides(None)}"
    peak = timed(f"{gnu_time()} {run} --force")["peak_mb"]
    size = target.stat().st_size
    # the file's bytes exactly, in 1 MiB writes (the last shorter): not rounded to whole MiB
    dd = f"dd if=/dev/zero of={dd_out} bs=1M count={size} iflag=count_bytes status=none"
    writer = f"{sys.executable} {ROOT}/benchmarks/rom_writer.py {image} {fmt} "
    shells = {"after": run, "dd": dd, "writer": writer + str(target)}
    if before is not None:
        run_before = f"{ENC} make-rom {d}/model.arrows --bits {bits} -q --force -o {kept}"
        shells |= {"before": with_env(before, run_before + overrides(before)),
                   "writer before": with_env(before, writer + str(kept))}
    # dd and the writer three times a turn: on a shared machine the kernel's CPU seconds
    # for the same bytes written into the page cache vary by 2-5x from run to run, for
    # both alike (a run that finds fresh pages slow to get): the best of nine each
    t = fresh_cpu(shells, {"after": target, "before": kept, "dd": dd_out}, repeat,
                  printed=("writer", "writer before"), times={"dd": 3, "writer": 3})
    cpu_dd = t["dd"][1]
    row = {"entries": 1 << bits, "bits": bits, "format": ext, "bytes": size, "peak_mb": peak,
           "seconds": t["after"][0], "cpu_seconds": t["after"][1],
           "entries_per_s": (1 << bits) / t["after"][0], "dd_seconds": t["dd"][0],
           "dd_cpu_seconds": cpu_dd, "vs_dd": t["after"][1] / cpu_dd,
           "writer_cpu_seconds": t["writer"][2], "writer_vs_dd": t["writer"][2] / cpu_dd,
           "verify_cpu_seconds": _verify(shells["writer"])}
    if before is not None:
        row |= {"before_seconds": t["before"][0], "before_cpu_seconds": t["before"][1],
                "before_vs_dd": t["before"][1] / cpu_dd,
                "writer_before_cpu_seconds": t["writer before"][2],
                "writer_before_vs_dd": t["writer before"][2] / cpu_dd,
                "verify_before_cpu_seconds": _verify(shells["writer before"]),
                # the two writers' files, comment and all: byte for byte
                "writer_identical_to_before": _same_bytes(target, kept, "cat")}
        timed(f"{run} --force")
        row["before_peak_mb"] = timed(with_env(before, f"{gnu_time()} {run} --force").replace(
            f"-o {target}", f"-o {kept}"))["peak_mb"]
        # the command's tables; the provenance comment (time, command line) aside
        # (a binary image has none: compared byte for byte, never through grep)
        row["identical_to_before"] = _same_bytes(target, kept, "cat" if fmt == "bin" else
                                                 r"grep -a -v -e '^-- ' -e '^; ' -e '^// '")
    for f in (target, kept, dd_out):
        f.unlink(missing_ok=True)
    return row


def _verify(writer: str) -> float:
    """The CPU seconds of reading a table back (``--verify``), the fastest of two runs (the
    reading allocates the file's bytes and the values afresh: page faults vary most)."""
    return min(_printed(f"{writer} --verify")[1] for _ in range(2))


def _printed(shell: str) -> list[float]:
    """The figures a command prints on stdout, one a line."""
    r = subprocess.run(["bash", "-c", shell], capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{shell}: {r.stderr[-500:]}")
    return [float(x) for x in r.stdout.split()]


def _same_bytes(a: Path, b: Path, through: str) -> bool:
    """Whether two files are the same bytes once passed through the ``through`` filter."""
    return subprocess.run(["bash", "-c", f"cmp -s <({through} {a}) <({through} {b})"]
                          ).returncode == 0


#: the seed 000 campaign's report as `make demo` writes it (examples/sjtu-dual.mk, step 11)
REPORT_INPUTS = ("grad.parquet", "grad-spectrum.parquet", "h-p.parquet", "interp.parquet",
                 "interp-by-p1.parquet", "interp-run.parquet")


def report_rows(out: Path, repeat: int, before: dict[str, str] | None) -> dict[str, dict]:
    """``enc report`` of the seed 000 campaign: HTML + PDF, text only, JSON only; this
    tree and the ``before`` code in turn (wall and CPU seconds, the best of ``repeat``)."""
    d = out / "campaign"
    r = subprocess.run(["make", "-s", "-f", str(ROOT / "examples" / "sjtu-dual.mk"),
                        f"ENC={ENC}", f"OUT={d}", str(d / "report.html")],
                       capture_output=True, cwd=ROOT)
    if r.returncode != 0:
        raise RuntimeError(f"campaign: {r.stderr.decode()[-500:]}")
    inputs = " ".join(str(d / f) for f in REPORT_INPUTS)
    runs = {"HTML + PDF": f"{ENC} report {inputs} --html {d}/r.html --pdf {d}/r.pdf --force",
            "text": f"{ENC} report {inputs}", "JSON": f"{ENC} report {inputs} --json"}
    rows: dict[str, dict] = {}
    for label, run in runs.items():
        shells = {"after": f"{run} > /dev/null"}
        if before is not None:
            shells["before"] = with_env(before, shells["after"])
        t = interleaved(shells, repeat)
        row = {"seconds": t["after"][0], "cpu_seconds": t["after"][1]}
        if "before" in t:
            row |= {"before_seconds": t["before"][0], "before_cpu_seconds": t["before"][1],
                    "speed_up_cpu": t["before"][1] / t["after"][1]}
        if before is not None:  # the same output from both
            a = subprocess.run(["bash", "-c", run], capture_output=True).stdout
            b = subprocess.run(["bash", "-c", with_env(before, run)], capture_output=True).stdout
            row["stdout_identical_to_before"] = a == b
        rows[label] = row
    shutil.rmtree(d)
    return rows


#: fit-rbf's default search (spreads x smoothings, closed-form leave-one-out) against one
#: plain fit (one spread and smoothing), in a child on one BLAS thread as enc runs; on the
#: MagAlpha run at its measured angle (../shared/data/magalpha) and on 5000 noisy points
FIT_RBF_TIMING = """
import json, sys, time
import numpy as np
from enctools.models.rbf import choose_network, fit_smoothed
sets = {}
src = sys.argv[1]
if src:
    rows = np.loadtxt(src, delimiter=",", skiprows=1)
    d = np.deg2rad(rows[:, 1] - rows[:, 0])
    d = np.angle(np.exp(1j * (d - np.angle(np.mean(np.exp(1j * d))))))
    sets["MagAlpha, 200 points"] = (np.mod(rows[:, 1], 360.0), np.rad2deg(d) * 3600.0)
x = np.sort(np.random.default_rng(1).uniform(0.0, 360.0, 5000))
sets["5000 noisy points"] = (x, 3600.0 * np.sin(np.deg2rad(2 * x)) + np.random.default_rng(2).normal(0, 100, x.size))
out = {}
for name, (x, y) in sets.items():
    t0, c0 = time.perf_counter(), time.process_time()
    model, choice = choose_network(x, y)
    search, search_cpu = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    fit_smoothed(x, y, choice.spread_deg, choice.smoothing)
    plain, plain_cpu = time.perf_counter() - t0, time.process_time() - c0
    out[name] = {"search_s": search, "plain_s": plain, "search_cpu_s": search_cpu,
                 "plain_cpu_s": plain_cpu, "ratio": search_cpu / plain_cpu, "tried": choice.tried,
                 "loo_rms_arcsec": float(np.sqrt(np.mean(choice.loo ** 2)))}
print(json.dumps(out))
"""


def fit_rbf_rows() -> dict[str, dict]:
    """fit-rbf's default spread search: seconds and the ratio to one plain fit."""
    src = ROOT.parent / "shared" / "data" / "magalpha" / "calibration_data_input_example.csv"
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    r = subprocess.run([sys.executable, "-c", FIT_RBF_TIMING, str(src) if src.exists() else ""],
                       capture_output=True, env=env, check=True)
    return json.loads(r.stdout)


def _fit_rbf_table(res: dict) -> list[str]:
    rows = res.get("fit_rbf") or {}
    if not rows:
        return []
    lines = ["", "| fit-rbf default search | networks tried | search [s] | search [CPU s] "
             "| one plain fit [CPU s] | ratio (CPU) |", "|---|---:|---:|---:|---:|---:|"]
    for name, r in rows.items():
        lines.append(f"| {name} | {r['tried']} | {r['search_s']:.3f} | {r['search_cpu_s']:.3f} "
                     f"| {r['plain_cpu_s']:.4f} | {r['ratio']:.0f} |")
    return lines


def measure(n: int, out: Path, filters: dict[str, list[str]], repeat: int,
            tiny: dict[str, float]) -> dict[str, object]:
    """One input size: the simulator, the raw pipe (both buffers) and every filter."""
    data = out / f"raw-{n}.arrows"
    samples = n * SAMPLES_PER_REV
    head_samples = samples * HEADS
    acq = timed(f"{gnu_time()} {ENC} {RUN} --revolutions {n} -o {data} --force")
    size = data.stat().st_size
    row: dict[str, object] = {
        "revolutions": n, "samples": samples, "head_samples": head_samples, "bytes": size,
        "acquire": {"head_samples_per_s": head_samples / acq["seconds"],
                    "samples_per_s": samples / acq["seconds"], "seconds": acq["seconds"],
                    "peak_mb": acq["peak_mb"]}}
    # the references and the filters in turn (cat, cat, filter, filter, ..., cat, cat, ...),
    # best of each: a machine busy for a while slows references and filters alike
    shells = {f"cat {label}": f"cat {data} | {pipe_cat(buf)} > /dev/null"
              for label, buf in PIPE_BUFFERS.items()}
    shells |= {name: f"cat {data} | {gnu_time()} {PREFIX.get(name, '')}{ENC} {' '.join(argv)} "
                     "> /dev/null"
               for name, argv in filters.items()}
    best: dict[str, dict[str, float]] = {}
    for _ in range(max(repeat, 3) if repeat > 1 else 1):
        for key, shell in shells.items():
            t = timed(shell, 1, ACCEPT.get(key, (0,)))
            if key not in best or t["seconds"] < best[key]["seconds"]:
                best[key] = t | {"peak_mb": max(t["peak_mb"], best.get(key, t)["peak_mb"]),
                                 "cpu_seconds": min(t["cpu_seconds"],
                                                    best.get(key, t)["cpu_seconds"])}
            else:
                best[key]["cpu_seconds"] = min(best[key]["cpu_seconds"], t["cpu_seconds"])
    cat: dict[str, dict[str, float]] = {}
    for label in PIPE_BUFFERS:
        c = best[f"cat {label}"]
        cat[label] = {"seconds": c["seconds"], "cpu_seconds": c["cpu_seconds"],
                      "bytes_per_s": size / c["seconds"],
                      "head_samples_per_s": head_samples / c["seconds"]}
    row["cat"] = cat
    ref = cat["1 MiB"]  # the buffer the filters use
    for name in filters:
        m = best[name]
        steady = m["seconds"] - tiny.get(name, 0.0)
        r: dict[str, object] = {
            "seconds": m["seconds"], "head_samples_per_s": head_samples / m["seconds"],
            "ratio_to_cat": ref["seconds"] / m["seconds"],
            "ratio_to_cat_64k": cat["64 KiB"]["seconds"] / m["seconds"],
            # CPU of the whole pipeline (cat and the filter) against that of cat's: what a
            # loaded machine changes least
            "cpu_seconds": m["cpu_seconds"], "cpu_ratio_to_cat": ref["cpu_seconds"] / m["cpu_seconds"],
            "peak_mb": m["peak_mb"]}
        if m["status"] != 0:
            r["refused"] = True
        elif steady > 0 and n > 1:
            r["steady_head_samples_per_s"] = head_samples / steady
            r["steady_ratio_to_cat"] = ref["seconds"] / steady
        row[name] = r
    data.unlink()
    return row


def variants(filters: dict[str, list[str]],
             before: dict[str, str] | None) -> dict[str, list[str]]:
    """Each filter, then it with the numpy passes (ENCTOOLS_KERNEL=numpy) and, given the
    before code, by that code: rows named "NAME, numpy passes" and "NAME, before"."""
    out: dict[str, list[str]] = {}
    for name, argv in filters.items():
        out[name] = argv
        out[f"{name}, numpy passes"] = argv
        PREFIX[f"{name}, numpy passes"] = "env ENCTOOLS_KERNEL=numpy "
        if before is not None:
            out[f"{name}, before"] = argv
            PREFIX[f"{name}, before"] = f"env PYTHONPATH={before['PYTHONPATH']} "
    return out


def done(results: dict, out: Path, part: str) -> None:
    """Keep what is measured so far (bench.json), say so on stderr."""
    (out / "bench.json").write_text(json.dumps(results, indent=2))
    print(f"bench: {part} done", file=sys.stderr)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--revolutions", default="20,200,2000")
    ap.add_argument("--out", default=str(ROOT / "bench-out"))
    ap.add_argument("--quick", action="store_true", help="20 and 200 revolutions, one repeat")
    ap.add_argument("--before", default="main",
                    help="the commit whose code gives the before figures ('' for none)")
    ap.add_argument("--only", choices=("all", "filters"), default="all",
                    help="filters: start-up and the filter rows alone")
    ap.add_argument("--filters", default=",".join(FILTERS),
                    help="the filters measured (comma-separated)")
    ap.add_argument("--variants", action="store_true",
                    help="each filter also with ENCTOOLS_KERNEL=numpy and by the before code")
    args = ap.parse_args()
    revs = [20, 200] if args.quick else [int(r) for r in args.revolutions.split(",")]
    repeat = 1 if args.quick else 3
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    # as installed: compiled bytecode cached (here in bench-out, not in the source tree)
    bytecode_env = os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    os.environ.setdefault("PYTHONPYCACHEPREFIX", str(out.resolve() / "pycache"))
    before = before_tree(args.before, out) if args.before else None
    results: dict[str, object] = {
        "date": time.strftime("%Y-%m-%d"),
        "machine": machine(bytecode_env),
        "before": None if before is None else {"rev": before["rev"], "commit": before["commit"]},
        "startup": startup(5),
        "runs": [],
    }
    if args.only == "all":
        results["commands"] = command_startup(out, 7, before)
        done(results, out, "start-up")
        results["report"] = report_rows(out, 1 if args.quick else 3, before)
        done(results, out, "report")
        results["make_rom"] = make_rom_rows(out, repeat, args.quick, before)
        done(results, out, "make-rom")
        results["fit_rbf"] = fit_rbf_rows()
        done(results, out, "fit-rbf")
    chosen = args.filters.split(",")
    filters = {k: v for k, v in FILTERS.items() if k in chosen and available(v[0])}
    if args.variants:
        filters = variants(filters, before)
    tiny = out / "raw-tiny.arrows"
    timed(f"{ENC} {RUN} --revolutions 2 -o {tiny} --force")
    # start-up and the work on two revolutions: subtracted to give the steady pass-through rate
    results["filters_tiny_input"] = {
        name: timed(f"cat {tiny} | {PREFIX.get(name, '')}{ENC} {' '.join(argv)} > /dev/null",
                    max(repeat, 3))["seconds"]
        for name, argv in filters.items()}
    tiny.unlink()
    for n in revs:
        results["runs"].append(measure(n, out, filters, repeat, results["filters_tiny_input"]))
        print(f"bench: {n} revolutions done", file=sys.stderr)
    (out / "bench.json").write_text(json.dumps(results, indent=2))
    print(markdown(results))


def machine_line(res: dict) -> str:
    """One sentence: the date, the machine and what it ran (the before code's commit)."""
    m = res["machine"]
    if not isinstance(m, dict):  # an older bench.json: the machine as one string
        return f"Measured {res['date']} on {m} (`make bench`)."
    libs = ", ".join(f"{k} {v}" for k, v in m["libraries"].items() if v)
    before = res.get("before")
    then = f"; before: the code of {before['rev']} ({before['commit']})" if before else ""
    return (f"Measured {res['date']} with `make bench` on {m['cores']} cores of an "
            f"{m['cpu']}, {m['memory_gib']:g} GiB, Python {m['python']}, {libs}; bytecode "
            f"{m['bytecode']}{then}.")


def markdown(res: dict) -> str:
    lines = [machine_line(res), ""]
    lines += ["| command | revolutions | head-samples/s | vs `cat` | vs `cat`, after start-up "
              "| vs `cat`, CPU | peak memory |",
              "|---|---:|---:|---:|---:|---:|---:|"]
    for run in res["runs"]:
        n = run["revolutions"]
        for label, c in run.get("cat", {}).items():
            lines.append(f"| `cat` ({label} pipe) | {n} | {c['head_samples_per_s']:.3g} | "
                         f"{c['bytes_per_s'] / 1e9:.2f} GB/s | | | |")
        for name, m in run.items():
            if not isinstance(m, dict) or name == "cat":
                continue
            ratio = f"{m['ratio_to_cat']:.2f}" if "ratio_to_cat" in m else ""
            steady = f"{m['steady_ratio_to_cat']:.2f}" if "steady_ratio_to_cat" in m else ""
            rate = f"{m['head_samples_per_s']:.3g}"
            if m.get("refused"):
                rate, ratio, steady = "refused (a sweep is fitted whole)", "", ""
            elif name == "acquire":
                rate += f" ({m['samples_per_s']:.3g} samples/s)"
            cpu = (f"{m['cpu_ratio_to_cat']:.2f}" if "cpu_ratio_to_cat" in m and not m.get("refused")
                   else "")
            lines.append(f"| {name} | {n} | {rate} | {ratio} | {steady} | {cpu} | "
                         f"{m['peak_mb']:.0f} MB |")
    memory = _memory_growth(res)
    if memory:
        lines += ["", "Peak memory at the most revolutions / at the fewest: " + ", ".join(
            f"{k} {v:.2f}x" for k, v in memory.items())]
    s = res["startup"]
    lines += ["", "| start-up | seconds |", "|---|---:|"]
    lines += [f"| {k} | {v:.3f} |" for k, v in s.items()]
    lines += _startup_table(res) + _report_table(res) + _make_rom_table(res) + _fit_rbf_table(res)
    return "\n".join(lines)


def _ratio(x: float | None) -> str:
    return "" if x is None else f"{x:.2f}"


def _same(x: bool | None) -> str:
    return "" if x is None else "identical" if x else "DIFFERENT"


def _report_table(res: dict) -> list[str]:
    rows = res.get("report") or {}
    if not rows:
        return []
    lines = ["", ("| `enc report`, seed 000 campaign (6 inputs) | seconds | CPU seconds "
                  "| before: CPU seconds | before / after (CPU) | stdout as before |"),
             "|---|---:|---:|---:|---:|---|"]
    for label, r in rows.items():
        lines.append(f"| {label} | {r['seconds']:.2f} | {r['cpu_seconds']:.2f} | "
                     f"{_ratio(r.get('before_cpu_seconds'))} | {_ratio(r.get('speed_up_cpu'))} | "
                     f"{_same(r.get('stdout_identical_to_before'))} |")
    return lines


def _startup_table(res: dict) -> list[str]:
    cmds = res.get("commands") or {}
    if not cmds:
        return []
    lines = ["", ("Start-up of every command; ratios of CPU seconds to references timed in turn "
                  "with it."), "",
             ("| command | `--help` [s] | vs `python -c pass` | vs `import click` "
              "| tiny run [s] | vs `import numpy, pyarrow` | before: vs `import numpy, pyarrow` "
              "| peak memory | tiny run |"),
             "|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for name, r in cmds.items():
        tiny = (f"{r['tiny_seconds']:.3f} | {r['tiny_vs_numpy_pyarrow']:.2f} | "
                f"{_ratio(r.get('tiny_before_vs_numpy_pyarrow'))} | "
                f"{r['tiny_peak_mb']:.0f} MB | `{r['tiny_run']}`") if "tiny_seconds" in r \
            else "| | | |"
        lines.append(f"| {name} | {r['help_seconds']:.3f} | {r['help_vs_pass']:.2f} | "
                     f"{r['help_vs_click']:.2f} | {tiny} |")
    return lines


def _make_rom_table(res: dict) -> list[str]:
    rows = res.get("make_rom") or []
    if not rows:
        return []
    lines = ["", ("| make-rom (RBF model, seed 001 table 1) | format | file | seconds | CPU s "
                  "| vs `dd` (CPU) | before: vs `dd` | peak memory | before: peak | file as "
                  "before |"),
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        lines.append(f"| 2^{r['bits']} entries | {r['format']} | {r['bytes'] / 1e6:.0f} MB | "
                     f"{r['seconds']:.2f} | {r['cpu_seconds']:.2f} | {_ratio(r.get('vs_dd'))} | "
                     f"{_ratio(r.get('before_vs_dd'))} | {r['peak_mb']:.0f} MB | "
                     f"{_mb(r.get('before_peak_mb'))} | {_same(r.get('identical_to_before'))} |")
    lines += ["", ("| the table's writer alone | format | `dd` CPU s | writer CPU s | vs `dd` "
                   "(CPU) | before: CPU s | before: vs `dd` | `--verify` CPU s | before: "
                   "`--verify` | file as before |"),
              "|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        lines.append(f"| 2^{r['bits']} entries | {r['format']} | {r['dd_cpu_seconds']:.3f} | "
                     f"{r['writer_cpu_seconds']:.3f} | {_ratio(r.get('writer_vs_dd'))} | "
                     f"{_secs(r.get('writer_before_cpu_seconds'))} | "
                     f"{_ratio(r.get('writer_before_vs_dd'))} | "
                     f"{_secs(r.get('verify_cpu_seconds'))} | "
                     f"{_secs(r.get('verify_before_cpu_seconds'))} | "
                     f"{_same(r.get('writer_identical_to_before'))} |")
    return lines


def _mb(x: float | None) -> str:
    return "" if x is None else f"{x:.0f} MB"


def _secs(x: float | None) -> str:
    return "" if x is None else f"{x:.3f}"


def _memory_growth(res: dict) -> dict[str, float]:
    runs = res["runs"]
    if len(runs) < 2:
        return {}
    first, last = runs[0], runs[-1]
    return {k: last[k]["peak_mb"] / first[k]["peak_mb"] for k, v in first.items()
            if isinstance(v, dict) and "peak_mb" in v and k in last and v["peak_mb"] > 0}


if __name__ == "__main__":
    if not shutil.which("bash"):
        sys.exit("bench: needs bash")
    main()
