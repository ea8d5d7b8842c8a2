#!/usr/bin/env python3
"""Coverage-guided fuzzing (atheris) of format detection and the stream readers.

Run with ``make fuzz`` (FUZZ_SECONDS=300 by default). Every input must either read or
raise a one-line DataError; anything else is a finding. Findings are written to
``fuzz-out/crash-*``; once fixed, add them to tests/data/fuzz/ where
tests/lib/data/test_streams_property.py replays them on every ``make test``.
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import atheris

with atheris.instrument_imports():
    from enctools.data import streams
    from enctools.errors import DataError


def one_input(data: bytes) -> None:
    try:
        with streams.open_input(None, stdin=io.BytesIO(data)) as s:
            for _ in s.batches():
                pass
    except DataError as exc:
        if "\n" in str(exc):
            raise AssertionError(f"multi-line error: {exc!r}") from None


def seeds(folder: Path) -> None:
    """Write valid files of every format as the starting corpus."""
    import numpy as np
    import pyarrow as pa

    from enctools.data.schemas import make_field

    folder.mkdir(parents=True, exist_ok=True)
    schema = pa.schema([make_field("theta", pa.float64(), "rad"),
                        make_field("H", pa.float64(), "arcsec", "deviation")])
    table = pa.table([np.linspace(0, 6, 64), np.sin(np.linspace(0, 6, 64))], schema=schema)
    for ext in (".parquet", ".h5", ".arrow", ".arrows"):
        streams.write_table(str(folder / f"seed{ext}"), streams.Header("deviations", schema, {}),
                            table, force=True)


if __name__ == "__main__":
    corpus = Path(sys.argv[1]) if len(sys.argv) > 1 and not sys.argv[1].startswith("-") else None
    if corpus is not None:
        seeds(corpus)
    atheris.Setup(sys.argv, one_input)
    atheris.Fuzz()
