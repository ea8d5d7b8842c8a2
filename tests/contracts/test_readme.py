"""The README's pipelines and make demo's campaigns run as written, without a warning.

Each section's ``sh`` blocks are read from README.md, so the test follows the README,
and run by bash (``set -e -o pipefail``) in a fresh folder that holds the repository's
tests/ and examples/, with this environment's enc on PATH; then each command of its
``console`` blocks, whose output must hold every line the README shows. The campaign
Makefiles are those the top Makefile's ``demo`` target runs. stderr
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
            "The polygon's own errors: its certificate, or closure", "Your own table")
#: sections with commands that this test does not run, and why
SKIPPED = {"Set-up: two commands": "make demo and make test are the set-up itself (CI runs "
           "both); the PATH, man and completion lines configure a login shell",
           "Same inputs, same bytes": "make demo twice takes minutes; "
           "test_reproducible_folders.py runs one campaign into two folders and compares"}
WARNING = re.compile(r"warn", re.IGNORECASE)


def sections() -> dict[str, str]:
    """The README's ``## `` sections by title (their ``###`` subsections included)."""
    text = README.read_text()
    return {m.group(1): m.group(2)
            for m in re.finditer(r"^## ([^\n]+)\n(.*?)(?=^## |\Z)", text, re.M | re.S)}


def blocks(title: str, kind: str) -> list[str]:
    """The ``kind`` (sh, console) blocks of the README's section ``title``, in order."""
    body = sections().get(title)
    assert body is not None, f"README.md has no section {title!r}"
    return re.findall(rf"^```{kind}\n(.*?)^```", body, re.M | re.S)


def section_script(title: str) -> str:
    """The ``sh`` blocks of the README's section ``title``, in order, as one script."""
    found = blocks(title, "sh")
    assert all("enc " in b for b in found), title
    return "\n".join(found)


def console(title: str) -> list[tuple[str, list[str]]]:
    """The commands of the section's ``console`` blocks (``$ `` lines, continued by a
    trailing backslash) with the lines shown as their output."""
    shown: list[tuple[str, list[str]]] = []
    for block in blocks(title, "console"):
        lines = block.splitlines()
        i = 0
        while i < len(lines):
            assert lines[i].startswith("$ "), f"{title}: output before a command: {lines[i]}"
            cmd = lines[i][2:]
            while cmd.endswith("\\"):
                i += 1
                cmd = cmd[:-1] + lines[i]
            i += 1
            out = []
            while i < len(lines) and not lines[i].startswith("$ "):
                out.append(lines[i])
                i += 1
            shown.append((cmd, out))
    return shown


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


@pytest.mark.heavy
def test_the_sections_and_campaigns_are_found():
    """Renaming a section or a campaign must fail here, not silently test nothing; a new
    section with commands must be run or listed as skipped."""
    for title in SECTIONS[:4]:
        assert "enc acquire" in section_script(title)
    assert "enc acquire --rig sjtu-dual -o" in section_script(SECTIONS[0])
    assert console(SECTIONS[2]) and console(SECTIONS[4])
    with_commands = {t for t in sections() if blocks(t, "sh") or blocks(t, "console")}
    assert with_commands == set(SECTIONS) | set(SKIPPED)
    assert demo_campaigns() == ["examples/sjtu-dual.mk", "examples/ciomp-23bit.mk"]


def _stage(folder: Path) -> None:
    """A fresh folder as a reader has it: the repository's tests/ and examples/."""
    (folder / "tests").symlink_to(ROOT / "tests")
    shutil.copytree(ROOT / "examples", folder / "examples")


@pytest.mark.slow
@pytest.mark.parametrize("title", SECTIONS)
def test_readme_section_runs_without_a_warning(title: str, tmp_path: Path) -> None:
    """The section's sh blocks, then each console command, whose output holds every line
    the README shows for it (the figures to the digits shown)."""
    _stage(tmp_path)
    script = tmp_path / "readme.sh"
    script.write_text("set -e -o pipefail\n" + section_script(title))
    r = run(f"bash {script}", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    assert warnings_in(r.stderr) == [], r.stderr.decode()
    for cmd, shown in console(title):
        if "| jq" in cmd and shutil.which("jq") is None:
            continue
        r = run(f"set -e -o pipefail\n{cmd}", cwd=tmp_path)
        printed = (r.stdout + r.stderr).decode().splitlines()
        assert r.returncode == 0, f"$ {cmd}\n{r.stderr.decode()}"
        missing = [line for line in shown if line not in printed]
        assert not missing, f"$ {cmd}\nshown, not printed: {missing}\nprinted: {printed}"


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
@pytest.mark.parametrize("campaign", demo_campaigns())
def test_demo_campaign_runs_without_a_warning(campaign: str, tmp_path: Path) -> None:
    r = run(["make", "--no-print-directory", "-f", str(ROOT / campaign), f"ENC={enc_exe()}",
             f"OUT={tmp_path / 'out'}"], cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    assert warnings_in(r.stderr) == [], r.stderr.decode()
