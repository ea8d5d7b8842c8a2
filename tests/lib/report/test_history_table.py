"""The nightly history as a Delta Lake table: one transaction a night, partitioned by the
rig's name as a string, a retried night a no-op, the schema version in the table's
properties, concurrent writers losing nothing; pyarrow.dataset, polars and DuckDB read the
same strings back for digit-only and non-ASCII rig names."""

from __future__ import annotations

import datetime as dt
import json
import os
import subprocess
import sys
import textwrap

import pyarrow as pa
import pytest
from conftest import run

from enctools.report import historytable
from enctools.report.history import SCHEMA, append_run, read_history

#: digit-only (an engine inferring partitions reads it as 42), non-ASCII, and every
#: character a Hive folder name escapes
NAMES = ["0042", "Prüfstand ü", "lab/3 a=b%20c"]


def utc(*args: int) -> dt.datetime:
    return dt.datetime(*args, tzinfo=dt.UTC)


def fleet(root) -> None:
    for k, rig in enumerate(NAMES):
        for when in (utc(2025, 11, 30, 23, 59), utc(2026, 1, 1)):
            append_run(root, {"rig": rig, "time": when, "status": "ok",
                              "pp": float(when.month), "drift_max": float(k)})


@pytest.mark.heavy
def test_a_night_is_one_commit_in_its_rig_partition_with_the_schema_version(tmp_path):
    from deltalake import DeltaTable

    assert append_run(tmp_path, {"rig": "0042", "status": "ok", "run_id": "n1"}) == 1
    table = DeltaTable(str(tmp_path))
    before = table.version()
    assert append_run(tmp_path, {"rig": "0042", "status": "ok", "run_id": "n2"}) == 1
    table = DeltaTable(str(tmp_path))
    assert table.version() == before + 1                     # one transaction a night
    assert table.metadata().partition_columns == ["rig"]
    assert table.metadata().configuration[historytable.VERSION_PROPERTY] == \
        historytable.SCHEMA_VERSION
    assert str(table.schema().fields[SCHEMA.names.index("rig")].type) in \
        ("string", 'PrimitiveType("string")')
    assert read_history(tmp_path).table.schema == SCHEMA


@pytest.mark.heavy
def test_a_retried_night_adds_nothing(tmp_path):
    from deltalake import DeltaTable

    night = {"rig": "r", "status": "ok", "run_id": "20261201T023000.000000Z-h-1-abc", "pp": 1.0}
    assert append_run(tmp_path, night) == 1
    version = DeltaTable(str(tmp_path)).version()
    assert append_run(tmp_path, night) == 0
    assert append_run(tmp_path, dict(night, pp=2.0)) == 0
    assert DeltaTable(str(tmp_path)).version() == version    # no commit at all
    assert read_history(tmp_path).column("pp").tolist() == [1.0]


@pytest.mark.heavy
def test_the_rig_names_come_back_as_the_same_strings_in_every_reader(tmp_path):
    """pyarrow.dataset, polars and DuckDB: "0042" a string, not 42; non-ASCII intact."""
    import duckdb
    import polars as pl
    from deltalake import DeltaTable

    fleet(tmp_path)
    dataset = DeltaTable(str(tmp_path)).to_pyarrow_dataset()
    arrow = dataset.to_table()
    assert arrow.schema.field("rig").type in (pa.string(), pa.large_string())
    assert sorted(set(arrow.column("rig").to_pylist())) == sorted(NAMES)
    frame = pl.read_delta(str(tmp_path))
    assert frame.schema["rig"] == pl.String
    assert sorted(set(frame["rig"].to_list())) == sorted(NAMES)
    got = duckdb.sql("SELECT rig, typeof(rig), count(*) FROM dataset GROUP BY ALL").fetchall()
    assert sorted(got) == sorted((n, "VARCHAR", 2) for n in NAMES)
    one = duckdb.sql("SELECT count(*) FROM dataset WHERE rig = '0042'").fetchall()
    assert one == [(2,)]
    for name in NAMES:  # the reader enctools uses, one partition each
        assert read_history(tmp_path, rig=name).column("rig").tolist() == [name, name]


