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
"""

from __future__ import annotations

import resource
import sys

import numpy as np
import pyarrow.compute
import pyarrow.csv  # noqa: F401  (imported before the clock starts)

from enctools.models import romformats


def cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main() -> None:
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


if __name__ == "__main__":
    main()
