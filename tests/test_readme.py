"""The README's pipelines and make demo's campaigns run as written, without a warning.

Each section's ``sh`` blocks are read from README.md, so the test follows the README,
and run by bash (``set -e -o pipefail``) in a fresh folder with this environment's enc
on PATH; the campaign Makefiles are those the top Makefile's ``demo`` target runs. stderr
may carry a command's summary lines, never a warning: the rigs' defaults are chosen so
that the documented commands meet none (the sjtu-dual rig samples every 5.05 ms, clear
of every head's signal period; the paper's 3 ms is warned about only when the drive
turns at exactly its nominal speed: test_compare.py).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from conftest import ROOT, enc_exe, run

README = ROOT / "README.md"
#: the README's sections whose commands a newcomer runs in turn, each in a fresh folder
SECTIONS = ("A first pipeline", "A calibration campaign, step by step (seed 000)",
            "Polygon, RBF model and correction ROM (seed 001)",
            "The polygon's own errors: its certificate, or closure")
WARNING = re.compile(r"warn", re.IGNORECASE)


def section_script(title: str) -> str:
    """The ``sh`` blocks of the README's section ``title``, in order, as one script."""
    text = README.read_text()
    section = re.search(rf"^## {re.escape(title)}\n(.*?)(?=^## |\Z)", text, re.M | re.S)
    assert section, f"README.md has no section {title!r}"
    blocks = re.findall(r"^```sh\n(.*?)^```", section.group(1), re.M | re.S)
    assert blocks and all("enc " in b for b in blocks), title
    return "\n".join(blocks)


def demo_campaigns() -> list[str]:
    """The campaign Makefiles that ``make demo`` runs, from the top Makefile's recipe."""
    text = (ROOT / "Makefile").read_text()
    recipe = re.search(r"^demo:.*\n((?:\t.*\n)+)", text, re.M)
    assert recipe, "the Makefile has no demo target"
    found = re.findall(r"-f (examples/\S+\.mk)", recipe.group(1))
    assert found, "make demo runs no campaign"
    return found


def warnings_in(stderr: bytes) -> list[str]:
    return [line for line in stderr.decode().splitlines() if WARNING.search(line)]


def test_the_sections_and_campaigns_are_found():
    """Renaming a section or a campaign must fail here, not silently test nothing."""
    for title in SECTIONS:
        assert "enc acquire" in section_script(title)
    assert "enc acquire --rig sjtu-dual -o" in section_script(SECTIONS[0])
    assert demo_campaigns() == ["examples/sjtu-dual.mk", "examples/ciomp-23bit.mk"]


@pytest.mark.slow
@pytest.mark.parametrize("title", SECTIONS)
def test_readme_section_runs_without_a_warning(title: str, tmp_path: Path) -> None:
    script = tmp_path / "readme.sh"
    script.write_text("set -e -o pipefail\n" + section_script(title))
    r = run(f"bash {script}", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    assert warnings_in(r.stderr) == [], r.stderr.decode()


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
@pytest.mark.parametrize("campaign", demo_campaigns())
def test_demo_campaign_runs_without_a_warning(campaign: str, tmp_path: Path) -> None:
    r = run(["make", "--no-print-directory", "-f", str(ROOT / campaign), f"ENC={enc_exe()}",
             f"OUT={tmp_path / 'out'}"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    assert warnings_in(r.stderr) == [], r.stderr.decode()
