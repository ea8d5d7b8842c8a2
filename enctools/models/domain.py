"""The domain of a correction: written only over the range its points measured.

A step run or a model fitted to its targets says nothing of the angles between the
last target and the first when the targets do not cover the turn
(:func:`enctools.methods.targets.measured_range`): a table over the whole turn would
hold corrections there that were never measured (the periodic interpolation or the
model's extrapolation across the gap). enc make-rom refuses such a source unless
``outside`` says what the table holds outside the measured range:

- ``zero``: no correction (deviation 0) outside;
- ``hold``: the value at the nearer end of the range (each half of the gap holds the
  value of the target on its side).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from enctools.errors import DataError
from enctools.methods.targets import MeasuredRange, group_within, measured_range, tolerance

if TYPE_CHECKING:
    import pyarrow as pa

    from enctools.data.header import Header
    from enctools.models.romformats.controls import Source

OUTSIDE = ("zero", "hold")

Deviation = Callable[[np.ndarray], np.ndarray]


def measured_of(header: Header, table: pa.Table, source: str) -> MeasuredRange | None:
    """The range a source of make-rom measured: a model's ``domain`` metadata (None for a
    model without it: written before models recorded it), a points stream's targets,
    None for a deviations stream (a curve over the whole turn)."""
    if header.kind == "model":
        meta = (header.meta.get("model") or {}).get("domain")
        return None if meta is None else MeasuredRange.from_meta(meta, source)
    if header.kind != "points":
        return None
    from enctools.data.columns import column, declared_unit
    from enctools.methods.points import count_deg

    position = column(table, "position", "deg", source,
                      declared_unit("points", header.meta, "position"))
    if not np.all(np.isfinite(position)) or position.size == 0:
        return None  # the source itself is refused, by its reader
    found = group_within(position, tolerance(position, count_deg(header.meta)))
    return measured_range(found.position_deg, found.tolerance_deg)


def check(measured: MeasuredRange | None, outside: str | None, source: str) -> None:
    """Refuse (DataError, one line naming the range) a partial range without ``outside``."""
    if measured is None or measured.full_turn or outside is not None:
        return
    msg = (f"{source}: the targets measure {measured.text()} only (a gap of "
           f"{measured.gap_deg:.6g} deg, the step {measured.step_deg:.6g} deg): a table over the "
           "turn would hold corrections never measured; give `outside` zero or `outside` hold")
    raise DataError(msg)


def outside_values(angle_deg: np.ndarray, values: np.ndarray, measured: MeasuredRange,
                   outside: str, edges: tuple[float, float]) -> np.ndarray:
    """``values`` [arcsec] at ``angle_deg`` [deg] with those outside the range replaced:
    0 (``zero``) or the deviation at the nearer end, ``edges`` = (at the start, at the
    end) [arcsec] (``hold``)."""
    a = np.asarray(angle_deg, np.float64)
    out = ~measured.contains(a)
    if not out.any():
        return values
    values = np.array(values, np.float64, copy=True)
    if outside == "zero":
        values[out] = 0.0
        return values
    past_end = np.mod(a[out] - measured.end_deg, 360.0)
    before_start = np.mod(measured.start_deg - a[out], 360.0)
    values[out] = np.where(past_end <= before_start, edges[1], edges[0])
    return values


class Restricted:
    """A deviation [arcsec] at angles [deg], replaced outside a measured range.

    Keeps the fast uniform-grid evaluation of the model it wraps (``on_grid``)."""

    def __init__(self, deviation: Deviation, measured: MeasuredRange, outside: str) -> None:
        self.deviation = deviation
        self.measured = measured
        self.outside = outside
        ends = np.array([measured.start_deg, measured.end_deg])
        start, end = np.asarray(deviation(ends), np.float64)
        self.edges = (float(start), float(end))

    def __call__(self, angle_deg: np.ndarray) -> np.ndarray:
        a = np.asarray(angle_deg, np.float64)
        return outside_values(a, np.asarray(self.deviation(a), np.float64), self.measured,
                              self.outside, self.edges)

    def on_grid(self, first_deg: float, step_deg: float) -> Callable[[int, int], np.ndarray]:
        """``values(start, stop)`` at ``first_deg + k * step_deg``, k = start..stop-1."""
        inner = getattr(self.deviation, "on_grid", None)
        at = None if inner is None else inner(first_deg, step_deg)

        def values(start: int, stop: int) -> np.ndarray:
            a = first_deg + np.arange(start, stop) * step_deg
            v = self.deviation(a) if at is None else at(start, stop)
            return outside_values(a, np.asarray(v, np.float64), self.measured, self.outside,
                                  self.edges)

        return values


def restrict(deviation: Deviation, measured: MeasuredRange | None, outside: str | None,
             source: str) -> Deviation:
    """The deviation a table is built from, checked (:func:`check`) and, over a partial
    range, replaced outside it as ``outside`` says."""
    check(measured, outside, source)
    if measured is None or measured.full_turn or outside is None:
        return deviation
    return Restricted(deviation, measured, outside)


def restrict_source(src: Source, measured: MeasuredRange | None, outside: str | None,
                    source: str) -> Source:
    """A control's source (:class:`~enctools.models.romformats.controls.Source`) checked
    and restricted to its measured range alike, each direction on its own."""
    check(measured, outside, source)
    if measured is None or measured.full_turn or outside is None:
        return replace(src, measured=measured)
    backward = None if src.backward is None else Restricted(src.backward, measured, outside)
    return replace(src, forward=Restricted(src.forward, measured, outside), backward=backward,
                   measured=measured)


def summary(measured: MeasuredRange | None, outside: str | None) -> dict[str, Any]:
    """What a table's summary and comment say of its domain."""
    if measured is None:
        return {}
    out: dict[str, Any] = {"measured_range": measured.text()}
    if not measured.full_turn:
        out["outside"] = {"zero": "zero correction",
                          "hold": "the nearer end's correction held"}[str(outside)]
    return out
