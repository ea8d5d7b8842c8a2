"""Monte Carlo check (GUM Supplement 1) of the uncertainty budget of an interpolation error
measured against capacitive probes (enc report's budget of ``enc interp-check`` curves
whose reference is the probes; seed 000 sec. 4: psi = h / L).

Each simulated curve is one signal period's interpolation error e(phi) [arcsec]: three
harmonics of the period (orders 1, 2 and 4, the ones a Heydemann-corrected head leaves)
with random phases and amplitudes, its largest magnitude drawn log-uniformly between
0.1" and 30" (a fine grating's residual up to a coarse one's). The probes read it through
the model enc report's budget propagates: the probe's scale error k_p, the arm's length
error dL and its temperature dT drawn from sjtu-dual's declarations
(``[uncertainty.probe]``, ``probe_arm``, ``temperature``), so that the angle read is

    psi = e (1 + k_p) / ((1 + dL / L) (1 + alpha dT))

and each of the curve's ``bins`` points is the mean of ``samples`` readings with noise of a
standard deviation drawn per curve between 0.001" and 0.05", its Type A u the samples'
s / sqrt(n), as interp-check gives a curve's u. The budget is built as enc report builds it
(:func:`enctools.methods.budget.probe_interpolation_budget` at the curve's largest
|psi|, each point's U = k sqrt(u_A(point)^2 + u_B^2)), and its U compared with the error
of the measured curve against e at the point of the largest |psi| (where the budget's
sensitivities are taken: elsewhere the probes' rows cover more than that point's share).
This checks the budget's model and its k, not the acquisition.

    .venv/bin/python benchmarks/interp_mc.py            # 4000 curves (make bench)
    .venv/bin/python benchmarks/interp_mc.py --runs 500

tests/lib/methods/test_budget_interp.py runs the same function on fewer curves.
Units: arcsec, m, K.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np
from coverage_band import report_band

from enctools.data.rig import load_rig
from enctools.data.uncertainty import Declaration, declaration
from enctools.methods.budget import PROBE_QUANTITIES, probe_interpolation_budget

#: the rig whose declarations are drawn from; its probes' arm [m]
RIG, ARM_M = "sjtu-dual", 0.2
#: points of a curve over one period, readings averaged into each point
BINS, SAMPLES = 64, 50
#: the band make bench requires of the coverage
BAND = (0.93, 0.97)


def declared() -> dict[str, Declaration]:
    """The probe's, the arm's and the temperature's declarations of sjtu-dual."""
    rig = load_rig(RIG)
    return {q: declaration(q, rig.uncertainty[q], RIG) for q in PROBE_QUANTITIES}


def _draw(d: Declaration, rng: np.random.Generator) -> float:
    """One value of a declared quantity's error [base unit], as its distribution says."""
    if d.distribution == "normal":
        return float(rng.normal(0.0, d.standard))
    if d.distribution == "rectangular":
        return float(rng.uniform(-d.base_value, d.base_value))
    msg = f"{d.quantity}: no draw for a {d.distribution} distribution"
    raise ValueError(msg)


def _curve(rng: np.random.Generator) -> np.ndarray:
    """One period's interpolation error at BINS points [arcsec]."""
    phi = np.arange(BINS) * (2.0 * np.pi / BINS)
    e = sum(rng.uniform(0.2, 1.0) * np.cos(n * phi + rng.uniform(0.0, 2.0 * np.pi))
            for n in (1, 2, 4))
    e = np.asarray(e)
    return e * (10.0 ** rng.uniform(-1.0, math.log10(30.0)) / float(np.max(np.abs(e))))


def monte_carlo(curves: int, seed: int = 0, leave_out: str = "") -> float:
    """The fraction of ``curves`` whose measured point of the largest |psi| is within the
    budget's U of the true interpolation error there. ``leave_out``: a declared quantity
    (``probe``, ``probe_arm``, ``temperature``) the budget is built without."""
    rng = np.random.default_rng(seed)
    decl = declared()
    kept = {q: d for q, d in decl.items() if q != leave_out}
    covered = 0
    for _ in range(curves):
        e = _curve(rng)
        k_p, d_l, d_t = (_draw(decl[q], rng) for q in PROBE_QUANTITIES)
        gain = (1.0 + k_p) / ((1.0 + d_l / ARM_M) * (1.0 + decl["temperature"].expansion_per_k
                                                       * d_t))
        sigma = float(rng.uniform(0.001, 0.05))
        readings = e[:, None] * gain + rng.normal(0.0, sigma, (BINS, SAMPLES))
        psi = readings.mean(axis=1)
        u = readings.std(axis=1, ddof=1) / math.sqrt(SAMPLES)
        u_a = float(np.sqrt(np.mean(u * u)))
        budget = probe_interpolation_budget(u_a, math.inf, float(np.max(np.abs(psi))),
                                            ARM_M, kept)
        u_b2 = sum(r.u_arcsec ** 2 for r in budget.contributions[1:])
        i = int(np.argmax(np.abs(psi)))
        covered += abs(psi[i] - e[i]) <= budget.k * math.sqrt(u[i] ** 2 + u_b2)
    return covered / curves


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=4000, help="curves simulated")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    p = monte_carlo(args.runs, seed=1)
    without = "; ".join(f"without the {q} row {monte_carlo(args.runs, seed=1, leave_out=q):.3f}"
                        for q in PROBE_QUANTITIES)
    inside = report_band("interpolation budget (probes)", p,
                         f"{args.runs} curves of {BINS} points", BAND, without)
    print(f"{time.perf_counter() - start:.1f} s")
    return 0 if inside else 1


if __name__ == "__main__":
    sys.exit(main())
