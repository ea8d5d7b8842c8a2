"""One interpolation check (enc interp-check): against a reference, or from the raw signals."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import pyarrow as pa

from enctools.methods.interp.curve import Curve
from enctools.methods.interp.readings import check_readings
from enctools.methods.interp.settings import Settings
from enctools.methods.interp.tables import read_sweep


@dataclass
class Checked:
    """What a check found.

    ``curves``: one per device; ``settings``: the effective settings as the output's
    metadata records them; ``signals``: per head, the Heydemann fit and the
    Lissajous radius (signals mode); ``corrected``: the readings with the counts
    re-interpolated from the corrected phase (signals mode with ``corrected``).
    """

    curves: list[Curve]
    settings: dict[str, Any]
    signals: dict[str, dict[str, Any]] | None = None
    corrected: pa.Table | None = None


def run(source: Any, settings: Settings, reference_source: Any = None) -> Checked:
    """Check the interpolation error of the heads of a readings ``source`` (a stream).

    Reference mode: the readings stream through the fit in constant memory; a
    reference stream (``reference_source``, opened by the caller from
    ``settings.reference_file``) is read whole and matched by time.
    Signals mode: the readings are read whole (at most
    :data:`~enctools.methods.interp.tables.MAX_SWEEP_SAMPLES` rows) for the ellipse fit.
    """
    continuous = source.meta.get("mode") == "continuous"
    meta = settings.to_meta(continuous)
    if settings.signals:
        # imported here: the ellipse fit needs scipy, the reference mode does not
        from enctools.methods.interp.signals import check_signals, corrected_readings

        table = read_sweep(source)
        curves, fits, fitted = check_signals(table, settings)
        corrected = corrected_readings(table, fits, [c.name for c in curves], fitted) \
            if settings.corrected else None
        return Checked(curves, meta, fits, corrected)
    reference_table = None
    if reference_source is not None:
        reference_table = read_sweep(reference_source, why="the reference file")
    return Checked(check_readings(source, settings, reference_table, continuous), meta)
