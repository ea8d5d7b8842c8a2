"""A command template's format spec declares no width or precision beyond the bound."""

from __future__ import annotations

import pytest

from enctools.data.riglimits import MAX_TEMPLATE_WIDTH
from enctools.errors import DataError
from enctools.hw.config import check_template, spec_size


class _Rig:
    source = "rig.toml"


@pytest.mark.parametrize(("spec", "size"), [
    ("", 0), (".4f", 4), (">12.6f", 12), ("0>20", 20), ("+08.3f", 8), ("_>9,d", 9),
    (">1500000000", 1_500_000_000), ("." + "9" * 30 + "f", 10**18), ("x<64", 64),
])
def test_spec_size(spec: str, size: int) -> None:
    assert spec_size(spec) == size


@pytest.mark.parametrize("tpl", ["MOVE {deg:>65}", "MOVE {deg:.65f}", "MOVE {deg:>1500000000}"])
def test_a_wide_field_is_refused_naming_key_and_field(tpl: str) -> None:
    with pytest.raises(DataError) as err:
        check_template(tpl, {"deg": 1.0}, _Rig(), "motion.backend.move")  # type: ignore[arg-type]
    text = str(err.value)
    assert "motion.backend.move" in text and "{deg:" in text
    assert f"more than {MAX_TEMPLATE_WIDTH}" in text
    assert "\n" not in text


def test_the_bound_itself_is_taken() -> None:
    check_template("MOVE {deg:>64.60f}", {"deg": 1.0}, _Rig(), "motion.backend.move")  # type: ignore[arg-type]
