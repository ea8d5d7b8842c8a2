"""``eda``: the equal-division averaged method.

N equally spaced heads, ``F(n) = mean_k exp(-i n alpha_k) G_k(n)`` (the basic least
squares over heads that divide the circle equally); the multiples of N are blind, and
radial motion leaks into the harmonics n = +/-1 (mod N). Without heads given it takes
the rig's measuring heads, which are the equally spaced ones.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from enctools.methods.selfcal_methods.base import SelfcalMethod
from enctools.methods.selfcal_methods.registry import register

if TYPE_CHECKING:
    import numpy as np


@dataclass(frozen=True)
class EqualDivision(SelfcalMethod):
    """The basic method over equally spaced heads, checked to be so."""

    def prepare(self, alpha_ref: float, alphas: np.ndarray, names: list[str]) -> Any:
        import numpy as np

        from enctools.methods.transfer import check_equal_spacing

        check_equal_spacing(np.concatenate([[alpha_ref], alphas]), names)
        return None

    def other_heads(self, all_but_ref: list[str], non_measuring: list[str],
                    measuring: list[str]) -> list[str]:
        return measuring or all_but_ref


METHOD = register(EqualDivision("eda", "equal-division averaging of equally spaced heads",
                                listed={"selfcal": 1}))
