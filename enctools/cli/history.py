"""enc history: show, compact and migrate the nightly history (the Delta table that
enc-nightly appends to); the work is :mod:`enctools.report.history_ops`'s."""

from __future__ import annotations

from datetime import datetime

import click

from enctools.cli import options

HISTORY = click.argument("history", metavar="DIR|URI")


@click.group("history")
def command() -> None:
    """The nightly history: show its runs, compact its table, migrate an older layout.

    DIR|URI is a folder or an object-store URI (s3://, az://, gs://; credentials from the
    environment as delta-rs reads them). See enc-history(1).
    """


@command.command("show")
@HISTORY
@click.option("--history-rig", "history_rig", default=None, metavar="NAME",
              help="Only this rig's runs (its partition alone is read).")
@click.option("--since", default=None, metavar="DATE",
              type=click.DateTime(["%Y-%m-%d", "%Y-%m-%dT%H:%M", "%Y-%m-%dT%H:%M:%S"]),
              help="Only runs at or after DATE (UTC; YYYY-MM-DD[THH:MM[:SS]]).")
@options.as_json
@click.option("--html", "html_path", default=None, metavar="FILE",
              type=click.Path(dir_okay=False), help="Also write the runs and the drift "
              "plotted as an HTML page.")
@click.option("--pdf", "pdf_path", default=None, metavar="FILE",
              type=click.Path(dir_okay=False), help="Also write them as an A4 PDF.")
@options.unit
@options.force
@options.verbosity
def show(history: str, history_rig: str | None, since: datetime | None, as_json: bool,
         html_path: str | None, pdf_path: str | None, unit: str, force: bool) -> None:
    """Tabulate the runs (one rig, from a date on), as enc report --history does."""
    from enctools.report.history_ops import show as show_runs
    from enctools.report.output import check_paths

    options.distinct_outputs({"--html": html_path, "--pdf": pdf_path})
    check_paths([html_path, pdf_path], force)
    show_runs(history, history_rig, since, as_json=as_json, html_path=html_path,
              pdf_path=pdf_path, unit=unit)


@command.command("compact")
@HISTORY
@click.option("--retention-hours", type=float, default=168.0, show_default=True,
              metavar="HOURS", help="Remove the files no version younger than HOURS needs "
              "(at least 1: a night writes its files before its commit).")
@options.verbosity
def compact(history: str, retention_hours: float) -> None:
    """Rewrite each rig's small files into few (OPTIMIZE), then remove the old (VACUUM)."""
    from enctools.report.history_ops import compact_lines

    for line in compact_lines(history, retention_hours):
        click.echo(line)


@command.command("migrate")
@click.argument("old", metavar="OLD", type=click.Path(file_okay=False))
@click.argument("new", metavar="NEW")
@options.verbosity
def migrate(old: str, new: str) -> None:
    """Copy a history of the layout before the table (rig=NAME/year=YYYY folders) into a
    table at NEW, every row kept; print the rows before and after."""
    from enctools.report.history_ops import migrate as migrate_rows

    for line in migrate_rows(old, new).lines(old, new):
        click.echo(line)
