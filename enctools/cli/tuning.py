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
- pandas kept out while a command runs (:func:`without_pandas`, used by the ``enc``
  driver): pyarrow asks whether every array it builds from numpy is a pandas object,
  and to answer it imports pandas when pandas is installed, which costs more CPU than
  importing numpy and pyarrow together. enctools never hands pyarrow a pandas object.
- The cyclic garbage collector run less often (:func:`collect_less`, used by
  ``enc report``): a report imports matplotlib, fpdf2 and fontTools and builds a
  hundred thousand small objects (artists, table cells, glyphs); at Python's default
  of a young collection every 700 new objects, three full collections walked the
  whole heap: a tenth of the campaign report's CPU.
"""

from __future__ import annotations

import gc
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager

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


class _NoPandas:
    """An import finder that refuses pandas (:func:`without_pandas`)."""

    @staticmethod
    def find_spec(name: str, path: object = None, target: object = None) -> None:
        if name == "pandas":
            msg = "pandas is not imported while an enc command runs"
            raise ModuleNotFoundError(msg, name=name)


@contextmanager
def without_pandas() -> Iterator[None]:
    """Make ``import pandas`` fail (ImportError) inside the block, unless pandas is
    already imported; afterwards it imports as usual. pyarrow then takes pandas as
    absent when it checks what it is given, and imports it again when a pandas
    conversion (``to_pandas``) is asked for."""
    if "pandas" in sys.modules:
        yield
        return
    finder = _NoPandas()
    sys.meta_path.insert(0, finder)
    try:
        yield
    finally:
        sys.meta_path.remove(finder)


#: how many new container objects between two collections of the youngest generation
#: in :func:`collect_less` (Python's default: 700)
YOUNG_OBJECTS = 5000


@contextmanager
def collect_less(young: int = YOUNG_OBJECTS) -> Iterator[None]:
    """Collect the youngest generation every ``young`` new objects inside the block
    (the older generations keep their ratios to it), then as before. Cyclic garbage
    lives a little longer (a few MB at 5000); nothing is left uncollected."""
    before = gc.get_threshold()
    gc.set_threshold(young, *before[1:])
    try:
        yield
    finally:
        gc.set_threshold(*before)
