"""``average``: the mean of the heads as one reading (enc design only).

Its transfer function is A(n) = (1/N) sum_k exp(i n alpha_k) (seed 000 eqs. (3)-(6)):
the harmonics the average passes and those it cancels; it divides by nothing, so it has
no noise gain and no ill-conditioned harmonics. One head is an arrangement too.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from enctools.methods.selfcal_methods.base import SelfcalMethod
from enctools.methods.selfcal_methods.registry import register

if TYPE_CHECKING:
    import numpy as np


@dataclass(frozen=True)
class Average(SelfcalMethod):
    """|A(n)| of the heads' mean: what it passes and cancels of the scale's error."""

    def transfer(self, alpha_ref: float, alphas: np.ndarray,
                 n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        import numpy as np

        from enctools.methods.heads import average_transfer

        a = np.abs(average_transfer(np.concatenate([[alpha_ref], alphas]), n))
        return a, a.copy()


METHOD = register(Average("average", "the mean of the heads: |A(n)|, what it passes and cancels",
                          listed={"design": 2}, min_heads=1, conditions=False,
                          figure="|A(n)|"))
