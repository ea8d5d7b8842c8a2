#!/usr/bin/env python3
"""The slowest tests of a run, as the README's development section shows them.

Reads the JSON lines ``tests/conftest.py`` appends to ``ENCTOOLS_TEST_TIMES`` (a test a
line: node id, tier, wall seconds, CPU seconds of the test's process and of the commands
it waited for, the load average at its end) and prints a Markdown table of the TOP tests
by wall time, then each tier's totals.

Usage: slowest_tests.py FILE [--top 25]
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict


def read(path: str) -> list[dict]:
    """The run's tests, the first line of a node id kept (CI's make test-min, after make
    test and make test-slow, runs every test again on the oldest versions)."""
    rows: dict[str, dict] = {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.strip():
                row = json.loads(line)
                rows.setdefault(row["test"], row)
    return list(rows.values())


def table(rows: list[dict], top: int) -> list[str]:
    """The TOP tests by wall time: wall and CPU seconds (the test's and its commands'), tier."""
    lines = ["| wall s | CPU s | of which commands | tier | test |", "|---:|---:|---:|---|---|"]
    for r in sorted(rows, key=lambda r: -r["wall_s"])[:top]:
        cpu = r["cpu_s"] + r["children_cpu_s"]
        test = r["test"].removeprefix("tests/").split("@")[0]  # xdist's group suffix
        lines.append(f"| {r['wall_s']:.1f} | {cpu:.1f} | {r['children_cpu_s']:.1f} | "
                     f"{r['tier']} | `{test}` |")
    return lines


def totals(rows: list[dict]) -> list[str]:
    """Each tier's count, wall and CPU seconds, and the load averages its tests ended at."""
    by: dict[str, list[dict]] = defaultdict(list)
    for r in rows:
        by[r["tier"]].append(r)
    out = []
    for tier in sorted(by):
        rs = by[tier]
        loads = sorted(r["load"] for r in rs)
        out.append(f"{tier}: {len(rs)} tests, {sum(r['wall_s'] for r in rs):.0f} s of wall "
                   f"(summed over the workers), "
                   f"{sum(r['cpu_s'] + r['children_cpu_s'] for r in rs):.0f} s of CPU "
                   f"({sum(r['children_cpu_s'] for r in rs):.0f} s in commands); load average "
                   f"{loads[0]:.1f} to {loads[-1]:.1f} (median {loads[len(loads) // 2]:.1f})")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file")
    ap.add_argument("--top", type=int, default=25)
    args = ap.parse_args()
    rows = read(args.file)
    print("\n".join(table(rows, args.top)))
    print()
    print("\n".join(totals(rows)))


if __name__ == "__main__":
    main()