@pytest.mark.heavy
def test_duckdb_reads_the_table_with_the_same_rig_strings(tmp_path):
    """enc-history(1)'s DuckDB recipe where its delta extension cannot be fetched: the
    table as an Arrow dataset, the rig from the log's partition values (never from the
    folder names, whose escaping is the writer's: deltalake 1.0.0 escapes them twice);
    and the reader enctools uses. "0042" a string, non-ASCII and escaped names intact."""
    import duckdb
    from deltalake import DeltaTable

    fleet(tmp_path)
    sql = ("SELECT rig, typeof(rig), count(*), max(drift_max) FROM history GROUP BY ALL")
    want = sorted((n, "VARCHAR", 2, float(k)) for k, n in enumerate(NAMES))
    history = DeltaTable(str(tmp_path)).to_pyarrow_dataset()
    assert sorted(duckdb.sql(sql).fetchall()) == want
    history = historytable.current_dataset(historytable.open_table(tmp_path))  # noqa: F841
    assert sorted(duckdb.sql(sql).fetchall()) == want
    got = duckdb.sql("SELECT rig, count(*) FROM history WHERE rig = '0042' GROUP BY ALL")
    assert got.fetchall() == [("0042", 2)]


@pytest.mark.heavy
def test_a_night_compacts_its_rig_when_its_files_pass_the_count(tmp_path, monkeypatch):
    """Nothing else compacts a table that enc-nightly appends to: the night that leaves
    more than CROWDED_FILES files in its rig's partition rewrites them into one, every
    row kept, the other rigs' files as they were."""
    monkeypatch.setattr(historytable, "CROWDED_FILES", 3)
    for i in range(2):
        append_run(tmp_path, {"rig": "Prüfstand ü", "status": "ok", "run_id": f"p{i}"})
    for i in range(4):
        append_run(tmp_path, {"rig": "0042", "status": "ok", "run_id": f"n{i}"})
    assert historytable.file_count(tmp_path) == 1 + 2              # 4 files > 3: one
    for i in range(4, 6):
        append_run(tmp_path, {"rig": "0042", "status": "ok", "run_id": f"n{i}"})
    assert historytable.file_count(tmp_path) == 3 + 2              # 3 files: not yet
    append_run(tmp_path, {"rig": "0042", "status": "ok", "run_id": "n6"})
    assert historytable.file_count(tmp_path) == 1 + 2
    h = read_history(tmp_path)
    assert sorted(h.column("run_id").tolist()) == sorted([f"n{i}" for i in range(7)]
                                                         + ["p0", "p1"])
    assert append_run(tmp_path, {"rig": "0042", "status": "ok", "run_id": "n3"}) == 0


