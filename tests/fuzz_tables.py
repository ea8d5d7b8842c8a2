#!/usr/bin/env python3
"""Coverage-guided fuzzing (atheris) of the text tables enctools reads: the points CSV
(``enc points``/``enc fit-rbf``: methods/points.py) and the correction-table readers of
every format (models/romformats: the fast and the general reader of each).

Run by ``make fuzz``. Every input must read or raise a one-line DataError (SettingsError
for what an option set); anything else is a finding, written to ``fuzz-out/crash-*``.
Once understood, a finding becomes a row of the adversarial catalogue, ``pending``
until fixed. The first byte of an input chooses the reader, the rest is the file.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import atheris

with atheris.instrument_imports():
    from enctools.data.usertables import read
    from enctools.errors import DataError, SettingsError
    from enctools.methods.points import points_from_table
    from enctools.models import romformats as rf
    from enctools.models.romformats.words import Target

FOLDER = Path(tempfile.mkdtemp(prefix="fuzz-tables-"))
CSV = FOLDER / "table.csv"
#: the readers under test: the points CSV, then each table format at two widths
READERS = ["points-csv"] + [f"{fmt}:{w}" for fmt in rf.FORMATS for w in (8, 16)]


def _read(which: str, body: bytes) -> None:
    if which == "points-csv":
        CSV.write_bytes(body)
        points_from_table(read(str(CSV)))
        return
    fmt, width = which.split(":")
    target = Target(fmt, int(width))
    path = FOLDER / f"table.{fmt}"
    path.write_bytes(body)
    rf.read_table(str(path), target)  # the fast reader, then the general one
    rf.READERS[fmt][1](body, target, str(path))  # the general reader on its own


def one_input(data: bytes) -> None:
    if not data:
        return
    which = READERS[data[0] % len(READERS)]
    try:
        _read(which, data[1:])
    except (DataError, SettingsError) as exc:
        if "\n" in str(exc):
            raise AssertionError(f"{which}: multi-line error: {exc!r}") from None


def seeds(folder: Path) -> None:
    """Tables of every format (and seed 001's CSV tables) as the starting corpus."""
    import numpy as np

    folder.mkdir(parents=True, exist_ok=True)
    data = Path(__file__).resolve().parent / "data"
    for p in sorted(data.glob("seed001_table*.csv")):
        (folder / p.name).write_bytes(bytes([0]) + p.read_bytes())
    values = np.array([0, 1, -1, 127, -128, 5, -7, 3], dtype=np.int64)
    for k, which in enumerate(READERS[1:], start=1):
        fmt, width = which.split(":")
        path = FOLDER / f"seed.{fmt}"
        rf.write_table(str(path), values, Target(fmt, int(width)), force=True)
        (folder / f"seed-{fmt}-{width}").write_bytes(bytes([k]) + path.read_bytes())


if __name__ == "__main__":
    corpus = Path(sys.argv[1]) if len(sys.argv) > 1 and not sys.argv[1].startswith("-") else None
    if corpus is not None:
        seeds(corpus)
    atheris.Setup(sys.argv, one_input)
    atheris.Fuzz()
