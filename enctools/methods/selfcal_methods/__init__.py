"""Self-calibration methods as strategy objects, one module each, in one registry.

:mod:`.base` says what a method is (:class:`~.base.SelfcalMethod`: its transfer
function, blind orders, design figure, how it combines the heads, its check of them,
its help line); :mod:`.registry` holds them by name. The methods of enctools:
:mod:`.fourier`, :mod:`.eda`, :mod:`.esa` (enc selfcal and enc design) and
:mod:`.average` (enc design). A new method is one more module here.
"""

from __future__ import annotations

from enctools.methods.selfcal_methods.base import SelfcalMethod, Solution
from enctools.methods.selfcal_methods.registry import (
    default,
    find,
    get,
    names,
    records,
    register,
    unregister,
)

__all__ = ["SelfcalMethod", "Solution", "default", "find", "get", "names", "records",
           "register", "unregister"]
