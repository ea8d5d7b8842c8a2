"""enc report's options under the headings of what they apply to, and the report library
naming its settings by field (the command line shows them as its options)."""

from __future__ import annotations

import click
from click.testing import CliRunner
from conftest import DATA, run_in_process

from enctools.cli import usage


def test_report_help_groups_its_options_under_headings() -> None:
    from enctools.cli.report import MODES, command

    text = CliRunner().invoke(command, ["--help"]).output
    headings = [text.index(f"\n{h}:\n") for h in MODES]
    assert headings == sorted(headings) and text.index("Options:") < headings[0]
    for heading, names in MODES.items():
        start = text.index(f"\n{heading}:\n")
        end = min([i for i in headings if i > start] or [len(text)])
        for p in command.params:
            if p.name in names and isinstance(p, click.Option) and not p.hidden:
                assert text.index(f"  {p.opts[0]} ", start) < end, (heading, p.opts)
    assert "INPUT" not in text.split("Options:", 1)[1]   # the argument: in the usage line
    assert "--history-rig NAME" in text and "\n  --rig" not in text


def test_a_mode_command_lists_no_argument_among_its_options() -> None:
    @click.command("demo", cls=usage.ModeCommand, modes={"Step runs": ("dwell",)})
    @click.argument("inputs", nargs=-1, metavar="[INPUT...]")
    @click.option("--dwell", type=float, default=None)
    def demo(inputs: tuple[str, ...], dwell: float | None) -> None:
        """Demo."""

    text = CliRunner().invoke(demo, ["--help"]).output
    assert text.count("[INPUT...]") == 1 and text.index("Step runs:") < text.index("--dwell")


def test_threshold_lines_name_fields_in_the_library_and_options_in_the_command() -> None:
    from enctools.report.thresholds import exceeded, in_words, parse_pairs

    line = exceeded(5.46, 3.0, "p-p", "deviation in x", "max_pp")
    assert line == ["p-p of deviation in x is 5.46 arcsec > `max_pp` 3"]
    assert in_words(line, None) == ["p-p of deviation in x is 5.46 arcsec > max_pp 3"]
    harmonic = exceeded(0.7, 0.5, "harmonic 2", "d in x", "max_harmonic 2:")
    assert in_words(harmonic, lambda f: "--" + f.replace("_", "-")) == \
        ["harmonic 2 of d in x is 0.7 arcsec > --max-harmonic 2:0.5"]
    assert parse_pairs(("2:0.5",), "max_harmonic", int) == {2: 0.5}


def test_a_threshold_exceeded_names_the_option(tmp_path) -> None:
    r = run_in_process(["report", str(DATA / "seed001_table1.csv"), "--max-pp", "3",
                        "--max-harmonic", "1:0.01"])
    err = r.stderr.decode()
    assert r.returncode == 1, err
    assert "> --max-pp 3" in err and "> --max-harmonic 1:0.01" in err and "`" not in err
