"""Monte Carlo check (GUM Supplement 1) of the uncertainty budget of a comparison against
a reference encoder (enc report's budget of an ``enc compare`` curve; seed 000 eq. 10).

Each simulated comparison measures a point of D = E_dev - E_ref averaged over R
revolutions: the revolutions scatter about the true D with a standard deviation drawn
anew for each run (their Type A u is then s / sqrt(R) on R - 1 degrees of freedom), and
the reference's error is what is left of it in the case at hand:

- ``corrected`` (the reference's calibrated curve applied, enc compare
  --reference-curve): the curve is off by an error drawn from its calibration's
  declaration (``[uncertainty.reference_encoder]`` of sjtu-dual: normal, U 0.06" at k = 2);
- ``uncorrected`` (the reference used as it reads, the demo's H - P): its whole error,
  the fixed graduation error of the simulator's encoder I (P = mean of P1, P2, harmonics
  1..100 as the comparison keeps them; reference_truth.py) at an angle drawn uniformly,
  not a draw from any declaration.

The budget is built as enc report builds it (:func:`enctools.methods.budget.
comparison_budget`, with the row of the case: ``reference_encoder`` or
``reference_encoder_uncorrected``) and its U compared with the error of the measured D.
This checks the budget's model and its k (Welch-Satterthwaite on few revolutions), not the
comparison's method, which tests/lib/methods/ scores against the simulator's truth. The
uncorrected case with the calibration's row (``row="reference_encoder"``, the budget
before the row depended on the case) shows what a U that leaves the reference's error
out covers.

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
from reference_truth import p_error, report_cases

from enctools.data.rig import load_rig
from enctools.data.uncertainty import Declaration, declaration
from enctools.methods.budget import comparison_budget

#: the harmonics the comparison keeps (enc compare --band)
K = 100
#: the row of each case
ROWS = {"corrected": "reference_encoder", "uncorrected": "reference_encoder_uncorrected"}


def reference(quantity: str = "reference_encoder") -> Declaration:
    """The reference encoder's declaration ``quantity`` of the bundled sjtu-dual rig."""
    rig = load_rig("sjtu-dual")
    return declaration(quantity, rig.uncertainty[quantity], "sjtu-dual")


def monte_carlo(runs: int, revolutions: int = 5, seed: int = 0,
                leave_out_reference: bool = False, case: str = "corrected",
                row: str | None = None) -> float:
    """The fraction of ``runs`` comparisons whose error is within the budget's U.

    The scatter of a revolution's D is drawn per run between 0.01" and 0.1" (the Type
    A then weighs from far less to more than the reference's u of 0.03"): the budget's
    k must hold over both. ``case``: ``corrected`` or ``uncorrected`` (the reference's
    error as above); ``row``: the declared quantity of the budget's reference row
    (default the case's); ``leave_out_reference``: the budget without the reference's
    row, which must cover less.
    """

    rng = np.random.default_rng(seed)
    ref = reference(row or ROWS[case])
    u_ref = reference("reference_encoder").standard
    # Student's k of the Type A alone: scipy.stats.t.ppf's own function, without importing
    # scipy.stats (0.5 s of CPU in the test that runs this Monte Carlo)
    from scipy.special import stdtrit

    k_a = float(stdtrit(revolutions - 1, 0.975))
    covered = 0
    for _ in range(runs):
        sigma = float(rng.uniform(0.01, 0.1))
        readings = rng.normal(0.0, sigma, revolutions)
        e_ref = float(rng.normal(0.0, u_ref)) if case == "corrected" else \
            float(p_error(np.array([rng.uniform(0.0, 2.0 * np.pi)]), band=K)[0])
        error = float(readings.mean()) - e_ref          # measured D - true D
        u_a = float(readings.std(ddof=1)) / math.sqrt(revolutions)
        if leave_out_reference:
            U = k_a * u_a
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
    runs, revs = args.runs, args.revolutions
    ok = report_cases(
        "comparison budget", f"{runs} runs of {revs} revolutions",
        lambda case, row: monte_carlo(runs, revs, seed=1, case=case, row=row),
        lambda case: "without the reference encoder's row "
        f"{monte_carlo(runs, revs, seed=1, case=case, leave_out_reference=True):.3f}")
    print(f"{time.perf_counter() - start:.1f} s")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
