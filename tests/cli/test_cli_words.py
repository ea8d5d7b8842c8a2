"""The command line's words stay in cli/: the library names settings by their fields.

Below ``enctools/cli`` no string (docstrings included) names a ``--flag`` and nothing
raises or names ``UsageError``; a :class:`SettingsError` names fields, which the command
line shows as its options (``cli/usage.py``). Options renamed keep their old spelling for
one release with a warning; options of one mode are refused in another.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from enctools.cli import options, usage
from enctools.errors import SettingsError

ROOT = Path(__file__).resolve().parents[2] / "enctools"
LAYERS = ("core", "data", "methods", "models", "hw", "report")
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9]*(?:-[a-z0-9]+)*")


def _files(layer: str) -> list[Path]:
    if layer == "core":
        return sorted(p for p in ROOT.glob("*.py"))
    return sorted((ROOT / layer).rglob("*.py"))


def flag_strings(layer: str) -> list[str]:
    """Each string constant of ``layer`` that names a --flag, as FILE:LINE: text."""
    found = []
    for path in _files(layer):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and FLAG.search(node.value):
                where = path.relative_to(ROOT.parent)
                found.append(f"{where}:{node.lineno}: {FLAG.search(node.value)[0]}")
    return found


def usage_errors(layer: str) -> list[str]:
    """Each line of ``layer`` that names UsageError (defined in ``cli/usage.py``)."""
    found = []
    for path in _files(layer):
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if "UsageError" in line:
                found.append(f"{path.relative_to(ROOT.parent)}:{n}: {line.strip()}")
    return found


@pytest.mark.heavy
@pytest.mark.parametrize("layer", LAYERS)
def test_no_flag_text_below_cli(layer: str) -> None:
    found = flag_strings(layer)
    assert not found, \
        f"{len(found)} strings name a --flag below cli/:\n" + "\n".join(found)


@pytest.mark.parametrize("layer", LAYERS)
def test_no_usage_error_below_cli(layer: str) -> None:
    found = usage_errors(layer)
    assert not found, \
        f"{len(found)} lines name UsageError below cli/:\n" + "\n".join(found)


@click.command("demo", cls=usage.ModeCommand,
               modes={"Step runs": ("dwell",), "Continuous runs": ("speed",)},
               mode_of=lambda p: {"steps": "Step runs", "continuous": "Continuous runs"}[p["mode"]])
@click.option("--mode", type=click.Choice(["steps", "continuous"]), default="steps")
@click.option("--dwell", type=float, default=None)
@click.option("--speed", type=float, default=None)
@click.option("--max-band", "band", type=int, default=3)
@click.option("--head", "ref_head", default=None)
@options.verbosity
def _demo(mode: str, dwell: float | None, speed: float | None, band: int,
          ref_head: str | None) -> None:
    if band < 0:
        raise SettingsError(f"`band` must be >= 0, not {band}; `ref_head` {ref_head}")
    click.echo(f"{mode} {dwell} {speed} {band} {ref_head}")


demo = usage.renamed({"--ref": "--head"})(_demo)


def test_settings_error_names_fields_in_the_library_and_options_on_the_command_line() -> None:
    exc = SettingsError("`band` must be >= 0, not -1; `ref_head` H1")
    assert str(exc) == "band must be >= 0, not -1; ref_head H1"
    assert exc.fields == ("band", "ref_head")
    assert usage.message(exc, demo, "demo") == "--max-band must be >= 0, not -1; --head H1"
    usage.FIELD_FLAGS["demo"] = {"ref_head": "--head (or the rig's first)"}
    try:
        assert usage.message(exc, demo, "demo").endswith("--head (or the rig's first) H1")
    finally:
        del usage.FIELD_FLAGS["demo"]
    assert usage.message(exc, None) == str(exc)


def test_an_old_spelling_still_works_for_one_release_with_a_warning() -> None:
    result = CliRunner().invoke(demo, ["--ref", "H2"])
    assert result.exit_code == 0, result.output
    assert result.stdout.strip() == "steps None None 3 H2"
    assert usage.RENAMED[("demo", "--ref")] == "--head"
    warning = [line for line in result.stderr.splitlines() if "--ref is now spelt" in line]
    assert len(warning) == 1 and warning[0].endswith(
        ": WARNING: --ref is now spelt --head; --ref will not be accepted after this release")
    quiet = CliRunner().invoke(demo, ["--ref", "H2", "-q"])
    assert quiet.exit_code == 0 and "spelt" not in quiet.stderr
    both = CliRunner().invoke(demo, ["--ref", "H2", "--head", "H3"])
    assert both.exit_code != 0 and "old spelling of --head" in str(both.exception)
    assert "--ref" not in CliRunner().invoke(demo, ["--help"]).output


def test_options_of_one_mode_are_shown_under_it_and_refused_in_another() -> None:
    help_text = CliRunner().invoke(demo, ["--help"]).output
    assert help_text.index("Step runs:") < help_text.index("--dwell") \
        < help_text.index("Continuous runs:") < help_text.index("--speed")
    ok = CliRunner().invoke(demo, ["--mode", "continuous", "--speed", "2"])
    assert ok.exit_code == 0 and ok.stdout.strip() == "continuous None 2.0 3 None"
    wrong = CliRunner().invoke(demo, ["--mode", "continuous", "--dwell", "2"])
    assert wrong.exit_code != 0
    assert str(wrong.exception) == "--dwell applies to Step runs, not to Continuous runs"
