"""enc history show|compact|migrate: a fleet's history of the layout before the table
migrated with every row kept, compacted to few files with the same rows, shown one rig
since a date."""

from __future__ import annotations

import datetime as dt
import json

import pyarrow as pa
import pyarrow.parquet as pq
from conftest import one_error_line, run_in_process

from enctools.report import historytable
from enctools.report.history import append_run, read_history
from enctools.report.history_hive import FILE_SCHEMA
from enctools.report.partitions import partition_folder

RIGS = ["0042", "Prüfstand ü", "lab/3 a=b%20c"]


def old_history(root, nights: int = 4) -> int:
    """A history of schema version 1: a Parquet file a night in rig=NAME/year=YYYY."""
    for k, rig in enumerate(RIGS):
        for i in range(nights):
            when = dt.datetime(2025, 12, 30, tzinfo=dt.UTC) + dt.timedelta(days=i)
            part = partition_folder(root, rig, when.year)
            part.mkdir(parents=True, exist_ok=True)
            row = {"run_id": f"{k}-{i}", "time": when, "status": "ok", "pp": float(i),
                   "drift_max": float(k)}
            pq.write_table(pa.Table.from_pylist([row], schema=FILE_SCHEMA),
                           part / f"run-{k}-{i}.parquet")
    return len(RIGS) * nights


def test_migrate_keeps_every_row_and_counts_them(tmp_path):
    old, new = tmp_path / "old", tmp_path / "new"
    n = old_history(old)
    r = run_in_process(["history", "migrate", str(old), str(new)])
    assert r.returncode == 0, r.stderr.decode()
    assert r.stdout.decode().splitlines() == [f"{old}: {n} row(s)",
                                              f"{new}: 0 row(s) before, {n} after ({n} added)"]
    before, after = read_history(old), read_history(new)
    assert after.runs == n
    def rows(h):
        return str(sorted(h.to_records(), key=lambda x: x["run_id"]))  # NaN != NaN
    assert rows(before) == rows(after)
    for rig in RIGS:  # each rig its own partition, its name the same string
        assert read_history(new, rig=rig).column("rig").tolist() == [rig] * 4
    again = run_in_process(["history", "migrate", str(old), str(new)])
    assert again.stdout.decode().splitlines()[1] == f"{new}: {n} row(s) before, {n} after " \
                                                    "(0 added)"
    # the night after: enc-nightly appends to the table
    append_run(new, {"rig": "0042", "status": "ok"})
    assert read_history(new, rig="0042").runs == 5


def test_compact_leaves_few_files_and_every_row(tmp_path):
    for i in range(12):
        append_run(tmp_path, {"rig": RIGS[i % 3], "status": "ok", "pp": float(i)})
    rows = read_history(tmp_path).to_records()
    assert historytable.file_count(tmp_path) == 12
    r = run_in_process(["history", "compact", str(tmp_path)])
    assert r.returncode == 0, r.stderr.decode()
    assert r.stdout.decode().splitlines()[0] == f"{tmp_path}: 12 data file(s) before, 3 after"
    assert historytable.file_count(tmp_path) == 3
    assert read_history(tmp_path).to_records() == rows


def test_show_is_what_report_history_tabulates(tmp_path):
    for i in range(4):
        append_run(tmp_path, {"rig": RIGS[i % 2], "status": "ok", "pp": float(i),
                              "time": dt.datetime(2026, 1, 1 + i, tzinfo=dt.UTC)})
    args = ["--history-rig", "0042", "--since", "2026-01-02", "--json"]
    shown = run_in_process(["history", "show", str(tmp_path), *args])
    report = run_in_process(["report", "--history", str(tmp_path), *args])
    assert shown.returncode == report.returncode == 0, shown.stderr.decode()
    rows = json.loads(shown.stdout)["history"]
    assert rows == json.loads(report.stdout)["history"]
    assert [(x["rig"], x["pp"]) for x in rows] == [("0042", 2.0)]


def test_history_errors_are_one_line(tmp_path):
    r = run_in_process(["history", "compact", str(tmp_path)])
    assert "no history table there" in one_error_line(r, 2, "enc history")
    append_run(tmp_path / "t", {"rig": "r", "status": "ok"})
    r = run_in_process(["history", "compact", str(tmp_path / "t"), "--retention-hours", "0"])
    assert "--retention-hours must be a number >= 1" in one_error_line(r, 2, "enc history")
    r = run_in_process(["history", "migrate", str(tmp_path / "t"), str(tmp_path / "n")])
    assert "OLD" in one_error_line(r, 2, "enc history")


def test_show_refuses_a_folder_of_parquet_files_that_is_no_history(tmp_path):
    """Neither a table nor the layout before it, yet Parquet files: one line naming what
    is there, exit 2, no --html written (it printed "0 run(s)" and exited 0)."""
    stray = tmp_path / "stray"
    stray.mkdir()
    pq.write_table(pa.table({"x": [1]}), stray / "notes.parquet")
    page = tmp_path / "out.html"
    r = run_in_process(["history", "show", str(stray), "--html", str(page)])
    line = one_error_line(r, 2, "enc history")
    assert "1 Parquet file(s), notes.parquet first" in line and "not a nightly history" in line
    assert not page.exists()
    old_history(tmp_path / "old")  # one rig's folder of the layout before, given
    line = one_error_line(run_in_process(["history", "show", str(tmp_path / "old" / "rig=0042")]),
                          2, "enc history")
    assert "`enc history migrate`" in line and f"{tmp_path / 'old'})" in line
    append_run(tmp_path / "t", {"rig": "0042", "status": "ok"})  # a partition of a table
    line = one_error_line(run_in_process(["history", "show", str(tmp_path / "t" / "rig=0042")]),
                          2, "enc history")
    assert f"a partition of the table {tmp_path / 't'}" in line
    r = run_in_process(["report", "--history", str(stray)])
    assert "notes.parquet" in one_error_line(r, 2, "enc report")
