"""enc rig: list the bundled rigs, print one as a TOML file to edit, check a rig file."""

from __future__ import annotations

import click

from enctools.cli import options


@click.group("rig")
def command() -> None:
    """The rig files: list the bundled ones, print one to start from, check your own.

    `enc rig show sjtu-dual > my-table.toml` gives a commented file to edit;
    `enc rig check my-table.toml` reads it as every command will (enc-rig(5)).
    """


@command.command("list")
@options.verbosity
def list_() -> None:
    """Name and description of every bundled rig (tab-separated)."""
    from enctools.data.riginfo import listing
    from enctools.data.text import printable

    for name, description in listing():
        click.echo(f"{name}\t{printable(description)}")


@command.command("show")
@click.argument("rig", metavar="NAME|PATH", shell_complete=options.complete_rig)
@options.verbosity
def show(rig: str) -> None:
    """Print a rig file (a bundled name or a path) as TOML, its comments kept."""
    from enctools.data.riginfo import text

    click.echo(text(rig), nl=False)


@command.command("check")
@click.argument("rig", metavar="NAME|PATH", shell_complete=options.complete_rig)
@options.as_json
@options.verbosity
def check(rig: str, as_json: bool) -> None:
    """Read a rig file as every command does and summarise it; exit 2 naming the key at fault."""
    from enctools.data.rig import load_rig
    from enctools.data.riginfo import summary, summary_dict

    loaded = load_rig(rig)
    if as_json:
        from enctools.cli.summary import emit

        emit(summary_dict(loaded), as_json=True)
        return
    for line in summary(loaded):
        click.echo(line)
