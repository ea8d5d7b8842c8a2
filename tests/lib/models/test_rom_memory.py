"""enc make-rom's memory does not follow the table: the table built a block at a time
(:func:`~enctools.models.rom.scan_rom`), written, and read back and compared block by block
(``--verify``) hold as much at 2^22 entries as at 2^20, in one process, by tracemalloc's
peak of each library call (numpy's buffers are traced; no clock). Before the blocks were
made smaller than a 2^20-entry table, the scan's peak went from 29 to 54 MB between the two
sizes and a binary image's verification from 9 to 29 MB. The blocks are evaluated on
one thread here (on THREADS, as many at once: a peak that depends on their timing)."""

from __future__ import annotations

import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from enctools.models import rom, romformats
from enctools.models.fourier import FourierModel

#: a peak may differ by this between the sizes [byte] (allocator and thread timing)
SLACK = 2 << 20


def _model() -> FourierModel:
    """A smooth deviation [arcsec] of a few harmonics, as a fitted model's series."""
    n = np.arange(12)
    return FourierModel(n, 3.0 / (1.0 + n), 2.0 / (1.0 + n * n))


def _peak(call: Callable[[], Any]) -> tuple[Any, int]:
    """What ``call`` returns and the peak [byte] of what it allocated (tracemalloc)."""
    tracemalloc.start()
    try:
        got = call()
        return got, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _peaks(tmp_path: Path, bits: int, fmt: str) -> tuple[int, int, int]:
    spec = rom.RomSpec(bits)
    target = romformats.Target(fmt, 16)
    path = str(tmp_path / f"t{bits}.{fmt}")
    table, scan = _peak(lambda: rom.scan_rom(_model(), spec))
    _, write = _peak(lambda: romformats.write_table(path, table.values, target, True, ["t"]))
    _, verify = _peak(lambda: romformats.verify_table(path, table.values, target))
    Path(path).unlink()
    return scan, write, verify


@pytest.mark.heavy
@pytest.mark.parametrize("fmt", ["bin", "mif", "csv"])
def test_peak_memory_does_not_grow_with_the_table(tmp_path: Path, fmt: str,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    threads = rom.THREADS
    monkeypatch.setattr(rom, "THREADS", 1)  # one block evaluated at a time: no timing
    small = _peaks(tmp_path, 20, fmt)
    large = _peaks(tmp_path, 22, fmt)
    grew = [f"{what}: {a / 1e6:.1f} MB at 2^20, {b / 1e6:.1f} MB at 2^22"
            for what, a, b in zip(("scan", "write", "verify"), small, large, strict=True)
            if b > a + SLACK]
    assert not grew
    # on THREADS threads, as many blocks are evaluated at once, whatever the table's size
    monkeypatch.setattr(rom, "THREADS", threads)
    scan = _peaks(tmp_path, 22, fmt)[0]
    assert scan <= threads * small[0] + SLACK, f"{scan / 1e6:.1f} MB on {threads} threads"
