"""The nightly history of a fleet: one Hive-partitioned dataset (rig=NAME/year=YYYY) that
pyarrow.dataset and DuckDB read as written; enc report --history --history-rig/--since reads
only the partitions asked for; the layout before partitions is read and moved."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import pyarrow as pa
import pyarrow.dataset as ds
import pyarrow.parquet as pq
import pytest
from conftest import ROOT, one_error_line, run, run_in_process

from enctools.report.history import FILE_SCHEMA, SCHEMA, append_run, read_history

HOSTILE = "lab/3 a=b%20c.toml"      # a rig given as a path: every character the layout encodes
RIGS = ["sjtu-dual", HOSTILE, "Prüfstand ü"]


def utc(*args: int) -> dt.datetime:
    return dt.datetime(*args, tzinfo=dt.UTC)


def fleet(root: Path) -> None:
    """Three rigs, runs in 2025 and 2026; pp = the month, drift_max = the rig's index."""
    for k, rig in enumerate(RIGS):
        for when in (utc(2025, 11, 30, 23, 59), utc(2026, 1, 1), utc(2026, 3, 1)):
            append_run(root, {"rig": rig, "time": when, "status": "ok",
                              "pp": float(when.month), "drift_max": float(k)})


def test_runs_land_in_their_partition_without_the_partition_columns(tmp_path):
    f = append_run(tmp_path, {"rig": HOSTILE, "time": utc(2026, 2, 3), "status": "ok"})
    assert f.parent.relative_to(tmp_path) == Path("rig=lab%2F3%20a%3Db%2520c.toml/year=2026")
    t = pq.read_table(f)
    assert t.schema.remove_metadata() == FILE_SCHEMA.remove_metadata() and t.num_rows == 1
    assert "rig" not in t.schema.names and "year" not in t.schema.names


def test_pyarrow_dataset_reads_the_fleet_as_written(tmp_path):
    fleet(tmp_path)
    t = ds.dataset(tmp_path, format="parquet", partitioning="hive").to_table()
    assert t.num_rows == 9
    assert sorted(set(t.column("rig").to_pylist())) == sorted(RIGS)
    assert sorted(set(t.column("year").to_pylist())) == [2025, 2026]
    rows = t.filter(ds.field("rig") == HOSTILE).column("drift_max").to_pylist()
    assert rows == [1.0, 1.0, 1.0]


def test_duckdb_reads_the_fleet_as_written(tmp_path):
    """The README's query, word for word, over the partitions as enc-nightly writes them."""
    import duckdb
    fleet(tmp_path)
    readme = (ROOT / "README.md").read_text()
    sql = readme.split("```sql\n", 1)[1].split("```", 1)[0]
    sql = sql.replace("/var/lib/enc/history", str(tmp_path))
    got = duckdb.sql(sql).fetchall()
    # one rig a row: nights since 2026-01-01, largest drift, nights not ok
    assert sorted(got) == sorted((rig, 2, float(k), 0)
                                 for k, rig in enumerate(RIGS)), got
    n = duckdb.sql(f"SELECT count(*) FROM read_parquet('{tmp_path}/*/*/*.parquet', "
                   f"hive_partitioning = true) WHERE rig = '{HOSTILE}' AND year = 2025")
    assert n.fetchall() == [(1,)]


def test_report_reads_one_rig_since_a_date(tmp_path):
    fleet(tmp_path)
    r = run(["enc", "report", "--history", str(tmp_path), "--history-rig", HOSTILE, "--since",
             "2026-01-01", "--json"])
    assert r.returncode == 0, r.stderr.decode()
    rows = json.loads(r.stdout)["history"]
    assert [(x["rig"], x["time"], x["pp"]) for x in rows] == \
        [(HOSTILE, "2026-01-01T00:00:00Z", 1.0), (HOSTILE, "2026-03-01T00:00:00Z", 3.0)]
    r = run(["enc", "report", "--history", str(tmp_path), "--since", "2025-11-30T23:59"])
    assert r.returncode == 0 and "(since 2025-11-30T23:59:00Z): 9 run(s)" in r.stdout.decode()
    h = read_history(tmp_path, rig="no such rig")
    assert h.runs == 0 and h.table.schema == SCHEMA


