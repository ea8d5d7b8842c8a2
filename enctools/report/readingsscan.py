"""One pass over a readings stream for enc report: its extent, a sample of its raw signals
(for the Lissajous plots) and, of a step run, the targets with the angle the reference
heads read (counts in, angles in rad)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa

from enctools.data import readings
from enctools.data.schemas import columns_with_role, field_meta


@dataclass
class ReadingsScan:
    """What one pass over a readings stream gathers: extent, signals, step positions."""

    rows: int = 0
    t_first: float | None = None
    t_last: float | None = None
    first: dict[str, int] = field(default_factory=dict)    # head -> first count
    last: dict[str, int] = field(default_factory=dict)     # head -> last count
    signals: dict[str, list[np.ndarray]] = field(default_factory=dict)  # "H1.cos" -> parts
    stride: int = 0                                         # signal samples kept: every n-th
    target: list[np.ndarray] = field(default_factory=list)      # rad
    direction: list[np.ndarray] = field(default_factory=list)
    run: list[np.ndarray] = field(default_factory=list)
    angle: list[np.ndarray] = field(default_factory=list)       # encoder angle [rad]
    autocollimator: bool = False                            # an autocollimator column


def signal_columns(schema: pa.Schema) -> dict[str, dict[str, str]]:
    """Raw signal columns: head -> component (cos, sin) -> column."""
    out: dict[str, dict[str, str]] = {}
    for name in columns_with_role(schema, "signal"):
        fm = field_meta(schema.field(name))
        out.setdefault(fm.get("head", name), {})[fm.get("component", "")] = name
    return out


def scan_batch(scan: ReadingsScan, batch: pa.RecordBatch, infos: list[readings.HeadInfo],
                signal_cols: dict[str, dict[str, str]],
                encoder: list[readings.HeadInfo]) -> None:
    """Add one batch to the scan; ``encoder``: the heads whose mean angle is recorded
    with the targets (step runs only)."""
    if not scan.rows:
        scan.t_first = float(batch.column("t")[0].as_py())
    scan.rows += batch.num_rows
    scan.t_last = float(batch.column("t")[-1].as_py())
    for i in infos:
        c = batch.column(i.name)
        scan.first.setdefault(i.name, int(c[0].as_py()))
        scan.last[i.name] = int(c[-1].as_py())
    if signal_cols:
        scan.stride = scan.stride or max(1, batch.num_rows // 500)  # set by the first batch
        for h, comp in signal_cols.items():
            if "cos" in comp and "sin" in comp:
                for part in ("cos", "sin"):
                    scan.signals.setdefault(f"{h}.{part}", []).append(
                        batch.column(comp[part]).to_numpy(zero_copy_only=False)[::scan.stride])
    if encoder:
        scan.target.append(batch.column("target").to_numpy(zero_copy_only=False))
        if "direction" in batch.schema.names:
            scan.direction.append(batch.column("direction").to_numpy(zero_copy_only=False))
        if "run" in batch.schema.names:
            scan.run.append(batch.column("run").to_numpy(zero_copy_only=False))
        scan.angle.append(readings.mean_head_angle([batch.column(i.name) for i in encoder],
                                                   encoder))
