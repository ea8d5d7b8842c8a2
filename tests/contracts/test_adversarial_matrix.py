"""The adversarial catalogue's matrices (tests/adversarial/cases/*-matrix.toml): every
reader against every broken input, every writer against every output it must refuse.
Run as the rows of test_adversarial.py are (its ``base`` fixture and ``run_case``)."""

from __future__ import annotations

from pathlib import Path

import pytest
from adversarial import catalogue
from test_adversarial import CASES, _param, base, run_case  # noqa: F401  (base: a fixture)

MATRIX = [c for c in CASES if c.matrix]


@pytest.mark.parametrize("case", [_param(c) for c in MATRIX])
def test_matrix_case(case: catalogue.Case, base: Path, tmp_path: Path,  # noqa: F811
                     record_property) -> None:
    run_case(case, base, tmp_path, record_property)
