"""A correction applied to what a command reads: points, or a continuous run's readings
against their reference angle, with the residuals before and after and the corrected
rows to write.

The table is given as ``table_for(bits)``: it is loaded once the input says the bits of
its 2^n-count code (a memory table that states none takes them), so the input is
opened before the table is read. :func:`to_points` and :func:`to_readings` take what the
command opened and return an :class:`Applied`; they never write a file.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from enctools.data.header import Header
    from enctools.data.streams import InputStream
    from enctools.methods.points import Points
    from enctools.models.corrected import Residuals
    from enctools.models.correction import Correction

#: the table, given the bits of the input's 2^n-count code (None: it has none)
TableFor = Callable[[int | None], "Correction"]


@dataclass(frozen=True)
class ReadingsSettings:
    """How a continuous run's readings are corrected.

    heads : the heads averaged into the encoder's code (None: the rig's measuring heads).
    reference : the reference angle: ``truth`` (the simulator's) or a reference
        encoder's heads (None: truth).
    points : bins of the deviations curves written.
    """

    heads: list[str] | None = None
    reference: list[str] | None = None
    points: int = 1024


@dataclass
class Applied:
    """A correction applied: the rows to write (a points or deviations table), the
    residuals before and after, what a summary says of the input, and the table."""

    rows: Any
    residuals: Residuals
    about: dict[str, Any]
    table: Correction


def to_points(header: Header, pts: Points, table_for: TableFor, source: str) -> Applied:
    """Points (their position the indicated angle) corrected by the table, the table
    loaded for the code of the points' rig."""
    from enctools.models.corrected import correct_points
    from enctools.models.correction import rig_code_bits

    table = table_for(rig_code_bits(header.meta))
    fixed, res = correct_points(pts, table, source)
    return Applied(fixed.table(), res, {"input": {"kind": "points", "source": source,
                                                  "n_rows": len(pts)}}, table)


def to_readings(src: InputStream, table_for: TableFor, settings: ReadingsSettings) -> Applied:
    """A continuous run's residuals against its reference angle, and both curves binned
    (a deviations table of ``before`` and ``after``). DataError (one line) for a step
    run (its points are corrected instead) or heads of different codes."""
    import numpy as np

    from enctools.data.curves import Column, deviations_table
    from enctools.data.readings import head_info, measuring_heads
    from enctools.errors import DataError
    from enctools.methods.harmonics import bin_average, grid
    from enctools.methods.reference_angle import reference_angle, times
    from enctools.models.corrected import correct_readings, encoder_code

    header = src.header
    if "step" in header.schema.names:
        msg = (f"{src.source}: a steps run; make its points first "
               "(enc points RUN | enc correct `table_path` ...)")
        raise DataError(msg)
    names = settings.heads or measuring_heads(header.schema, header.meta, src.source)
    infos = [head_info(header.schema, h, src.source) for h in names]
    cpr = infos[0].counts_per_rev
    if any(i.counts_per_rev != cpr for i in infos):
        raise DataError(f"{src.source}: heads {', '.join(names)} count differently per turn")
    table = table_for(cpr.bit_length() - 1 if cpr > 0 and cpr & (cpr - 1) == 0 else None)
    rows = src.read_all()
    code = encoder_code([rows.column(i.name).to_numpy(zero_copy_only=False) for i in infos], cpr)
    ref = reference_angle(rows, header.schema, header.meta, times(rows, src.source),
                          settings.reference, src.source)
    angle, res = correct_readings(code, cpr, ref, table, src.source)
    curves = bin_average(angle, np.stack([res.before, res.after]), settings.points)
    out = deviations_table(grid(settings.points),
                           [Column("before", curves[0]), Column("after", curves[1])])
    about = {"input": {"kind": "readings", "source": src.source, "n_samples": int(code.size),
                       "heads": names, "reference": settings.reference or ["truth"]},
             "zero_offset_arcsec": res.zero_offset}
    return Applied(out, res, about, table)
