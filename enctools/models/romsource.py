"""What a controller's or a control's table is built from, and what its points cost.

A model or deviations stream gives one deviation curve; a ``points`` stream of a step
run gives the mean per target and direction (:mod:`.romformats.steprun`). A
controller's addressed table (acs, siemens) is built from the mean of both directions,
or, with a backlash machine datum written beside it, from the positive direction's
with the mean reversal value B apart (enc-make-rom(1), CONTROLS).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from enctools.errors import DataError, SettingsError
from enctools.units import factor

if TYPE_CHECKING:
    import pyarrow as pa

    from enctools.data.header import Header
    from enctools.models.rom import RomSpec
    from enctools.models.romformats.controls import Source

#: angles over the turn at which a controller table's interpolation is checked
INTERPOLATION_CHECKS = 14_400

#: arcsec in one degree
ARCSEC_PER_DEG = factor("deg", "arcsec")


def control_source(header: Header, table: pa.Table, source: str, curve: str | None) -> Source:
    """What a control's table is built from: a ``points`` stream (a step run: the means
    per target and direction) or a model or deviations stream (one direction)."""
    from enctools.data.columns import column, declared_unit
    from enctools.methods.points import count_deg
    from enctools.models.curve_model import from_stream
    from enctools.models.romformats import steprun

    if header.kind != "points":
        return steprun.from_model(from_stream(header, table, source, curve))
    if curve is not None:
        msg = f"`curve` chooses a curve of a deviations stream; {source} is a points stream"
        raise SettingsError(msg)
    position = column(table, "position", "deg", source,
                      declared_unit("points", header.meta, "position"))
    deviation = column(table, "deviation", "arcsec", source)
    direction, run = (table.column(c).to_numpy(zero_copy_only=False)
                      if c in table.schema.names else None for c in ("direction", "run"))
    return steprun.from_points(position, deviation, direction, run, count_deg(header.meta))


def deviation_model(header: Header, table: pa.Table, source: str, curve: str | None,
                    backlash: bool = False
                    ) -> tuple[Callable[[np.ndarray], np.ndarray], np.ndarray | None]:
    """The deviation [arcsec] at angles [deg] a table is built from: a model or deviations
    stream's (its evaluator, which may evaluate a uniform grid fast: ``on_grid``), or a
    step run's (points stream) mean over both directions per target; with ``backlash``,
    the step run's positive direction. And the reversal value B_i = up - down per target
    [arcsec] when ``backlash`` (DataError, one line, without both directions), else None."""
    from enctools.models.curve_model import from_stream

    if header.kind != "points" and not backlash:
        return from_stream(header, table, source, curve), None
    s = control_source(header, table, source, curve)
    if backlash:
        if s.backward is None or s.reversal_arcsec is None:
            msg = ("`backlash` needs a step run with both directions "
                   "(a points stream with direction +1 and -1)")
            raise DataError(msg)
        return s.forward, s.reversal_arcsec
    if s.backward is None:
        return s.forward, None
    forward, backward = s.forward, s.backward
    return (lambda a: (forward(a) + backward(a)) / 2.0), None


def interpolation_error(deviation: Callable[[np.ndarray], np.ndarray], spec: RomSpec) -> float:
    """The largest difference [arcsec] between a controller's linear interpolation of the
    model's values at the table's points (before rounding) and the model, at
    INTERPOLATION_CHECKS angles over the turn and the points' midpoints (tables up to
    2^16 points; a finer table is checked at the INTERPOLATION_CHECKS angles only)."""
    first, step = spec.grid_deg()
    points = first + np.arange(spec.entries + 1) * step
    values = np.asarray(deviation(points), dtype=np.float64)
    check = np.arange(INTERPOLATION_CHECKS) * (360.0 / INTERPOLATION_CHECKS)
    if spec.entries <= 1 << 16:
        check = np.r_[check, points[:-1] + step / 2.0]
    at = first + np.mod(check - first, 360.0)
    return float(np.max(np.abs(np.interp(at, points, values)
                               - np.asarray(deviation(at), dtype=np.float64))))


def backlash_figures(reversal_arcsec: np.ndarray, unit_deg: float) -> dict[str, object]:
    """:func:`backlash_summary` as the summary prints it: the datum in the deviation's
    sign (mean up - down of the deviation, what the controls call backlash), and
    ``reversal_mean_arcsec`` in ISO 230-2's, B_mean = mean(x up - x down) with x =
    actual - target = -deviation, the opposite sign [arcsec]."""
    out = backlash_summary(reversal_arcsec, unit_deg)
    return out | {"reversal_mean_arcsec": -float(np.mean(reversal_arcsec)) + 0.0}


#: what a controller table's summary says of a backlash machine datum written beside it
BACKLASH_KEYS = ("direction", "reversal_max_arcsec", "reversal_mean_arcsec", "backlash_steps",
                 "backlash_unit_deg", "backlash_arcsec", "machine_data")


def backlash_summary(reversal_arcsec: np.ndarray, unit_deg: float) -> dict[str, object]:
    """The mean reversal value B of a step run (B_i = up - down per target [arcsec]) as a
    backlash machine datum in steps of ``unit_deg`` [deg] (the control's resolution),
    rounded, and what it stands for [arcsec]."""
    b = float(np.mean(reversal_arcsec)) + 0.0  # never -0.0
    steps = int(np.rint(b / (unit_deg * ARCSEC_PER_DEG)))
    return {"direction": "positive, backlash apart",
            "reversal_max_arcsec": float(np.max(np.abs(reversal_arcsec))),
            "reversal_mean_arcsec": b, "backlash_steps": steps, "backlash_unit_deg": unit_deg,
            "backlash_arcsec": steps * unit_deg * ARCSEC_PER_DEG + 0.0}
