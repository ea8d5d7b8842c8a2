"""The nightly history of a fleet: one Delta table partitioned by the rig's name that
enc report --history --history-rig/--since reads one partition of; the Hive folders of the
layout before the table (rig=NAME/year=YYYY) and the flat one before those, still read."""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import ROOT, one_error_line, run, run_in_process

from enctools.report.history import SCHEMA, append_run, read_history
from enctools.report.history_hive import FILE_SCHEMA
from enctools.report.partitions import partition_folder

HOSTILE = "lab/3 a=b%20c.toml"      # a rig given as a path: every character the layout encodes
RIGS = ["sjtu-dual", HOSTILE, "Prüfstand ü"]


def utc(*args: int) -> dt.datetime:
    return dt.datetime(*args, tzinfo=dt.UTC)


NIGHTS = (utc(2025, 11, 30, 23, 59), utc(2026, 1, 1), utc(2026, 3, 1))


def fleet(root: Path) -> None:
    """Three rigs, runs in 2025 and 2026; pp = the month, drift_max = the rig's index."""
    for k, rig in enumerate(RIGS):
        for when in NIGHTS:
            append_run(root, {"rig": rig, "time": when, "status": "ok",
                              "pp": float(when.month), "drift_max": float(k)})


def hive_fleet(root: Path) -> None:
    """:func:`fleet` in the layout before the table: a Parquet file a night in its
    ``rig=NAME/year=YYYY`` folder."""
    for k, rig in enumerate(RIGS):
        for i, when in enumerate(NIGHTS):
            row = {"run_id": f"{k}-{i}", "time": when, "status": "ok",
                   "pp": float(when.month), "drift_max": float(k)}
            part = partition_folder(root, rig, when.year)
            part.mkdir(parents=True, exist_ok=True)
            pq.write_table(pa.Table.from_pylist([row], schema=FILE_SCHEMA),
                           part / f"run-{k}-{i}.parquet")


@pytest.mark.heavy
def test_pyarrow_dataset_reads_the_fleet_as_written(tmp_path):
    import pyarrow.dataset as ds  # with pandas, 0.2 s: not at collection
    from deltalake import DeltaTable
    fleet(tmp_path)
    t = DeltaTable(str(tmp_path)).to_pyarrow_dataset().to_table()
    assert t.num_rows == 9
    assert sorted(set(t.column("rig").to_pylist())) == sorted(RIGS)
    rows = t.filter(ds.field("rig") == HOSTILE).column("drift_max").to_pylist()
    assert rows == [1.0, 1.0, 1.0]


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
    """The layout before the table: damaged files in another rig's folder and in a year
    before --since are never opened (no warning); read without the filters they are
    skipped and named."""
    hive_fleet(tmp_path)
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


def test_the_layout_before_partitions_is_read(tmp_path):
    old = {"run_id": "20250101T000000.000000Z-old", "time": utc(2025, 1, 1), "host": "h",
           "rig": "ciomp-23bit", "status": "ok", "exit_code": 0, "pp": 4.0}
    table = pa.table({f.name: pa.array([old.get(f.name)], f.type) for f in SCHEMA})
    pq.write_table(table, tmp_path / f"run-{old['run_id']}.parquet")
    h = read_history(tmp_path, rig="ciomp-23bit", since=dt.datetime(2024, 12, 31))
    assert h.column("pp").tolist() == [4.0] and read_history(tmp_path, rig="x").runs == 0


def test_a_run_both_in_a_partition_and_flat_is_read_once(tmp_path):
    """A history that an older version was moving into its partitions."""
    hive_fleet(tmp_path)
    f = next(tmp_path.glob("rig=sjtu-dual/year=2026/*.parquet"))
    whole = pq.read_table(f).append_column("rig", pa.array(["sjtu-dual"])).select(SCHEMA.names)
    pq.write_table(whole, tmp_path / f.name)
    assert read_history(tmp_path).runs == 9


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
