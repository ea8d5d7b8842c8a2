"""The readings of a continuous run as commands compare them: a device's heads against a
reference angle (the simulator's truth, or the heads of a reference encoder)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np
    import pyarrow as pa


def times(table: pa.Table, source: str) -> np.ndarray:
    """Column ``t`` [s], finite and rising (DataError naming the row otherwise)."""
    import numpy as np

    from enctools.errors import DataError

    t = table.column("t").to_numpy(zero_copy_only=False).astype(np.float64)
    if not np.all(np.isfinite(t)):
        raise DataError(f"{source}: column 't' has NaN or infinite values")
    if t.size > 1 and not np.all(t[1:] > t[:-1]):
        row = int(np.argmax(t[1:] <= t[:-1])) + 1
        raise DataError(f"{source}: column 't' does not rise at row {row} "
                        f"({t[row - 1]!r} s, then {t[row]!r} s); a run's times must increase")
    return t


def mean_reading(table: pa.Table, schema: pa.Schema, names: list[str],
                 source: str) -> np.ndarray:
    """Mean spindle reading [rad] of heads (each head's alpha and zero count removed)."""
    from enctools.data.readings import head_info, mean_head_reading
    infos = [head_info(schema, h, source) for h in names]
    return mean_head_reading([table.column(i.name) for i in infos], infos)


def reference_angle(table: pa.Table, schema: pa.Schema, meta: dict[str, Any], t: np.ndarray,
                    reference: list[str] | None, source: str) -> np.ndarray:
    """The reference angle [rad] at each reading: the true motion a simulated stream
    carries (``reference`` None or ``["truth"]``), else the mean of the named heads."""
    from enctools.data.truth import Motion
    from enctools.errors import DataError

    if reference is None or reference == ["truth"]:
        motion = (meta.get("truth") or {}).get("motion")
        if motion is None:
            raise DataError(f"{source}: no true motion in the stream; give `reference` HEADS")
        return Motion.from_dict(motion)(t)
    return mean_reading(table, schema, reference, source)
