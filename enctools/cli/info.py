"""enc info: describe a stream (kind, columns, units, rows, history) on stdout."""

from __future__ import annotations

import click

from enctools.cli import options


@click.command("info")
@options.input_arg
@click.option("--json", "as_json", is_flag=True, default=False,
              help="Print the description as JSON (enc-streams(5), SUMMARIES).")
@options.verbosity
def command(input: str | None, as_json: bool) -> None:
    """Describe a stream: its kind, columns with units and roles, rows and history."""
    from enctools.data.streams import open_input

    if as_json:
        from enctools.cli.summary import emit
        from enctools.data.info import info_dict

        emit(info_dict(open_input(input)), as_json=True)
        return
    from enctools.data.info import describe

    click.echo(describe(open_input(input)))
