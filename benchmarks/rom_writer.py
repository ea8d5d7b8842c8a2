#!/usr/bin/env python3
"""The CPU seconds of writing one correction table, and nothing else, for bench.py.

Reads a binary table (``enc make-rom --target bin``: little-endian 16-bit words), writes it
in FORMAT through ``enctools.models.romformats.write_table`` (of whichever enctools is first
on the path: this tree's, or the before code's by PYTHONPATH) and prints the CPU seconds
(user + system) of that call alone: the formatting and the write, not the start-up, the
model or the reading of the image. With ``--verify``, the seconds of reading the table
back and comparing it (``verify_table``) on a second line. The libraries either code may
import on the way (pyarrow's CSV and compute modules) are imported first, so that neither
figure holds an import.

Usage: rom_writer.py IMAGE FORMAT OUTPUT [--verify]

``rom_writer.py command [--out DIR] [--bits 20,24,26] [--formats bin,mif,csv]
[--before REV] [--repeat N]`` measures the whole ``enc make-rom`` command instead: at each
size and format, this tree's and the ``before`` code's (main by default) run in turn with
``dd`` writing the file's bytes into the same folder (the best of ``repeat`` turns, wall
and CPU seconds; ratios to dd's), and the peak resident memory [MB] of make-rom, of
make-rom ``--verify`` and of ``enc correct --table`` on the table, for both codes. Every
command runs with its bytecode cached (PYTHONPYCACHEPREFIX under DIR), as bench.py's do.
Prints a Markdown table and each format's peak at the most entries over that at the
fewest; writes DIR/rom-command.json.
"""

from __future__ import annotations

import os
import resource
import sys
from typing import Any


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
    if sys.argv[1:2] == ["command"]:
        command(sys.argv[2:])
        return
    import numpy as np
    import pyarrow.compute
    import pyarrow.csv  # noqa: F401  (imported before the clock starts)

    from enctools.models import romformats

    image, fmt, output = sys.argv[1:4]
    values = np.fromfile(image, dtype="<i2").astype(np.int16)
    target = romformats.Target(fmt, 16)
    comment = ["enctools make-rom: a table written by benchmarks/rom_writer.py"]
    t0 = cpu()
    romformats.write_table(output, values, target, force=True, comment=comment)
    print(f"{cpu() - t0:.6f}")
    if "--verify" in sys.argv[4:]:
        t0 = cpu()
        romformats.verify_table(output, values, target)
        print(f"{cpu() - t0:.6f}")


#: extensions of the formats measured by ``command``
EXT = {"bin": "bin", "mif": "mif", "csv": "csv", "coe": "coe", "mem": "mem", "ihex": "hex"}


def command(argv: list[str]) -> None:
    """The whole make-rom command against dd, and the peaks of make-rom, --verify, correct."""
    import argparse
    import json
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench

    ap = argparse.ArgumentParser(prog="rom_writer.py command")
    ap.add_argument("--out", default=str(bench.ROOT / "bench-out"))
    ap.add_argument("--bits", default="20,24,26")
    ap.add_argument("--formats", default="bin,mif,csv")
    ap.add_argument("--before", default="main")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    out = Path(args.out)
    # bytecode cached, as an installed enctools has it and as bench.py runs every command
    # (with PYTHONDONTWRITEBYTECODE=1 every run would compile enctools again: some 0.1 s)
    bytecode_env = os.environ.pop("PYTHONDONTWRITEBYTECODE", None)
    load0 = os.getloadavg()[0]
    os.environ.setdefault("PYTHONPYCACHEPREFIX", str(out.resolve() / "pycache"))
    d = out / "rom-command"
    d.mkdir(parents=True, exist_ok=True)
    before = bench.before_tree(args.before, out) if args.before else None
    table1 = bench.ROOT / "tests" / "data" / "seed001_table1.csv"
    bench.timed(f"{bench.ENC} fit-rbf {table1} -q -o {d}/model.arrows --force")
    rows = [_command_row(d, int(bits), fmt, args.repeat, before)
            for bits in args.bits.split(",") for fmt in args.formats.split(",")]
    (out / "rom-command.json").write_text(json.dumps(
        {"before": None if before is None else {k: before[k] for k in ("rev", "commit")},
         "load": os.getloadavg(), "rows": rows}, indent=2))
    print(_markdown(rows, before))
    print(f"Load {load0:.1f} at the start. Bytecode cached (PYTHONPYCACHEPREFIX); the caller "
          f"had PYTHONDONTWRITEBYTECODE={bytecode_env or '(unset)'}.")


