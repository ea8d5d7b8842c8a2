"""``esa``: the four-head error separation (seed 000 eqs. (11)-(18)).

The weights a1..a3 of eq. (14) cancel radial motion in the weighted sum of the
differences to the reference head, ``F(n) = E(n) / W(n)`` for n >= 2 (eqs. (15),
(16)), the 1st harmonic from the basic model, and x(theta), y(theta) from eqs. (17),
(18). Where W(n) = 0 the graduation term at order n is itself a radial-motion pattern:
F(n), X(n) and Y(n) are all undetermined, and all three are set to 0 and named. Its
design figure is min |W(n)| over n = 2..K (Jiao et al. 2017, seed 000 ref. [16]).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from enctools.errors import SettingsError
from enctools.methods.selfcal_methods.base import Bound, SelfcalMethod, Solution
from enctools.methods.selfcal_methods.registry import register

if TYPE_CHECKING:
    import numpy as np

#: scores are figured this many candidates at a time (arrays of the band each)
CHUNK = 8192


@dataclass(frozen=True)
class ErrorSeparation(SelfcalMethod):
    """Four heads: the graduation error and the spindle's radial motion x, y."""

    def prepare(self, alpha_ref: float, alphas: np.ndarray, names: list[str]) -> Any:
        import numpy as np

        from enctools.methods.transfer import esa_weights

        a = esa_weights(alpha_ref, alphas)
        if np.max(np.abs(a)) < 1e-9:
            msg = (f"esa: heads {', '.join(names)} cannot separate radial motion "
                   "(collinear arrangement); choose other heads")
            raise SettingsError(msg)
        return a

    def check_angles(self, alphas: np.ndarray, angles_deg: list[float]) -> None:
        import numpy as np

        from enctools.methods.transfer import esa_weights

        super().check_angles(alphas, angles_deg)
        if np.max(np.abs(esa_weights(alphas[0], alphas[1:]))) < 1e-12:
            msg = f"esa: heads at {angles_deg} cannot separate radial motion"
            raise SettingsError(msg)

    def transfer(self, alpha_ref: float, alphas: np.ndarray,
                 n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """|W(n)| of eq. (15) with C = 1 and |W| / noise norm; n < 2 from the basic model."""
        import numpy as np

        from enctools.methods.transfer import esa_noise_norm, esa_transfer, fourier_transfer

        basic = fourier_transfer(np.concatenate([[alpha_ref], alphas]), n)
        transfer = np.abs(esa_transfer(alpha_ref, alphas, n))
        normalised = transfer / esa_noise_norm(alpha_ref, alphas)
        low = n < 2
        transfer[low] = basic[low]
        normalised[low] = basic[low]
        return transfer, normalised

    def tables(self, bound: Bound, n: np.ndarray, w: np.ndarray) -> dict[str, np.ndarray]:
        """``inverse`` 1 / W(n) (0 where blind and at n < 2), ``pairs`` exp(i n alpha_j) -
        exp(i n alpha_ref) and ``radial`` the least-squares inverse of eqs. (17), (18)."""
        import numpy as np

        from enctools.methods.transfer import BLIND, esa_noise_norm, esa_transfer

        transfer = esa_transfer(bound.alpha_ref, bound.alphas, n)
        ok = np.abs(transfer) / esa_noise_norm(bound.alpha_ref, bound.alphas) > BLIND
        ok[:2] = False
        s = np.sin(bound.alphas) - np.sin(bound.alpha_ref)
        c = -(np.cos(bound.alphas) - np.cos(bound.alpha_ref))
        return {"inverse": np.where(ok, 1.0 / np.where(ok, transfer, 1.0), 0),
                "pairs": w[1:] - w[0],
                "radial": np.linalg.pinv(np.stack([s, c], axis=1))}  # resid = m @ [X, Y]

    def solve(self, bound: Bound, spectra: np.ndarray,
              table: dict[str, np.ndarray]) -> Solution:
        """Seed 000 eqs. (12)-(18) on spectra (ref first, then the three heads)."""
        import numpy as np

        d = spectra[1:] - spectra[0]  # delta_j1(n), eq. (11)
        e = bound.params @ d  # E(n), eqs. (12), (15)
        f = e * table["inverse"]  # eq. (16)
        f[1] = np.dot(table["basic"][:, 1], spectra[:, 1])  # basic model
        # radial motion: what the differences leave once F is removed (eqs. (17), (18)),
        # least squares over the three differences
        resid = (d - table["pairs"] * f) * bound.radius_m  # (3, K+1), [m]
        x, y = table["radial"] @ resid
        # DC: not observable; 1st harmonic: counted as eccentricity in F; where W(n) = 0
        # F(n) and X(n), Y(n) trade against each other: neither is determined
        for gone in (slice(0, 2), bound.blind_radial):
            x[gone] = 0
            y[gone] = 0
        return Solution(f, x, y)

    def scores(self, angles: np.ndarray, n: np.ndarray, criterion: str) -> np.ndarray:
        """min over n of |W(n)| (or |W| / noise norm) for candidate rows (ref at 0) [rad]."""
        import numpy as np

        s = np.sin(angles)
        c = np.cos(angles) - 1.0
        a = np.cross(s, c)  # (N, 3), eq. (14)
        out = np.empty(angles.shape[0])
        for i0 in range(0, angles.shape[0], CHUNK):
            sl = slice(i0, i0 + CHUNK)
            w = np.zeros((a[sl].shape[0], n.size), dtype=np.complex128)
            for j in range(3):
                w += a[sl, j, None] * (np.exp(1j * angles[sl, j, None] * n[None, :]) - 1.0)
            m = np.abs(w)
            if criterion == "gain":
                m = m / np.sqrt(np.sum(a[sl] ** 2, axis=1) + np.sum(a[sl], axis=1) ** 2)[:, None]
            out[sl] = m.min(axis=1)
        return out

    def grid_scores(self, cand_deg: np.ndarray, step: float, n: np.ndarray,
                    criterion: str) -> np.ndarray:
        """As :meth:`scores` for angles on a grid of ``step`` [deg]: a table lookup."""
        import numpy as np

        from enctools.units import DEG

        idx = np.rint(cand_deg / step).astype(np.int64)
        slots = np.arange(round(360.0 / step)) * (step * DEG)
        table = np.exp(1j * np.outer(slots, n)) - 1.0  # (slots, K)
        sn, cs = np.sin(slots), np.cos(slots) - 1.0
        out = np.empty(idx.shape[0])
        for i0 in range(0, idx.shape[0], CHUNK):
            ii = idx[i0:i0 + CHUNK]
            a = np.cross(sn[ii], cs[ii])
            w = (a[:, 0, None] * table[ii[:, 0]] + a[:, 1, None] * table[ii[:, 1]]
                 + a[:, 2, None] * table[ii[:, 2]])
            m = np.abs(w)
            if criterion == "gain":
                m = m / np.sqrt(np.sum(a**2, axis=1) + np.sum(a, axis=1) ** 2)[:, None]
            out[i0:i0 + CHUNK] = m.min(axis=1)
        return out


METHOD = register(ErrorSeparation(
    "esa", "four-head error separation: graduation error and radial motion x, y",
    listed={"selfcal": 2, "design": 0}, heads=4, first=2, separates_radial=True,
    default_heads=4, rank=0))
