"""Monte Carlo check (GUM Supplement 1) of the uncertainty budget of a step run's target
(enc report's budget of a bidirectional ``enc acquire --mode steps`` run read on an
encoder the axis does not position on; ISO 230-2).

Each simulated target is approached ``runs`` times in each direction; at each stop the
N heads of the reference encoder read the axis' true position P plus the reference's
error in the case at hand (``uncorrected``, as enc report reads every step run: the
simulator's encoder I as its truth has it, P's graduation and interpolation error at an
angle drawn uniformly (reference_truth.py), the budget's row
``[uncertainty.reference_encoder_uncorrected]``; ``corrected``, its calibrated curve
applied: the curve off by an error drawn from ``[uncertainty.reference_encoder]`` of
sjtu-dual, normal, U 0.06" at k = 2), its alignment (an error drawn from a rectangular
+-0.03" declaration), the stop's scatter (its standard deviation drawn per target
between 0.002" and 0.05") and each head's own offset within a count, then rounded to
whole counts of q = 0.05" (coarse, so that below the scatter's upper end the rounding is
the same at every approach and only the budget's resolution row holds it). The target's
mean over the directions' means, its Type A u and degrees of freedom are formed as enc
report forms them (``sections._means_and_u``: s / sqrt(n) per direction, combined by
Welch-Satterthwaite), the budget as it builds it
(:func:`enctools.methods.budget.step_run_budget`), and its U compared with the error of
the measured mean against P. This checks the budget's model and its k, not the
acquisition, which tests/lib/report/test_iso230.py checks against the raw readings.

    .venv/bin/python benchmarks/steprun_mc.py            # 4000 targets (make bench)
    .venv/bin/python benchmarks/steprun_mc.py --runs 500

tests/lib/methods/test_budget_steprun.py runs the same function on fewer targets.
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
from enctools.methods.budget import reference_quantity, resolution, step_run_budget

#: one count of the simulated reference [arcsec]; its heads
LSB, HEADS = 0.05, 2
#: the alignment declared for the check [arcsec, rectangular half-width]
ALIGNMENT = 0.03


def declared() -> dict[str, Declaration]:
    """The reference encoder's declarations of the bundled sjtu-dual rig (with its
    calibrated curve applied and without) and an alignment."""
    rig = load_rig("sjtu-dual")
    out = {q: declaration(q, rig.uncertainty[q], "sjtu-dual")
           for q in ("reference_encoder", "reference_encoder_uncorrected")}
    out["alignment"] = declaration("alignment", {"value": ALIGNMENT, "unit": "arcsec",
                                                 "distribution": "rectangular"}, "check")
    return out


def _type_a(up: np.ndarray, down: np.ndarray) -> tuple[float, float]:
    """u of the mean of the directions' means [arcsec] and its Welch-Satterthwaite dof."""
    v = [float(np.var(x, ddof=1)) / x.size / 4.0 for x in (up, down)]
    nu = [x.size - 1.0 for x in (up, down)]
    denominator = sum(vi * vi / ni for vi, ni in zip(v, nu, strict=True))
    dof = sum(v) ** 2 / denominator if denominator > 0 else math.inf
    return math.sqrt(sum(v)), dof


def monte_carlo(targets: int, runs: int = 3, seed: int = 0, leave_out: str = "",
                case: str = "corrected", row: str | None = None) -> float:
    """The fraction of ``targets`` whose measured mean is within the budget's U of the
    true positioning deviation. ``case``: ``corrected`` or ``uncorrected`` (the
    reference's error as above); ``row``: the declared quantity the budget's reference
    row is of (default the case's); ``leave_out``: a row (``reference_encoder``,
    ``resolution``) the budget is built without, which must cover less."""

    rng = np.random.default_rng(seed)
    decl = declared()
    corrected = (row or reference_quantity(case == "corrected")) == "reference_encoder"
    u_ref = decl["reference_encoder"].standard
    covered = 0
    for _ in range(targets):
        sigma = float(rng.uniform(0.002, 0.05))
        p = float(rng.normal(0.0, 1.0))                             # the axis' deviation
        e_ref = float(rng.normal(0.0, u_ref)) if case == "corrected" else \
            float(p_error(np.array([rng.uniform(0.0, 2.0 * np.pi)]), interpolation=True)[0])
        common = p + e_ref + rng.uniform(-ALIGNMENT, ALIGNMENT)
        offsets = rng.uniform(0.0, LSB, HEADS)                      # each head's phase
        means = []
        for _direction in (1, -1):
            true = common + rng.normal(0.0, sigma, runs)
            read = np.rint((true[:, None] + offsets) / LSB) * LSB - offsets
            means.append(read.mean(axis=1))
        u_a, dof = _type_a(*means)
        if u_a == 0.0:                  # every approach read the same counts
            dof = math.inf
        res = resolution(1e-12 if leave_out == "resolution" else LSB, HEADS, "the reference")
        kept = {q: d for q, d in decl.items()
                if not (leave_out == "reference_encoder" and q.startswith(leave_out))}
        U = step_run_budget(u_a, dof if dof > 0 else math.inf, res, kept,
                            corrected=corrected).U
        measured = 0.5 * (means[0].mean() + means[1].mean())
        covered += abs(measured - p) <= U
    return covered / targets


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=4000, help="targets simulated")
    parser.add_argument("--approaches", type=int, default=3, help="runs in each direction")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    runs, approaches = args.runs, args.approaches
    ok = report_cases(
        "step-run budget", f"{runs} targets of {approaches} runs a direction",
        lambda case, row: monte_carlo(runs, approaches, seed=1, case=case, row=row),
        lambda case: "; ".join(
            f"without the {q} row "
            f"{monte_carlo(runs, approaches, seed=1, leave_out=q, case=case):.3f}"
            for q in ("reference_encoder", "resolution")))
    print(f"{time.perf_counter() - start:.1f} s")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
