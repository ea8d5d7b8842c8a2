"""A long nightly history summarised as it is read: what enc report's JSON, HTML and PDF
show of a history of more than :data:`LISTED` runs (its text is written run by run:
:mod:`.historyrows`).

One pass over the runs' batches keeps the last :data:`LISTED` runs and, per rig and
calendar month (UTC), the runs, the failed ones (status other than ok), the first and
last time and the largest p-p, s and drift; a second pass bins p-p, s and drift into
:data:`~enctools.report.longcurves.COLUMNS` equal columns of time, each column's smallest
and largest value kept and whether a run in it failed. Memory: a batch, the runs listed,
a row per rig and month, the columns; not the runs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.report.longcurves import COLUMNS

#: the runs a report lists (the last ones) and plots run by run [runs]
LISTED = 1000
#: the figures binned by time and summarised per rig and month [arcsec, or the unit read]
SERIES = ("pp", "std", "drift_max")


@dataclass
class HistoryDigest:
    """What a report shows of a long history: ``runs``; ``last``, the records of the last
    :data:`LISTED` runs, oldest first; ``groups``, one dict per rig and month; ``times``
    (datetime64 [us], UTC) with each series' smallest and largest value per column of
    time and ``bad`` (a failed run in the column)."""

    runs: int
    unit: str
    last: list[dict[str, Any]] = field(default_factory=list)
    groups: list[dict[str, Any]] = field(default_factory=list)
    times: np.ndarray | None = None
    series: dict[str, np.ndarray] = field(default_factory=dict)
    bad: np.ndarray | None = None

    def to_dict(self) -> dict[str, Any]:
        """For JSON: the runs, those listed, and the summary per rig and month (each
        figure's key ending in its unit)."""
        return {"runs": self.runs, "listed": len(self.last),
                "listed_rule": f"the last {LISTED} runs", "per_rig_and_month": self.groups}


def _failed(b: pa.RecordBatch) -> pa.Array:
    import pyarrow.compute as pc

    return pc.fill_null(pc.not_equal(b.column("status"), "ok"), True)


def _group(groups: dict[tuple[str, str], dict[str, Any]], b: pa.RecordBatch, unit: str) -> None:
    """Add a batch of runs to the summary per rig and month."""
    import pyarrow.compute as pc

    t = pa.table({"rig": pc.fill_null(b.column("rig"), "-"),
                  "month": pc.strftime(b.column("time"), format="%Y-%m"),
                  "failed": pc.cast(_failed(b), pa.int64()), "time": b.column("time"),
                  **{n: b.column(n) for n in SERIES}})
    agg = t.group_by(["rig", "month"]).aggregate(
        [("failed", "count"), ("failed", "sum"), ("time", "min"), ("time", "max")]
        + [(n, "max") for n in SERIES]).to_pylist()
    for r in agg:
        g = groups.setdefault((r["rig"], r["month"]), {
            "rig": r["rig"], "month": r["month"], "runs": 0, "failed": 0, "first": None,
            "last": None, **{f"{n}_max_{unit}": None for n in SERIES}})
        g["runs"] += r["failed_count"]
        g["failed"] += r["failed_sum"] or 0
        g["first"] = min(filter(None, (g["first"], r["time_min"])))
        g["last"] = max(filter(None, (g["last"], r["time_max"])))
        for n in SERIES:
            v, key = r[f"{n}_max"], f"{n}_max_{unit}"
            if v is not None and np.isfinite(v) and (g[key] is None or v > g[key]):
                g[key] = v


def digest(history: Any, binned: bool = True) -> HistoryDigest:
    """The digest of a history (:class:`~enctools.report.historyrows.History`), read batch
    by batch; ``binned``: the figures binned by time too (a second pass)."""
    from enctools.report.historyrows import SCHEMA, _records

    names = [n for n in SCHEMA.names if n != "summary_json"]
    out = HistoryDigest(0, history.unit)
    tail: list[pa.RecordBatch] = []
    kept = 0
    groups: dict[tuple[str, str], dict[str, Any]] = {}
    first = last = None
    for b in history.batches(names):
        out.runs += b.num_rows
        tail.append(b)
        kept += b.num_rows
        while kept - tail[0].num_rows >= LISTED:
            kept -= tail.pop(0).num_rows
        _group(groups, b, history.unit)
        us = b.column("time").cast(pa.int64()).to_numpy(zero_copy_only=False)
        first = int(us[0]) if first is None else first
        last = int(us[-1])
    if tail:
        rows = pa.Table.from_batches(tail).slice(max(kept - LISTED, 0))
        out.last = [r for batch in rows.to_batches() for r in _records(batch)]
    for g in groups.values():
        for k in ("first", "last"):
            g[k] = g[k].strftime("%Y-%m-%dT%H:%M:%SZ")
    out.groups = [groups[k] for k in sorted(groups)]
    if binned and first is not None and last is not None:
        _bin(out, history, first, last)
    return out


def _bin(out: HistoryDigest, history: Any, first: int, last: int) -> None:
    """Second pass: each series' smallest and largest value in each column of time."""
    width = (last - first) / COLUMNS or 1.0    # [us]
    lo = {n: np.full(COLUMNS, np.inf) for n in SERIES}
    hi = {n: np.full(COLUMNS, -np.inf) for n in SERIES}
    bad = np.zeros(COLUMNS, bool)
    seen = np.zeros(COLUMNS, bool)
    for b in history.batches(["time", "status", *SERIES]):
        us = b.column("time").cast(pa.int64()).to_numpy(zero_copy_only=False)
        col = np.clip(((us - first) / width).astype(np.int64), 0, COLUMNS - 1)
        seen[col] = True
        np.logical_or.at(bad, col, _failed(b).to_numpy(zero_copy_only=False))
        for n in SERIES:
            v = b.column(n).to_numpy(zero_copy_only=False).astype(np.float64)
            np.fmin.at(lo[n], col, v)
            np.fmax.at(hi[n], col, v)
    has = np.flatnonzero(seen)
    centre = first + (has + 0.5) * width
    out.times = np.repeat(centre.astype(np.int64), 2).astype("datetime64[us]")
    for n in SERIES:
        pair = np.stack([lo[n][has], hi[n][has]], axis=1).ravel()
        out.series[n] = np.where(np.isfinite(pair), pair, np.nan)
    out.bad = np.repeat(bad[has], 2)