def test_the_old_spelling_of_history_rig_still_works_with_a_warning(tmp_path):
    """enc report's --rig, the rig of the nightly history, is now --history-rig (acquire's
    --rig is a rig file): --rig and ENC_REPORT_RIG still work for one release."""
    fleet(tmp_path)
    report = ["enc", "report", "--history", str(tmp_path)]
    new = run_in_process([*report, "--history-rig", HOSTILE, "--json"])
    old = run_in_process([*report, "--rig", HOSTILE, "--json"])
    assert new.returncode == old.returncode == 0, old.stderr.decode()
    assert json.loads(old.stdout)["history"] == json.loads(new.stdout)["history"]
    assert "--rig is now spelt --history-rig" in old.stderr.decode()
    env = run_in_process([*report, "--json"], env={"ENC_REPORT_RIG": HOSTILE})
    assert json.loads(env.stdout)["history"] == json.loads(new.stdout)["history"]
    both = run_in_process([*report, "--rig", "a", "--history-rig", "b"])
    assert both.returncode == 2 and "old spelling of --history-rig" in both.stderr.decode()


def test_one_rig_reads_its_partition_only(tmp_path):
    """Damaged files in another rig's folder and in a year before --since are never
    opened (no warning); read without the filters they are skipped and named."""
    fleet(tmp_path)
    damaged = [tmp_path / "rig=sjtu-dual" / "year=2026" / "run-damaged.parquet",
               tmp_path / "rig=lab%2F3%20a%3Db%2520c.toml" / "year=2025" / "run-damaged.parquet"]
    for f in damaged:
        f.write_bytes(b"PAR1 not really")
    r = run(["enc", "report", "--history", str(tmp_path), "--history-rig", HOSTILE, "--since",
             "2026-01-01"])
    assert r.returncode == 0 and r.stderr == b"" and ": 2 run(s)" in r.stdout.decode()
    r = run(["enc", "report", "--history", str(tmp_path)])
    err = r.stderr.decode()
    assert r.returncode == 0 and ": 9 run(s), 2 unreadable file(s) skipped" in r.stdout.decode()
    assert err.count("skipping unreadable") == 2 and "year=2025/run-damaged.parquet" in err


def test_the_layout_before_partitions_is_read_then_moved(tmp_path):
    old = {"run_id": "20250101T000000.000000Z-old", "time": utc(2025, 1, 1), "host": "h",
           "rig": "ciomp-23bit", "status": "ok", "exit_code": 0, "pp": 4.0}
    table = pa.table({f.name: pa.array([old.get(f.name)], f.type) for f in SCHEMA})
    pq.write_table(table, tmp_path / f"run-{old['run_id']}.parquet")
    h = read_history(tmp_path, rig="ciomp-23bit", since=dt.datetime(2024, 12, 31))
    assert h.column("pp").tolist() == [4.0] and read_history(tmp_path, rig="x").runs == 0
    append_run(tmp_path, {"rig": "ciomp-23bit", "status": "ok", "pp": 5.0})
    assert not list(tmp_path.glob("*.parquet"))                 # moved into its partition
    moved = tmp_path / "rig=ciomp-23bit" / "year=2025" / f"run-{old['run_id']}.parquet"
    assert pq.read_table(moved).column("pp").to_pylist() == [4.0]
    assert read_history(tmp_path).column("pp").tolist() == [4.0, 5.0]


def test_a_run_both_moved_and_not_yet_removed_is_read_once(tmp_path):
    """A reader between the move's write and its removal of the old file."""
    f = append_run(tmp_path, {"rig": "r", "status": "ok", "time": utc(2026, 5, 1)})
    t = pq.read_table(f)
    whole = t.append_column("rig", pa.array(["r"])).select(SCHEMA.names)
    pq.write_table(whole, tmp_path / f.name)
    assert read_history(tmp_path).runs == 1


@pytest.mark.parametrize(("argv", "says"), [
    (["--history-rig", "x"], "--history-rig and --since select runs of --history DIR"),
    (["--history", ".", "--since", "2026-13-01"], "Invalid value for '--since'"),
])
def test_report_filter_errors_are_one_line(argv, says):
    r = run_in_process(["report", *argv])
    assert says in one_error_line(r, 2, "enc report")


@pytest.mark.parametrize("rig", ["", "x" * 300])
def test_nightly_refuses_a_rig_that_names_no_folder(tmp_path, rig):
    r = run([str(ROOT / "bin" / "enc-nightly"), "--rig", rig, "--history", str(tmp_path / "h"),
             "--calibration", str(tmp_path / "c.parquet"), "--campaign", "true"])
    assert "--rig: " in one_error_line(r, 2, "enc-nightly")
    assert not (tmp_path / "h").exists()
