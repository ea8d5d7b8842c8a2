"""The optional compiled kernel: per-sample passes in one loop each (interp-check's fit;
selfcal's readings to channels, binned moments of a revolution and repeated sample
positions).

``enctools/_kernel.c`` is compiled at install time (``hatch_build.py``) into a shared
library beside this module and called through ctypes: plain C over the arrays' buffers,
no Python or numpy headers, so one build serves any Python. When it is absent (no
compiler at install, an unknown platform) or ``ENCTOOLS_KERNEL=numpy`` is set, the numpy
passes run instead, to the same results to rounding. Loaded on first use, not at import.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path
from typing import Any

#: the library's file name beside this module (hatch_build.py writes it)
LIBRARY = "_enckernel.so"
#: the interface version the loader expects of the library (enc_kernel_abi)
ABI = 3
#: the most channels and series terms enc_rev_moments takes (_kernel.c)
MAX_CHANNELS = 16
MAX_TERMS = 32
#: the environment variable that forces the numpy passes ("numpy") or asks for the kernel
ENV = "ENCTOOLS_KERNEL"


@functools.lru_cache(maxsize=1)
def library() -> Any | None:
    """The loaded library (a ctypes CDLL), or None: absent, of another interface, or
    ``ENCTOOLS_KERNEL=numpy``."""
    if os.environ.get(ENV, "").strip().lower() == "numpy":
        return None
    path = Path(__file__).with_name(LIBRARY)
    if not path.exists():
        return None
    import ctypes

    try:
        lib = ctypes.CDLL(str(path))
    except OSError:
        return None
    lib.enc_kernel_abi.restype = ctypes.c_int64
    if lib.enc_kernel_abi() != ABI:
        return None
    i64, f64, ptr = ctypes.c_int64, ctypes.c_double, ctypes.c_void_p
    lib.enc_interp_member.restype = i64
    lib.enc_interp_member.argtypes = [
        i64, ptr, f64, i64, i64, ptr, f64, ptr, i64, ptr, ptr, i64, i64,
        i64, ptr, ptr, ptr, i64, ptr, ptr, ptr, ptr, i64, ptr]
    lib.enc_rev_moments.restype = i64
    lib.enc_rev_moments.argtypes = [i64, ptr, i64, i64, ptr, ptr, ptr, ptr, i64, i64, f64,
                                    i64, i64, ptr, ptr]
    lib.enc_repeat_count.restype = i64
    lib.enc_repeat_count.argtypes = [i64, ptr, f64, f64, i64, ptr]
    lib.enc_head_channels.restype = i64
    lib.enc_head_channels.argtypes = [i64, i64, ptr, f64, f64, i64, ptr, ptr, ptr, ptr, ptr,
                                      ptr]
    return lib


def name() -> str:
    """Which per-sample passes run: "compiled (C)" or "numpy" with why."""
    if library() is not None:
        return "compiled (C)"
    if os.environ.get(ENV, "").strip().lower() == "numpy":
        return f"numpy ({ENV}=numpy)"
    return "numpy (no compiled kernel installed)"