def _command_row(d: Any, bits: int, fmt: str, repeat: int, before: dict | None) -> dict:
    """One size and format: make-rom after and before, dd, in turn; the three peaks."""
    import bench

    target, kept, dd_out = d / f"table.{EXT[fmt]}", d / f"before.{EXT[fmt]}", d / "dd.out"
    allow = " --allow-no-gain --allow-coarse --force"  # --force: a CSV's sidecar is left
    run = f"{bench.ENC} make-rom {d}/model.arrows --bits {bits} -q{allow} -o "
    peak = bench.timed(f"{bench.gnu_time()} {run}{target}")["peak_mb"]
    size = target.stat().st_size
    dd = f"dd if=/dev/zero of={dd_out} bs=1M count={size} iflag=count_bytes status=none"
    shells = {"after": run + str(target), "dd": dd}
    if before is not None:
        shells["before"] = bench.with_env(before, run + str(kept))
    t = bench.fresh_cpu(shells, {"after": target, "before": kept, "dd": dd_out}, repeat,
                        times={"dd": 3})
    row = {"bits": bits, "format": fmt, "bytes": size, "dd_seconds": t["dd"][0],
           "dd_cpu_seconds": t["dd"][1], "seconds": t["after"][0],
           "cpu_seconds": t["after"][1], "vs_dd_wall": t["after"][0] / t["dd"][0],
           "vs_dd_cpu": t["after"][1] / t["dd"][1], "peak_mb": peak}
    row |= _peaks(run, target, bits, d, None, "")
    if before is not None:
        row |= {"before_seconds": t["before"][0], "before_cpu_seconds": t["before"][1],
                "before_vs_dd_wall": t["before"][0] / t["dd"][0],
                "before_vs_dd_cpu": t["before"][1] / t["dd"][1]}
        row["before_peak_mb"] = bench.timed(bench.with_env(
            before, f"{bench.gnu_time()} {run}{kept}"))["peak_mb"]
        row |= _peaks(run, kept, bits, d, before, "before_")
        row["as_before"] = _same_table(target, kept)  # both left by their --verify run
    for f in (target, kept, dd_out):
        f.unlink(missing_ok=True)
    print(f"rom_writer: 2^{bits} {fmt} done", file=sys.stderr)
    return row


def _same_table(a: Any, b: Any) -> bool:
    """Whether two table files hold the same bytes after their leading comment lines
    (MIF's ``--``: the history names the file and the time), read 1 MiB at a time."""
    with open(a, "rb") as fa, open(b, "rb") as fb:
        for f in (fa, fb):
            while f.peek(2)[:2] == b"--":
                f.readline()
        while True:
            x, y = fa.read(1 << 20), fb.read(1 << 20)
            if x != y:
                return False
            if not x:
                return True


def _peaks(run: str, table: Any, bits: int, d: Any, env: dict | None, key: str) -> dict:
    """The peak [MB] of make-rom --verify and of enc correct --table on its table."""
    import bench

    def peak(shell: str) -> float:
        return float(bench.timed(bench.with_env(env, f"{bench.gnu_time()} {shell}"))["peak_mb"])

    points = d / "points.arrows"
    if not points.exists():
        bench.timed(f"{bench.ENC} points {bench.ROOT}/tests/data/seed001_table1.csv -q -o {points}")
    return {f"{key}verify_peak_mb": peak(f"{run}{table} --verify"),
            f"{key}correct_peak_mb": peak(f"{bench.ENC} correct {points} --table {table} "
                                          f"--bits {bits} -q")}


def _markdown(rows: list[dict], before: dict | None) -> str:
    """The rows as a Markdown table: CPU and wall ratios to dd, peaks, after (before)."""
    def pair(r: dict, k: str, fmt: str) -> str:
        b = r.get(f"before_{k}")
        return format(r[k], fmt) + ("" if b is None else f" ({format(b, fmt)})")

    head = ("| entries | format | MB written | make-rom CPU s | make-rom / dd, CPU | "
            "make-rom / dd, wall | "
            "peak MB | --verify peak MB | correct peak MB | file as before |\n"
            "|---|---|---|---|---|---|---|---|---|---|")
    lines = [head] + [
        f"| 2^{r['bits']} | {r['format']} | {r['bytes'] / 1e6:.0f} "
        f"| {pair(r, 'cpu_seconds', '.2f')} | {pair(r, 'vs_dd_cpu', '.2f')} "
        f"| {pair(r, 'vs_dd_wall', '.2f')} | {pair(r, 'peak_mb', '.0f')} | "
        f"{pair(r, 'verify_peak_mb', '.0f')} | {pair(r, 'correct_peak_mb', '.0f')} | "
        f"{_as_before(r)} |"
        for r in rows]
    then = "" if before is None else \
        f" (in brackets: the code of {before['rev']}, {before['commit']})"
    return "\n".join(lines) + "\n\n" + _flatness(rows) + \
        f"\n\nThis tree{then}; load {os.getloadavg()[0]:.1f}."


def _as_before(row: dict) -> str:
    """The file against the before code's: identical, DIFFERENT or blank (no before)."""
    if "as_before" not in row:
        return ""
    return "identical" if row["as_before"] else "DIFFERENT"


def _flatness(rows: list[dict]) -> str:
    """Each format's peak memory at the most entries over that at the fewest (make-rom and
    make-rom --verify; in brackets the before code's)."""
    def ratio(a: dict, b: dict, k: str) -> str:
        out = f"{b[k]:.0f}/{a[k]:.0f} MB = {b[k] / a[k]:.2f}x"
        if f"before_{k}" in a:
            out += f" ({b['before_' + k] / a['before_' + k]:.2f}x)"
        return out

    lo, hi = min(r["bits"] for r in rows), max(r["bits"] for r in rows)
    parts = []
    for fmt in dict.fromkeys(r["format"] for r in rows):
        a, b = (next(r for r in rows if r["format"] == fmt and r["bits"] == bits)
                for bits in (lo, hi))
        parts.append(f"{fmt} {ratio(a, b, 'peak_mb')}, --verify {ratio(a, b, 'verify_peak_mb')}")
    return f"Peak memory at 2^{hi} / at 2^{lo} entries: " + "; ".join(parts)


if __name__ == "__main__":
    main()
