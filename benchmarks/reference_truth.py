"""The error of sjtu-dual's encoder I as the simulator's truth has it: what the Monte Carlos
of the comparison's and the step run's budgets (comparison_mc.py, steprun_mc.py) draw for
a reference used without its calibrated curve.

P = mean(P1, P2), heads at 0 and 180 deg (seed 000 eq. 6): its error at the table angle
theta is the mean of the graduation error eps(theta + alpha_k) of its heads and, read at a
standstill (a step run's target), of their interpolation errors psi_k (enctools.data.truth);
the diametral heads cancel the spindle's radial motion. Its mean over the turn is taken
out, as every deviation curve of enctools has its mean removed. Units: rad in, arcsec out.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np
from coverage_band import report_band

#: the rig, its reference encoder and its measuring heads
RIG, ENCODER, HEADS = "sjtu-dual", "I", (("P1", 0.0), ("P2", np.pi))
#: grid over one turn for the error's mean [points]
GRID = 1 << 14
#: each case of the reference and the coverage make bench requires of its U: about 95 %
#: for a normal declaration (its calibrated curve applied, off by the calibration's U); at
#: least 93 % for a bound (used as it reads: a rectangular half-width a gives U = 1.96 a /
#: sqrt 3 = 1.13 a, which covers every error within it, more than 95 % by construction)
CASES = (("corrected", (0.93, 0.97)), ("uncorrected", (0.93, 1.0)))


@cache
def _truth() -> tuple[Any, int]:
    """The rig's truth (enctools.data.truth.Truth) and encoder I's signal periods per turn."""
    from enctools.data.rig import load_rig
    from enctools.hw.sim_truth import make_truth

    rig = load_rig(RIG)
    enc = next(e for e in rig.encoders if e.name == ENCODER)
    return make_truth(rig), enc.periods_per_rev


def _graduation(theta: np.ndarray, band: int | None) -> np.ndarray:
    truth, _ = _truth()
    g = truth.graduation[ENCODER]
    if band is not None:
        g = g.band(n_max=band)
    return np.mean([g(theta + alpha) for _, alpha in HEADS], axis=0)


@cache
def _mean(band: int | None) -> float:
    """The mean of P's graduation error over the turn [arcsec]."""
    return float(np.mean(_graduation(np.arange(GRID) * (2.0 * np.pi / GRID), band)))


def p_error(theta: np.ndarray, band: int | None = None, interpolation: bool = False
            ) -> np.ndarray:
    """Encoder I's error [arcsec] at table angles ``theta`` [rad], its mean over the turn
    removed: the graduation error of P (``band``: its harmonics 1..band alone, as a
    band-limited comparison sees it) and, with ``interpolation``, its heads' interpolation
    error at those angles (a step run's standstill; a comparison's band removes it)."""
    from enctools.data.truth import interpolation_error
    from enctools.units import ARCSEC

    theta = np.asarray(theta, dtype=np.float64)
    out = _graduation(theta, band) - _mean(band)
    if interpolation:
        truth, periods = _truth()
        g = truth.graduation[ENCODER]
        out = out + np.mean([interpolation_error(truth.signals[name],
                                                 theta + alpha + g(theta + alpha) * ARCSEC,
                                                 periods) for name, alpha in HEADS], axis=0)
    return out


def report_cases(title: str, size: str, coverage: Callable[[str, str | None], float],
                 without: Callable[[str], str]) -> bool:
    """Print a Monte Carlo's coverage in each case of :data:`CASES` and whether it is in
    its band: ``coverage(case, row)`` the fraction covered (``row``: the declared quantity
    of the budget's reference row, None the case's own); ``without(case)`` the text of its
    coverages with rows left out. The uncorrected case is also run with the calibration's
    row in its place (the budget before the row depended on the case). True when every
    case is in its band."""
    ok = True
    for case, band in CASES:
        rest = without(case)
        if case == "uncorrected":
            rest += (f"; with the calibration's row in its place "
                     f"{coverage(case, 'reference_encoder'):.3f}")
        ok &= report_band(f"{title}, reference {case}", coverage(case, None), size, band, rest)
    return ok
