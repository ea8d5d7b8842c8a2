"""Monte Carlo check (GUM Supplement 1) of the uncertainty budget of a comparison against
a reference encoder (enc report's budget of an ``enc compare`` curve; seed 000 eq. 10).

Each simulated comparison measures a point of D = E_dev - E_ref averaged over R
revolutions: the revolutions scatter about the true D with a standard deviation drawn
anew for each run (their Type A u is then s / sqrt(R) on R - 1 degrees of freedom), and
the reference's calibrated deviation is off by an error drawn from its declaration
(``[uncertainty.reference_encoder]`` of sjtu-dual: normal, U 0.06" at k = 2). The
budget is built as enc report builds it (:func:`enctools.methods.budget.
comparison_budget`) and its U compared with the error of the measured D. This checks
the budget's model and its k (Welch-Satterthwaite on few revolutions), not the
comparison's method, which tests/lib/methods/ scores against the simulator's truth.

    .venv/bin/python benchmarks/comparison_mc.py            # 4000 runs (make bench)
    .venv/bin/python benchmarks/comparison_mc.py --runs 500

tests/lib/methods/test_budget_comparison.py runs the same function on fewer runs.
Units: arcsec.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from enctools.data.rig import load_rig
from enctools.data.uncertainty import Declaration, declaration
from enctools.methods.budget import comparison_budget

#: the coverage make bench requires of the expanded uncertainty over its runs
BAND = (0.93, 0.97)


def reference() -> Declaration:
    """The reference encoder's declaration of the bundled sjtu-dual rig."""
    rig = load_rig("sjtu-dual")
    return declaration("reference_encoder", rig.uncertainty["reference_encoder"],
                       "sjtu-dual")


def monte_carlo(runs: int, revolutions: int = 5, seed: int = 0,
                leave_out_reference: bool = False) -> float:
    """The fraction of ``runs`` comparisons whose error is within the budget's U.

    The scatter of a revolution's D is drawn per run between 0.01" and 0.1" (the Type
    A then weighs from far less to more than the reference's u of 0.03"): the budget's
    k must hold over both. ``leave_out_reference``: the budget without the reference's
    row, which must cover less.
    """
    rng = np.random.default_rng(seed)
    ref = reference()
    u_ref = ref.base_value / ref.k
    covered = 0
    for _ in range(runs):
        sigma = float(rng.uniform(0.01, 0.1))
        readings = rng.normal(0.0, sigma, revolutions)
        e_ref = float(rng.normal(0.0, u_ref))
        error = float(readings.mean()) - e_ref          # measured D - true D
        u_a = float(readings.std(ddof=1)) / math.sqrt(revolutions)
        if leave_out_reference:
            from scipy import stats

            U = float(stats.t.ppf(0.975, revolutions - 1)) * u_a
        else:
            U = comparison_budget(u_a, float(revolutions - 1), ref).U
        covered += abs(error) <= U
    return covered / runs


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=4000)
    parser.add_argument("--revolutions", type=int, default=5)
    args = parser.parse_args(argv)
    start = time.perf_counter()
    p = monte_carlo(args.runs, args.revolutions, seed=1)
    without = monte_carlo(args.runs, args.revolutions, seed=1, leave_out_reference=True)
    ok = BAND[0] <= p <= BAND[1]
    print(f"comparison budget: coverage {p:.3f} over {args.runs} runs of {args.revolutions} "
          f"revolutions (band {BAND[0]:.2f}..{BAND[1]:.2f}: {'ok' if ok else 'OUT'}); "
          f"without the reference encoder's row {without:.3f}; "
          f"{time.perf_counter() - start:.1f} s")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
