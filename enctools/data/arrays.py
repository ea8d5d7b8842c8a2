"""Arrow arrays from numpy arrays: what ``pa.array`` gives, without its masked-array test.

``pa.array(ndarray)`` asks whether its input is a ``numpy.ma.MaskedArray``, and under
numpy 2 the first such question imports ``numpy.ma``: a tenth of the start-up of a
command that writes a short stream (importing numpy and pyarrow). :func:`arrow_array`
wraps a one-dimensional numeric array's memory as an Arrow array directly (no copy, no
nulls: NaN stays a value, as with ``pa.array``) and hands anything else to ``pa.array``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyarrow as pa


def arrow_array(values: Any, type: pa.DataType | None = None) -> pa.Array:
    """``pa.array(values, type)`` of a numpy array or a sequence (units as given).

    A one-dimensional array of integers or floats in the machine's byte order whose every
    value ``type`` holds exactly (numpy's safe casting: int8 to int32, float32 to float64,
    never float to int) shares its memory with the result, as with ``pa.array``. Any other
    input goes to ``pa.array``, which checks the values as it converts them.
    """
    a = np.asarray(values)
    if a.ndim != 1 or a.dtype.kind not in "iuf" or not a.dtype.isnative:
        return pa.array(a, type)
    if type is not None:
        if not (pa.types.is_integer(type) or pa.types.is_floating(type)):
            return pa.array(a, type)
        # the numpy dtype of the Arrow type (not type.to_pandas_dtype(): pyarrow < 15
        # imports pandas for it)
        kind = "f" if pa.types.is_floating(type) else (
            "u" if pa.types.is_unsigned_integer(type) else "i")
        dtype = np.dtype(f"{kind}{type.bit_width // 8}")
        if not np.can_cast(a.dtype, dtype, "safe"):
            return pa.array(a, type)
        a = a.astype(dtype, copy=False)
    a = np.ascontiguousarray(a)
    return pa.Array.from_buffers(pa.from_numpy_dtype(a.dtype), a.size, [None, pa.py_buffer(a)])
