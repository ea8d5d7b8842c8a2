#!/usr/bin/env python3
"""Coverage-guided fuzzing (atheris) of rig files: ``load_rig`` on arbitrary bytes.

Run by ``make fuzz``. A rig file is data received from elsewhere: every input must load
or raise a one-line SettingsError/DataError; anything else (a crash, RecursionError,
MemoryError, an exception of another type, a multi-line message) is a finding, written
to ``fuzz-out/crash-*``. Once understood, a finding becomes a row of the adversarial
catalogue (tests/adversarial/cases/rigs.toml), ``pending`` until fixed.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import atheris

with atheris.instrument_imports():
    from enctools.data.rig import load_rig
    from enctools.errors import DataError, SettingsError

FOLDER = Path(tempfile.mkdtemp(prefix="fuzz-rigs-"))
RIG = FOLDER / "rig.toml"


def one_input(data: bytes) -> None:
    RIG.write_bytes(data)
    try:
        load_rig(str(RIG))
    except (DataError, SettingsError) as exc:
        if "\n" in str(exc):
            raise AssertionError(f"multi-line error: {exc!r}") from None


def seeds(folder: Path) -> None:
    """The bundled rigs and the pyvisa-sim rig as the starting corpus."""
    root = Path(__file__).resolve().parent.parent
    folder.mkdir(parents=True, exist_ok=True)
    for p in [*sorted((root / "enctools" / "rigs").glob("*.toml")),
              root / "tests" / "rigs" / "visa-sim.toml"]:
        (folder / p.name).write_bytes(p.read_bytes())


if __name__ == "__main__":
    corpus = Path(sys.argv[1]) if len(sys.argv) > 1 and not sys.argv[1].startswith("-") else None
    if corpus is not None:
        seeds(corpus)
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 1000))
    os.chdir(FOLDER)
    atheris.Setup(sys.argv, one_input)
    atheris.Fuzz()
