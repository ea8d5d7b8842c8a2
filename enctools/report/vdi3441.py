"""VDI/DGQ 3441 (1977) positioning figures of a bidirectional step run, in arcsec.

The same approaches as :mod:`enctools.report.iso230`: one x per run's visit of one
target j in one direction, its readings averaged first, so n counts runs. Per target j
(up: approach from below, down: from above):

- mean deviation per direction  x_j up = (1/n) sum x up (and down)  [arcsec]
- standard deviation per direction  s_j up = sqrt(sum (x - x_j up)^2 / (n - 1))  [arcsec]
- mean position deviation  x_j = (x_j up + x_j down) / 2
- reversal span  U_j = |x_j up - x_j down|
- position scatter  Ps_j = 6 s_j, s_j = (s_j up + s_j down) / 2  (coverage +/-3 s)

Of the axis:

- U_max = max U_j; U_mean = (1/m) sum U_j
- Ps_max = max Ps_j
- position deviation  Pa = max x_j - min x_j
- position uncertainty  P = max (x_j + (U_j + Ps_j) / 2) - min (x_j - (U_j + Ps_j) / 2)

These are the definitions stated in enc-report(1), where their source is named.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from enctools.errors import DataError
from enctools.report.iso230 import Iso230

#: the axis figures, in the order they are given
AXIS_FIGURES = ("P", "Pa", "Ps_max", "U_max", "U_mean")


@dataclass
class Vdi3441:
    """VDI/DGQ 3441 figures of a step run (positions in deg, figures in ``unit``)."""

    positions: np.ndarray     # target j [deg]
    mean_up: np.ndarray       # x_j up [arcsec]
    s_up: np.ndarray          # s_j up [arcsec]
    n_up: np.ndarray          # runs per target, up
    mean_down: np.ndarray     # x_j down [arcsec]
    s_down: np.ndarray        # s_j down [arcsec]
    n_down: np.ndarray        # runs per target, down
    unit: str = "arcsec"      # of the figures: arcsec, or um on a linear axis
    position_unit: str = "deg"    # of the targets: deg, or mm on a linear axis

    @property
    def mean(self) -> np.ndarray:
        """Mean position deviation x_j = (x_j up + x_j down) / 2 [unit]."""
        return (self.mean_up + self.mean_down) / 2.0

    @property
    def U(self) -> np.ndarray:
        """Reversal span U_j = |x_j up - x_j down| [unit]."""
        return np.abs(self.mean_up - self.mean_down)

    @property
    def Ps(self) -> np.ndarray:
        """Position scatter Ps_j = 6 (s_j up + s_j down) / 2 [unit]."""
        return 6.0 * (self.s_up + self.s_down) / 2.0

    def axis(self) -> dict[str, float]:
        """The axis figures P, Pa, Ps_max, U_max, U_mean [unit]."""
        half = (self.U + self.Ps) / 2.0
        return {"P": float((self.mean + half).max() - (self.mean - half).min()),
                "Pa": float(self.mean.max() - self.mean.min()),
                "Ps_max": float(self.Ps.max()),
                "U_max": float(self.U.max()),
                "U_mean": float(self.U.mean())}

    def table(self) -> list[dict[str, float]]:
        """One row per target (``position_deg``, or ``position_mm``): x_j up/down, s_j
        up/down, x_j, U_j, Ps_j [unit] and the runs per direction."""
        cols = {"mean_up": self.mean_up, "s_up": self.s_up, "mean_down": self.mean_down,
                "s_down": self.s_down, "mean": self.mean, "U": self.U, "Ps": self.Ps}
        rows: list[dict[str, float]] = []
        for j, p in enumerate(self.positions):
            row: dict[str, float] = {f"position_{self.position_unit}": float(p)}
            row |= {k: float(v[j]) for k, v in cols.items()}
            row |= {"n_up": int(self.n_up[j]), "n_down": int(self.n_down[j])}
            rows.append(row)
        return rows

    def scaled(self, k: float, unit: str) -> Vdi3441:
        """The figures multiplied by ``k`` (arcsec -> ``unit``)."""
        return dataclasses.replace(self, mean_up=self.mean_up * k, s_up=self.s_up * k,
                                   mean_down=self.mean_down * k, s_down=self.s_down * k,
                                   unit=unit)


def vdi3441(positions_deg: np.ndarray, mean_up: np.ndarray, s_up: np.ndarray,
            mean_down: np.ndarray, s_down: np.ndarray, n_up: np.ndarray,
            n_down: np.ndarray) -> Vdi3441:
    """VDI/DGQ 3441 figures from each target's mean and standard deviation per direction.

    Parameters
    ----------
    positions_deg : target positions j [deg]
    mean_up, mean_down : mean deviation of the approaches per direction [arcsec]
    s_up, s_down : their standard deviation (n - 1) per direction [arcsec]
    n_up, n_down : approaches (runs) per target and direction
    """
    arrays = [np.asarray(a, dtype=np.float64) for a in (positions_deg, mean_up, s_up,
                                                         mean_down, s_down)]
    counts = [np.asarray(a, dtype=np.int64) for a in (n_up, n_down)]
    if len({a.size for a in arrays + counts}) != 1 or arrays[0].size == 0:
        msg = "VDI/DGQ 3441: targets, means, scatters and runs differ in length or are empty"
        raise DataError(msg)
    if not all(np.all(np.isfinite(a)) for a in arrays):
        msg = "VDI/DGQ 3441: a mean or standard deviation is NaN or infinite"
        raise DataError(msg)
    if min(int(c.min()) for c in counts) < 2:
        msg = "VDI/DGQ 3441: a target has fewer than 2 runs in a direction; s is undefined"
        raise DataError(msg)
    p, mu, su, md, sd = arrays
    return Vdi3441(p, mu, su, counts[0], md, sd, counts[1])


def from_iso(iso: Iso230) -> Vdi3441:
    """VDI/DGQ 3441 from the per-approach means and scatters ISO 230-2 computed of the
    same run (the two standards share x_j and s_j per direction) [arcsec, or um]."""
    if iso.up is None or iso.down is None:
        msg = ("one approach direction: the reversal span U and P need both "
               "(a bidirectional step run of enc acquire)")
        raise DataError(msg)
    vdi = vdi3441(iso.positions, iso.up.mean, iso.up.s, iso.down.mean, iso.down.s,
                  iso.up.runs, iso.down.runs)
    return dataclasses.replace(vdi, unit=iso.unit, position_unit=iso.position_unit)
