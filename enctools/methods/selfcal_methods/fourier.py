"""``fourier``: the basic transfer-function method (Geckeler 2006; seed 000 refs [13, 14]).

Least squares for F(n) and C(n) across all heads, radial motion ignored:
``|W(n)| = sqrt(sum_k |exp(i n alpha_k) - mean_j exp(i n alpha_j)|^2)``, blind where
every head sees the same phase. Any two heads or more; gives the 1st harmonic. It is
:class:`~enctools.methods.selfcal_methods.base.SelfcalMethod` as it stands.
"""

from __future__ import annotations

from enctools.methods.selfcal_methods.base import SelfcalMethod
from enctools.methods.selfcal_methods.registry import register

METHOD = register(SelfcalMethod(
    "fourier", "basic transfer-function method (least squares across the heads)",
    listed={"selfcal": 0, "design": 1}, fallback=True, rank=10))
