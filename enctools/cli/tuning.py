"""Process settings for commands that share a small machine with their pipeline.

- One BLAS thread unless the environment says otherwise (``OPENBLAS_NUM_THREADS``,
  ``OMP_NUM_THREADS``), for every command (:func:`one_blas_thread`, called by the
  ``enc`` driver): a pipeline already keeps every core busy, the commands' matrix
  products are small, and idle OpenBLAS threads spinning around them slow a filter
  severalfold and add a third to the CPU cost of a short command. Must run before
  numpy is first imported.
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


def one_blas_thread() -> None:
    """One BLAS thread unless OMP_NUM_THREADS or OPENBLAS_NUM_THREADS is set."""
    if "OMP_NUM_THREADS" not in os.environ:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def tune_for_streaming() -> None:
    """Apply both settings above (idempotent; does nothing where they do not apply)."""
    one_blas_thread()
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
