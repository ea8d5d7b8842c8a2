"""An option's name means one thing across the commands.

Every long option that two or more commands take is declared here with its one meaning,
and takes the same kind of value (a flag, a number, a word, a path; once or repeated)
in each of them: a name that means two things (``--table``: a flag printing TSV in one
command, the correction's file in another) fails here, and a new shared option must say
what it means before it lands.
"""

from __future__ import annotations

from collections import defaultdict

import click
import pytest

from enctools.cli import main

#: option -> its one meaning in every command that takes it
MEANINGS = {
    # every command's
    "--debug": "a traceback on errors",
    "--json": "the summary as one JSON document on stdout",
    "--quiet": "fewer messages on stderr",
    "--verbose": "more messages on stderr",
    "--force": "overwrite an existing output",
    "--format": "the output's file format (else from its extension)",
    "--output": "the output file (else stdout)",
    "--unit": "the unit angles are shown and written in",
    # a user's table read as points (cli/options.table_columns)
    "--position": "the table's column of the indicated angle",
    "--reference-column": "the table's column of the reference angle",
    "--measured": "the table's column of the indicated angle beside the reference",
    "--deviation": "the table's column of indicated minus reference angle",
    "--direction": "the table's column of the approach direction",
    "--run": "the table's column of the run number",
    "--position-unit": "the unit of the position column",
    "--reference-unit": "the unit of the reference column",
    "--measured-unit": "the unit of the measured column",
    "--deviation-unit": "the unit of the deviation column",
    "--counts-per-rev": "counts a revolution, for a column in counts",
    "--zero-offset": "remove or keep the constant offset of the table's deviations",
    "--decimal-comma": "a text table's numbers have a decimal comma",
    "--deviation-sign": "the sign a table's deviations are printed in (ISO 230-2's or enctools')",
    "--forward": "a wide table's deviation columns of the forward direction, one a run",
    "--reverse": "a wide table's deviation columns of the reverse direction, one a run",
    # the methods' words
    "--band": "the highest harmonic order K solved for, kept or shown",
    "--method": "the self-calibration method (the registry's names)",
    "--min-transfer": "the normalised |W(n)| below which a harmonic is ill-conditioned",
    "--strict": "exit 2 when the band holds blind or ill-conditioned harmonics",
    "--heads": "the heads used (recorded, averaged or checked)",
    "--reference": "where the reference angle comes from: truth, probes or heads",
    "--points": "the points of the output curve or table over the turn",
    "--spectrum": "also write the harmonics as a spectrum stream to FILE",
    "--autocollimator": "the autocollimator's column",
    "--faces": "the polygon's faces",
    "--signals": "each head's raw sin/cos signals",
    "--bidirectional": "both directions of approach",
    # a correction table and its controller file
    "--target": "the correction table's format",
    "--bits": "bits n of the encoder's code",
    "--address-bits": "the table addressed by the code's top bits",
    "--width": "the word width of a stored correction [bit]",
    "--lsb": "counts of the code per LSB of a stored correction",
    "--endian": "the byte order of a binary table's words",
    "--sign": "whether the control stores the correction or the error",
    "--axis": "the controller's axis the table is for",
    "--array": "the controller's array holding the table",
    "--comp-type": "LinuxCNC's COMP_FILE_TYPE",
    "--detection-unit": "a Fanuc axis's detection unit, the unit of its table [deg]",
    "--curve": "the curve of a deviations stream used as the correction",
    # thresholds: exit 1 beyond
    "--max-abs": "the largest |deviation| allowed",
    "--max-pp": "the peak-to-peak allowed",
    "--max-std": "the Bessel standard deviation allowed",
}


def _kind(p: click.Option) -> tuple[str, bool, bool]:
    """The kind of value an option takes: (type family, repeated, counted)."""
    if p.is_flag and not p.count:
        family = "flag"
    else:
        t = p.type
        family = ("int" if isinstance(t, (click.types.IntParamType, click.IntRange)) else
                  "float" if isinstance(t, (click.types.FloatParamType, click.FloatRange)) else
                  "path" if isinstance(t, (click.Path, click.File)) else
                  "choice" if isinstance(t, click.Choice) else "text")
    return family, bool(p.multiple), bool(p.count)


def _shared() -> dict[str, dict[str, tuple[str, bool, bool]]]:
    """option -> command -> the kind of value it takes there, for options of 2+ commands."""
    ctx = click.Context(main.cli)
    uses: dict[str, dict[str, tuple[str, bool, bool]]] = defaultdict(dict)
    for name in main.cli.list_commands(ctx):
        command = main.cli.get_command(ctx, name)
        assert command is not None
        for p in command.params:
            if isinstance(p, click.Option) and not p.hidden:
                for opt in (*p.opts, *p.secondary_opts):
                    if opt.startswith("--"):
                        uses[opt][name] = _kind(p)
    return {opt: by for opt, by in uses.items() if len(by) > 1}


SHARED = _shared()


def test_every_shared_option_says_what_it_means():
    undeclared = sorted(set(SHARED) - set(MEANINGS))
    assert not undeclared, ("options of several commands with no declared meaning "
                            f"(add one, or rename where they mean two things): {undeclared}")


def test_no_meaning_declared_for_an_option_no_longer_shared():
    stale = sorted(set(MEANINGS) - set(SHARED))
    assert not stale, f"declared but not shared by two commands: {stale}"


@pytest.mark.parametrize("option", sorted(SHARED))
def test_a_shared_option_takes_one_kind_of_value(option):
    kinds = defaultdict(list)
    for command, kind in SHARED[option].items():
        kinds[kind].append(command)
    assert len(kinds) == 1, f"{option} takes different values: {dict(kinds)}"


def test_the_check_tells_two_kinds_apart():
    flag = click.Option(["--table"], is_flag=True)
    path = click.Option(["--table"], type=click.Path())
    many = click.Option(["--table"], type=click.Path(), multiple=True)
    assert len({_kind(flag), _kind(path), _kind(many)}) == 3
