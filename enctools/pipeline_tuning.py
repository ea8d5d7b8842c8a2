"""Process settings for a streaming filter that shares a small machine with its pipeline.

- One BLAS thread unless the environment says otherwise (``OPENBLAS_NUM_THREADS``,
  ``OMP_NUM_THREADS``): a pipeline already keeps every core busy, and idle OpenBLAS
  threads spinning around small matrix products slow a filter severalfold. Must run
  before numpy is first imported.
- glibc's malloc told to keep freed memory (``mallopt``): a filter allocates the same
  few-megabyte arrays for every batch and revolution; by default glibc hands them back
  to the kernel and faults them in again, which costs a fifth of selfcal's time. Peak
  memory does not grow with the input (the arrays are reused); an explicit
  ``MALLOC_TRIM_THRESHOLD_`` or ``MALLOC_MMAP_THRESHOLD_`` in the environment wins.
"""

from __future__ import annotations

import os
import sys

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3


def tune_for_streaming() -> None:
    """Apply the settings above (idempotent; does nothing where they do not apply)."""
    if "OMP_NUM_THREADS" not in os.environ:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    if not sys.platform.startswith("linux") or any(
            k in os.environ for k in ("MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_THRESHOLD_")):
        return
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(_M_TRIM_THRESHOLD, 256 << 20)
        libc.mallopt(_M_MMAP_THRESHOLD, 64 << 20)
    except (OSError, AttributeError):  # not glibc
        pass
