"""enc info: describe a stream (kind, columns, units, rows, history) on stdout."""

from __future__ import annotations

import click

from enctools.cli import options


@click.command("info")
@options.input_arg
@options.verbosity
def command(input: str | None) -> None:
    """Describe a stream: its kind, columns with units and roles, rows and history."""
    from enctools.data.info import describe
    from enctools.data.streams import open_input

    click.echo(describe(open_input(input)))
