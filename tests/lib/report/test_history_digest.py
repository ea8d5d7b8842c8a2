"""enc report --history of more runs than it lists: the last runs listed, a summary per
rig and month, the figures binned by time; read batch by batch, never held."""

from __future__ import annotations

import datetime as _dt

import numpy as np
import pyarrow as pa

from enctools.report import historydigest, jsonout
from enctools.report.historyrows import SCHEMA, History
from enctools.report.summary import Report


def _history(runs: int) -> History:
    start = np.datetime64("2026-01-30T00:00:00", "us")
    times = start + np.arange(runs) * np.timedelta64(6, "h")       # over Jan and Feb
    rig = np.where(np.arange(runs) % 3 == 0, "a", "b")
    status = np.where(np.arange(runs) % 7 == 0, "drift", "ok")
    pp = 1.0 + np.arange(runs) / runs
    cols = {"time": pa.array(times, SCHEMA.field("time").type), "rig": pa.array(rig),
            "status": pa.array(status), "pp": pa.array(pp), "std": pa.array(pp / 4),
            "drift_max": pa.array(pp / 10)}
    table = pa.Table.from_arrays([cols.get(f.name, pa.nulls(runs, f.type)) for f in SCHEMA],
                                 schema=SCHEMA)
    return History("h", table)


def test_a_long_history_lists_its_last_runs_and_sums_the_rest(monkeypatch):
    monkeypatch.setattr(historydigest, "LISTED", 10)
    monkeypatch.setattr(jsonout, "LISTED", 10)
    h = _history(400)
    d = jsonout.report_dict(Report(sections=[], history=h, settings={}))
    assert d["history"] == h.to_records()[-10:]
    summary = d["history_summary"]
    assert summary["runs"] == 400 and summary["listed"] == 10
    groups = {(g["rig"], g["month"]): g for g in summary["per_rig_and_month"]}
    assert sum(g["runs"] for g in groups.values()) == 400
    jan_a = groups[("a", "2026-01")]          # 30 Jan 00:00 .. 31 Jan 18:00: runs 0..7
    assert jan_a["runs"] == 3 and jan_a["failed"] == 1          # runs 0, 3, 6; 0 failed
    assert jan_a["first"] == "2026-01-30T00:00:00Z"
    assert jan_a["pp_max_arcsec"] == 1.0 + 6 / 400


def test_a_short_history_is_listed_whole():
    h = _history(50)
    d = jsonout.report_dict(Report(sections=[], history=h, settings={}))
    assert d["history"] == h.to_records() and "history_summary" not in d


def test_the_figures_are_binned_by_time_each_bins_extremes(monkeypatch):
    h = _history(5000)
    dg = historydigest.digest(h)
    assert dg.times is not None and dg.bad is not None
    assert dg.times.size <= 2 * historydigest.COLUMNS
    pp = dg.series["pp"]
    assert np.nanmax(pp) == 1.0 + 4999 / 5000 and np.nanmin(pp) == 1.0
    assert dg.bad.any() and not dg.bad.all()
    assert dg.times[0] >= np.datetime64(_dt.datetime(2026, 1, 30), "us")