@pytest.mark.heavy
def test_a_compaction_that_fails_leaves_the_night_recorded(tmp_path, monkeypatch):
    """The night is committed before its rig is compacted: a compaction that fails (a full
    disk, another writer's compaction first) is told and loses nothing."""
    import logging

    from deltalake.table import TableOptimizer

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    # a handler of the test's own on the library's logger: what an earlier test in the
    # same worker left on it (no propagation to caplog's root handler) does not matter
    said: list[str] = []

    class Said(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            said.append(record.getMessage())

    log = logging.getLogger("enctools")
    monkeypatch.setattr(log, "handlers", [Said(logging.WARNING)])
    monkeypatch.setattr(log, "disabled", False)
    monkeypatch.setattr(log, "propagate", False)
    monkeypatch.setattr(historytable, "CROWDED_FILES", 1)
    monkeypatch.setattr(TableOptimizer, "compact", full)
    level = log.level
    log.setLevel(logging.WARNING)
    try:
        for i in range(3):
            assert append_run(tmp_path, {"rig": "0042", "status": "ok", "run_id": f"n{i}"}) == 1
    finally:
        log.setLevel(level)
    assert any("could not be compacted" in m for m in said), said
    assert sorted(read_history(tmp_path).column("run_id").tolist()) == ["n0", "n1", "n2"]


@pytest.mark.heavy
def test_since_skips_the_files_before_it_by_the_log_alone(tmp_path):
    """--since is pushed down to the log's statistics: a file whose runs all precede it
    is not opened (here: removed from the disk, and the read does not notice)."""
    from deltalake import DeltaTable

    fleet(tmp_path)
    for path in DeltaTable(str(tmp_path)).file_uris():
        if read_one_time(path) < utc(2026, 1, 1):
            os.remove(path)
    h = read_history(tmp_path, rig="0042", since=utc(2026, 1, 1))
    assert h.column("run_id").size == 1 and h.column("pp").tolist() == [1.0]
    assert read_history(tmp_path, since=utc(2025, 12, 31)).runs == len(NAMES)


def read_one_time(path) -> dt.datetime:
    import pyarrow.parquet as pq

    return pq.read_table(path, columns=["time"]).column("time")[0].as_py()


@pytest.mark.heavy
def test_compact_leaves_a_checkpoint_of_the_version_it_made(tmp_path):
    """A reader opens a compacted table from one checkpoint, not by replaying each night's
    commit since the last (36,500 nights: 1.2 s to open, 0.1 s)."""
    fleet(tmp_path)
    historytable.compact(tmp_path, historytable.MIN_RETENTION_HOURS)
    last = json.loads((tmp_path / "_delta_log" / "_last_checkpoint").read_text())
    assert last["version"] == historytable.open_table(tmp_path).version()
    assert read_history(tmp_path).runs == 2 * len(NAMES)


@pytest.mark.heavy
def test_the_readme_query_runs_in_duckdb(tmp_path):
    """The README's fleet query, word for word, on the table read through Arrow."""
    import duckdb
    from conftest import ROOT
    from deltalake import DeltaTable

    fleet(tmp_path)
    readme = (ROOT / "README.md").read_text()
    sql = readme.split("```sql\n", 1)[1].split("```", 1)[0]
    assert "delta_scan('/var/lib/enc/history')" in sql
    history = DeltaTable(str(tmp_path)).to_pyarrow_dataset()  # noqa: F841 - named in the SQL
    got = duckdb.sql(sql.replace("delta_scan('/var/lib/enc/history')", "history")).fetchall()
    assert sorted(got) == sorted((rig, 1, float(k), 0) for k, rig in enumerate(NAMES)), got


def test_report_reads_the_table_one_rig_since_a_date(tmp_path):
    fleet(tmp_path)
    r = run(["enc", "report", "--history", str(tmp_path), "--history-rig", "0042", "--since",
             "2026-01-01", "--json"])
    assert r.returncode == 0, r.stderr.decode()
    rows = json.loads(r.stdout)["history"]
    assert [(x["rig"], x["time"], x["pp"]) for x in rows] == [("0042", "2026-01-01T00:00:00Z",
                                                               1.0)]


@pytest.mark.heavy
def test_a_new_column_is_a_schema_evolution_of_the_same_table(tmp_path):
    """A later version's column is added to the table; this version reads on."""
    from deltalake import DeltaTable, write_deltalake

    append_run(tmp_path, {"rig": "r", "status": "ok", "run_id": "a"})
    later = pa.table({"run_id": ["b"], "time": pa.array([utc(2026, 6, 1)],
                                                          pa.timestamp("us", tz="UTC")),
                      "rig": ["r"], "status": ["ok"], "humidity": [41.0]})
    write_deltalake(str(tmp_path), later, mode="append", schema_mode="merge")
    assert "humidity" in DeltaTable(str(tmp_path)).to_pyarrow_dataset().schema.names
    assert append_run(tmp_path, {"rig": "r", "status": "ok", "run_id": "c"}) == 1
    h = read_history(tmp_path)
    assert sorted(h.column("run_id").tolist()) == ["a", "b", "c"]
    assert h.runs == 3 and h.table.schema == SCHEMA


def test_a_folder_of_the_layout_before_is_not_written_to(tmp_path):
    import pyarrow.parquet as pq

    from enctools.report.history_hive import FILE_SCHEMA
    part = tmp_path / "rig=r" / "year=2026"
    part.mkdir(parents=True)
    pq.write_table(FILE_SCHEMA.empty_table(), part / "run-x.parquet")
    from enctools.errors import DataError
    with pytest.raises(DataError, match="enc history migrate"):
        append_run(tmp_path, {"rig": "r", "status": "ok"})
    assert not (tmp_path / "_delta_log").exists()


_WRITERS = textwrap.dedent("""
    import sys
    from enctools.report.history import append_run
    for i in range(int(sys.argv[2])):
        append_run(sys.argv[1], {"rig": "w" + sys.argv[3][-1], "status": "ok", "pp": float(i),
                                 "run_id": f"p{sys.argv[3]}-{i}"})
""")


@pytest.mark.slow
def test_twenty_processes_appending_at_once_lose_nothing(tmp_path):
    hist = tmp_path / "h"
    procs = [subprocess.Popen([sys.executable, "-c", _WRITERS, str(hist), "2", str(k)],
                              stderr=subprocess.PIPE) for k in range(20)]
    errs = [p.communicate(timeout=600)[1] for p in procs]
    assert [p.returncode for p in procs] == [0] * 20, errs
    h = read_history(hist)
    assert h.runs == 40 and len(set(h.column("run_id"))) == 40
    assert sorted(h.column("rig").tolist()).count("w0") == 4
