"""What a self-calibration method is: one :class:`SelfcalMethod` strategy object.

A method is a record of its behaviour, read by :mod:`enctools.methods.selfcal` (which
solves with it), :mod:`enctools.methods.design` (which analyses and searches head
arrangements by it) and the command line (which lists it): its transfer function
|W(n)| over heads at angles alpha_k [rad], the first order its design figure looks at,
whether it separates radial motion, how it combines the heads' spectra into the
graduation error, the heads it needs and its check of them, and its help line.

The base class is the basic least-squares method (Geckeler 2006; seed 000 refs [13, 14]):
F(n) and the heads' common part C(n) by least squares across all heads, radial motion
ignored. A method that differs overrides what differs.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from enctools.errors import SettingsError

if TYPE_CHECKING:
    import numpy as np

__all__ = ["Bound", "SelfcalMethod", "Solution", "basic_scores", "basic_table"]


@dataclass
class Solution:
    """Coefficients c_0..c_K [rad] of the graduation error F and radial motion X, Y [m]."""

    graduation: np.ndarray
    x: np.ndarray | None = None
    y: np.ndarray | None = None


class Bound(Protocol):
    """A method bound to heads and a band (:class:`enctools.methods.selfcal.Method`)."""

    alpha_ref: float
    alphas: np.ndarray
    all_alphas: np.ndarray
    radius_m: float
    names: list[str]
    params: Any

    @property
    def blind(self) -> list[int]: ...

    @property
    def blind_radial(self) -> list[int]: ...


def basic_table(all_alphas: np.ndarray, n: np.ndarray, blind: float) -> tuple[np.ndarray,
                                                                                  np.ndarray]:
    """(exp(i n alpha_k) per head and order, the basic least squares' multiplier
    conj(exp(i n alpha_k) - mean_j exp(i n alpha_j)) / |W(n)|^2, 0 where blind and at n = 0)."""
    import numpy as np

    w = np.exp(1j * np.outer(all_alphas, n))  # (heads, size)
    wc = w - w.mean(axis=0)
    den = np.sum(np.abs(wc) ** 2, axis=0)
    den = np.where(den > blind * len(all_alphas), den, np.inf)
    basic = np.conj(wc) / den
    basic[:, 0] = 0
    return w, basic


def basic_scores(angles: np.ndarray, n: np.ndarray, criterion: str) -> np.ndarray:
    """min over ``n`` of the least-squares |W(n)| for candidate rows of angles [rad]
    besides a reference at 0 (``criterion`` alike: the basic |W| is its own noise norm)."""
    import numpy as np

    full = np.concatenate([np.zeros((angles.shape[0], 1)), angles], axis=1)
    out = np.empty(angles.shape[0])
    for i0 in range(0, angles.shape[0], 4096):
        sl = slice(i0, i0 + 4096)
        w = np.exp(1j * full[sl, :, None] * n[None, None, :])
        t = np.sqrt(np.sum(np.abs(w - w.mean(axis=1, keepdims=True)) ** 2, axis=1))
        out[sl] = t.min(axis=1)
    return out


@dataclass(frozen=True)
class SelfcalMethod:
    """One self-calibration method: what enc selfcal solves with and enc design analyses.

    ``name``: as ``method`` gives it; ``about``: its help line; ``listed``: the commands
    that offer it (``"selfcal"``: it solves; ``"design"``: its arrangements are
    analysed), each with its place in their lists; ``heads``: the number of heads it
    needs, the reference among them (None: any from ``min_heads``); ``first``: the
    first order its design figure (min |W(n)|) looks at; ``separates_radial``: it
    solves the radial motion x, y too; ``conditions``: its noise gain is a figure
    (False: an average passes or cancels, it divides by nothing); ``figure``: the name
    of its transfer function in reports; ``default_heads``: it is the default method
    for this many heads, ``fallback``: for any number (``rank`` orders defaults: lower
    first).
    """

    name: str
    about: str
    listed: Mapping[str, int] = field(default_factory=lambda: {"selfcal": 100,
                                                                "design": 100})
    heads: int | None = None
    min_heads: int = 2
    first: int = 1
    separates_radial: bool = False
    conditions: bool = True
    figure: str = "|W(n)|"
    default_heads: int | None = None
    fallback: bool = False
    rank: int = 100

    # -- the heads it takes ------------------------------------------------------------

    def default_for(self, count: int) -> bool:
        """It is the method chosen, when none is given, for ``count`` heads."""
        return self.fallback or self.default_heads == count

    def check_count(self, count: int, names: list[str]) -> None:
        """SettingsError unless ``count`` heads (the reference and the others, ``names``)
        fit the method in enc selfcal."""
        if self.heads is not None and count != self.heads:
            msg = (f"{self.name} needs the reference and exactly {self.heads - 1} more heads, "
                   f"not {count} heads ({', '.join(names)}); use `method` fourier")
            raise SettingsError(msg)

    def check_angles(self, alphas: np.ndarray, angles_deg: list[float]) -> None:
        """SettingsError unless heads at ``alphas`` [rad] (``angles_deg`` as given, the
        reference first) fit the method in enc design."""
        if self.heads is not None and alphas.size != self.heads:
            msg = f"{self.name} needs {self.heads} head angles, not {alphas.size}"
            raise SettingsError(msg)

    def check_search(self, heads: int) -> None:
        """SettingsError unless an arrangement of ``heads`` heads can be searched for."""
        if self.heads is not None and heads != self.heads:
            msg = (f"{self.name} arrangements have {self.heads} heads, not {heads} "
                   "(use `method` fourier)")
            raise SettingsError(msg)

    def prepare(self, alpha_ref: float, alphas: np.ndarray, names: list[str]) -> Any:
        """Check heads at ``alpha_ref`` and ``alphas`` [rad] (called ``names``) for solving
        and return what :meth:`solve` needs of them beyond their angles (None)."""
        return None

    def other_heads(self, all_but_ref: list[str], non_measuring: list[str],
                    measuring: list[str]) -> list[str]:
        """The heads besides the reference when none are given: the encoder's heads that
        do not measure, else all of them (the reference left out of every list)."""
        return non_measuring or all_but_ref

    # -- its transfer function ---------------------------------------------------------

    def transfer(self, alpha_ref: float, alphas: np.ndarray,
                 n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(|W(n)| as the method defines it, |W(n)| / its noise norm: 1 / noise gain) at
        orders ``n`` for heads at ``alpha_ref`` then ``alphas`` [rad]."""
        import numpy as np

        from enctools.methods.transfer import fourier_transfer

        basic = fourier_transfer(np.concatenate([[alpha_ref], alphas]), n)
        return basic, basic.copy()

    # -- how it combines the heads ----------------------------------------------------

    def tables(self, bound: Bound, n: np.ndarray, w: np.ndarray) -> dict[str, np.ndarray]:
        """What :meth:`solve` multiplies by besides the basic table, at orders ``n``
        (``w``: exp(i n alpha_k), heads by orders); made once per size."""
        return {}

    def solve(self, bound: Bound, spectra: np.ndarray,
              table: dict[str, np.ndarray]) -> Solution:
        """The head spectra (reference first; rad) solved for F (X, Y): the basic least
        squares, blind orders 0."""
        import numpy as np

        f = np.einsum("kn,kn->n", table["basic"], spectra)  # fourier_solve's sum
        f[bound.blind] = 0
        return Solution(f)

    # -- its design figure ------------------------------------------------------------

    def scores(self, angles: np.ndarray, n: np.ndarray, criterion: str) -> np.ndarray:
        """min over ``n`` of |W(n)| (``criterion`` "gain": of |W| / noise norm) for candidate
        rows of angles [rad] besides a reference at 0."""
        return basic_scores(angles, n, criterion)

    def grid_scores(self, cand_deg: np.ndarray, step: float, n: np.ndarray,
                    criterion: str) -> np.ndarray:
        """As :meth:`scores` for candidates on a grid of ``step`` [deg]."""
        from enctools.units import DEG

        return self.scores(cand_deg * DEG, n, criterion)
