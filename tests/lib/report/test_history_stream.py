"""A large nightly history of the layout before the table is read batch by batch
(enc-report(1), MEMORY): the same text, records and drift line as the history read whole."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from enctools.report import historyrows
from enctools.report.display import _history
from enctools.report.history import read_history
from enctools.report.history_hive import FILE_SCHEMA


def _write(folder, start, count, seed, reverse=False):
    part = folder / "rig=r1" / "year=2026"
    part.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    i = np.arange(start, start + count)[::-1 if reverse else 1]
    t0 = np.datetime64("2026-01-01T00:00:00", "us")
    cols = {"run_id": [f"r{j}" for j in i],
            "time": pa.array(t0 + i * 3_600_000_000, pa.timestamp("us", tz="UTC")),
            "host": ["h"] * count, "status": np.where(i % 7 == 0, "drift", "ok"),
            "exit_code": pa.array((i % 7 == 0).astype(np.int32)),
            "pp": rng.random(count), "std": rng.random(count), "mean": rng.random(count),
            "max_abs": rng.random(count), "drift_pp": rng.random(count),
            "drift_max": np.where(i % 5 == 0, np.nan, rng.random(count)),
            "tolerance": np.full(count, 2.0), "campaign": pa.nulls(count, pa.string()),
            "summary_json": pa.nulls(count, pa.string())}
    pq.write_table(pa.table(cols, schema=FILE_SCHEMA), part / f"run-{start}.parquet",
                   row_group_size=7)


@pytest.mark.heavy
def test_a_large_history_reads_as_the_whole(tmp_path, monkeypatch):
    _write(tmp_path, 0, 40, 1)
    _write(tmp_path, 40, 30, 2)
    whole = read_history(tmp_path)
    monkeypatch.setattr(historyrows, "STREAM_ROWS", 10)
    monkeypatch.setattr(historyrows, "BATCH_ROWS", 4)
    streamed = read_history(tmp_path)
    assert whole._table is not None and streamed._table is None and streamed.runs == 70
    assert streamed.text_lines() == whole.text_lines()
    assert str(streamed.to_records()) == str(whole.to_records())  # NaN != NaN
    assert streamed.table.schema == whole.table.schema
    assert str(streamed.table.to_pydict()) == str(whole.table.to_pydict())
    since = dt.datetime(2026, 1, 2, 5)
    after = read_history(tmp_path, since=since)
    assert after._table is None and after.runs == 70 - 29
    assert after.text_lines()[2:-1] == [line for line in whole.text_lines()[2:-1]
                                        if line[2:22] >= "2026-01-02T05:00:00Z"]
    assert whole.text_lines()[2].startswith("  2026-01-01T00:00:00Z r1")
    shown = _history(streamed, "urad", 4.84813681109536)
    assert shown.text_lines()[1].endswith("[urad]")
    assert shown.column("pp")[0] == whole.column("pp")[0] * 4.84813681109536


def test_files_out_of_order_are_read_whole_and_sorted(tmp_path, monkeypatch):
    _write(tmp_path, 0, 40, 1, reverse=True)
    monkeypatch.setattr(historyrows, "STREAM_ROWS", 10)
    h = read_history(tmp_path)
    assert h._table is not None and h.runs == 40
    assert list(h.times()) == sorted(h.times())
