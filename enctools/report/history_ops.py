"""What ``enc history`` does to a nightly history (:mod:`enctools.cli.history`): show it,
compact its table, and migrate a history of the layout before the table into one.

- show: the runs of one rig and from a date on, read with both filters pushed down, as
  ``enc report`` tabulates a history (text or JSON) and plots them (HTML, PDF);
- compact: OPTIMIZE then VACUUM with a retention (:func:`.historytable.compact`);
- migrate: every row of a history of schema version 1 (Hive folders
  ``rig=NAME/year=YYYY`` of one Parquet file a night, or the flat ``run-*.parquet``
  before them) appended to a table in one transaction, its rows counted before and
  after; a run id the table holds already is not added twice, so a migration run again
  adds nothing.
"""

from __future__ import annotations

import datetime as _dt
import math
import os
from dataclasses import dataclass
from typing import Any

from enctools.errors import DataError, SettingsError
from enctools.report import historytable


def show(history: str, rig: str | None, since: _dt.datetime | None, *, as_json: bool,
         html_path: str | None, pdf_path: str | None, unit: str) -> None:
    """Print the runs of ``history`` (one ``rig``, from ``since`` on) as ``enc report``
    prints a history, and write its HTML or PDF with the drift plotted."""
    from enctools.report.output import run_report
    from enctools.report.sections import Options
    from enctools.report.thresholds import Thresholds

    run_report([], Options(), Thresholds(), as_json=as_json, html_path=html_path,
               pdf_path=pdf_path, history_dir=history, unit=unit,
               history_filter={"rig": rig, "since": since}, prog="enc history show")


def compact_lines(history: str, retention_hours: float) -> list[str]:
    """Compact the table at ``history``; the counts as the lines the command prints."""
    if not historytable.MIN_RETENTION_HOURS <= retention_hours < math.inf:  # NaN too
        msg = (f"`retention_hours` must be a number >= {historytable.MIN_RETENTION_HOURS:g} "
               f"(a night writes its files before its commit), not {retention_hours:g}")
        raise SettingsError(msg)
    if not historytable.is_table(history):
        msg = f"`history_dir` {history}: no history table there (`enc history migrate` makes one)"
        raise DataError(msg)
    c = historytable.compact(history, retention_hours)
    return [f"{history}: {c['files_before']} data file(s) before, {c['files_after']} after",
            f"optimize: {c['files_removed']} file(s) rewritten into {c['files_added']}",
            f"vacuum: {c['files_vacuumed']} file(s) older than {retention_hours:g} h "
            "and in no current version removed"]


@dataclass(frozen=True)
class Migration:
    """The rows of a migration: read from the old history (and its files skipped), in the
    table before and after, and added."""

    rows_old: int
    skipped_files: int
    rows_before: int
    rows_after: int

    @property
    def added(self) -> int:
        return self.rows_after - self.rows_before

    def lines(self, old: str, new: str) -> list[str]:
        return [f"{old}: {self.rows_old} row(s)"
                + (f", {self.skipped_files} unreadable file(s) skipped"
                   if self.skipped_files else ""),
                f"{new}: {self.rows_before} row(s) before, {self.rows_after} after "
                f"({self.added} added)"]


def migrate(old: str, new: str) -> Migration:
    """Append every row of the history of the layout before the table at ``old`` to the
    table at ``new`` (made if needed) in one transaction; check that every run id of
    ``old`` is in ``new`` afterwards."""
    from enctools.report.history import SCHEMA
    from enctools.report.history_hive import is_hive, read_hive

    if not os.path.isdir(old):
        msg = f"`old` {old}: no such folder"
        raise DataError(msg)
    if historytable.is_table(old) or not is_hive(old):
        msg = f"`old` {old}: no history of the layout before the table (rig=NAME/year=YYYY)"
        raise DataError(msg)
    if not historytable.is_remote(new) and os.path.abspath(new) == os.path.abspath(old):
        msg = f"`new` {new}: migrate into another folder than `old`"
        raise DataError(msg)
    rows = read_hive(old).table.select(SCHEMA.names)
    before = _count(new)
    if rows.num_rows:
        rows = rows.cast(historytable.table_schema(SCHEMA))
        historytable.append_rows(new, rows, ["migrate"])
    after = _count(new)
    kept = _run_ids(new)
    lost = [r for r in rows.column("run_id").to_pylist() if r not in kept]
    if lost:
        msg = f"`new` {new}: {len(lost)} run(s) of {old} missing after the migration"
        raise DataError(msg)
    return Migration(rows.num_rows, len(read_hive(old).skipped), before, after)


def _count(history: str) -> int:
    table = historytable.open_table(history)
    return 0 if table is None else int(historytable.current_dataset(table).count_rows())


def _run_ids(history: str) -> set[Any]:
    table = historytable.open_table(history)
    if table is None:
        return set()
    return set(historytable.current_dataset(table).to_table(columns=["run_id"])
               .column("run_id").to_pylist())
