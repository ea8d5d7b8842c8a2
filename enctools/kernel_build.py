"""How the optional compiled kernel is built: one C compiler call, run by the package's build.

``hatch_build.py`` (the build hook of ``pip install``) loads this file by its path, without
importing enctools, and calls :func:`build`; ``benchmarks/bench.py`` times the same call.
A failure (no compiler, no C library headers) is not an error of the install: enctools
then runs its numpy passes (:mod:`enctools.kernel`).
"""

from __future__ import annotations

import os
import shlex
import subprocess
import time
from pathlib import Path

#: the kernel's source, beside this file
SOURCE = Path(__file__).with_name("_kernel.c")
#: the flags: optimised, position independent, no fused multiply-add (the same doubles as
#: numpy's for an angle and a deviation), and no CPU-specific instructions (a wheel runs on
#: another machine of its platform; the one loop built for AVX2 and AVX-512 as well, a
#: revolution's moments, is chosen at load by the CPU: _kernel.c, MOMENT_CLONES)
FLAGS = ["-O3", "-std=c99", "-fPIC", "-shared", "-ffp-contract=off", "-fno-math-errno"]


def compiler() -> list[str]:
    """The C compiler's command: ``$CC`` (split as a shell would) or ``cc``."""
    return shlex.split(os.environ.get("CC", "") or "cc")


def build(source: Path, out: Path) -> tuple[bool, float, str]:
    """Compile ``source`` into the shared library ``out``: (built, seconds [s], the
    compiler's message when it failed)."""
    t0 = time.perf_counter()
    tmp = out.with_name(out.name + ".tmp")
    try:
        r = subprocess.run([*compiler(), *FLAGS, "-o", str(tmp), str(source)],
                           capture_output=True, text=True, check=False)
    except OSError as exc:                  # no compiler at all
        return False, time.perf_counter() - t0, str(exc)
    if r.returncode != 0:
        tmp.unlink(missing_ok=True)
        return False, time.perf_counter() - t0, (r.stderr or r.stdout).strip()
    os.replace(tmp, out)                    # whole or not at all
    return True, time.perf_counter() - t0, ""
