"""Monte Carlo check (GUM Supplement 1) of the uncertainty budget of a polygon step run.

Each simulated run is seed 001's polygon calibration (``enc acquire --mode steps`` on
ciomp-23bit: 24 positions, 5 readings each, one run) on a new simulated rig whose Type
B inputs are drawn from the rig's declarations: a new polygon (its face errors drawn
by the simulator from ``face_error_arcsec``, which the declaration states), a new
autocollimator scale error (drawn from ``[uncertainty.autocollimator]``) and new noise.
The points are made as ``enc points`` makes them, the budget as ``enc report`` builds
it, and each point's error against the simulator's truth (the encoder's own error at
the position the table stopped at, relative to the datum's) is compared with U.

Points of one run share the datum's readings and face: they are not independent. The
coverage over every point estimates the coverage probability; the binomial count of
the test takes one point per run (a random face other than the datum).

    .venv/bin/python benchmarks/budget_mc.py            # 2000 runs (make bench)
    .venv/bin/python benchmarks/budget_mc.py --runs 500

tests/lib/methods/test_budget.py runs the same function on fewer runs. Units: arcsec.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data.rig import Rig, load_rig
from enctools.data.uncertainty import Declaration, declaration
from enctools.hw import acquire as acq
from enctools.hw.sim import VirtualRig
from enctools.methods.budget import Budget
from enctools.methods.points import Points, Settings, points_from_steps
from enctools.report.budget import points_budget
from enctools.units import ARCSEC

#: the coverage make bench requires of the expanded uncertainty over its runs
BAND = (0.94, 0.96)


def draw(d: Declaration, rng: np.random.Generator) -> float:
    """One value [base unit of its dimension] from a declaration's distribution about 0."""
    a = d.base_value / (d.k if d.distribution == "normal" else 1.0)
    if d.distribution == "normal":
        return float(rng.normal(0.0, a))
    if d.distribution == "rectangular":
        return float(rng.uniform(-a, a))
    if d.distribution == "triangular":
        return float(rng.triangular(-a, 0.0, a))
    return float(a * math.sin(rng.uniform(0.0, 2.0 * math.pi)))  # u-shaped (arcsine)


@dataclass
class RunResult:
    """One simulated run: every point's error against the truth [arcsec] (the datum
    left out), the error of one random point of it, and the metadata its points carry
    for the budget (the drawn rig's, with its declarations, and ``polygon_run``)."""

    errors: np.ndarray
    picked: float
    meta: dict[str, Any]


def simulated_rig(rig: Rig, rng: np.random.Generator) -> Rig:
    """The rig with its Type B inputs drawn anew: the polygon's faces (a new seed; the
    simulator draws them from face_error_arcsec) and the autocollimator's scale error."""
    polygon = {**rig.polygon, "seed": int(rng.integers(1 << 62))}
    autocollimator = dict(rig.autocollimator)
    scale = rig.uncertainty.get("autocollimator")
    if scale is not None:
        kappa = draw(declaration("autocollimator", scale, "autocollimator"), rng)
        autocollimator["scale_error_ppm"] = kappa * 1e6
    return dataclasses.replace(rig, polygon=polygon, autocollimator=autocollimator)


def simulated_points(sim_rig: Rig, seed: int, given: dict[str, Any]) -> tuple[Points, np.ndarray]:
    """A step run of ``sim_rig`` (enc acquire's settings ``given`` over mode steps): its
    points as enc points makes them, and the encoder's own error at each stop [arcsec]."""
    sim = VirtualRig(sim_rig, seed=seed)
    header, batches = acq.acquire(sim_rig, sim, acq.resolve(sim_rig, {"mode": "steps",
                                                                      "seed": seed} | given))
    kept, held = [], []
    for batch in batches:           # one batch per stop: where the table stopped
        kept.append(batch)
        held.append(sim._held)
    points = points_from_steps(header, pa.Table.from_batches(kept), Settings())
    return points, np.array([sim.feedback_error(theta) for theta in held]) / ARCSEC


def one_run(rig: Rig, seed: int, rng: np.random.Generator) -> RunResult:
    """A polygon step run on a rig drawn from ``rig``'s declarations: its points as
    enc points makes them, and their errors against the simulator's truth."""
    sim_rig = simulated_rig(rig, rng)
    points, own = simulated_points(sim_rig, seed, {})
    errors = points.deviation - (own - own[0])
    picked = errors[int(rng.integers(1, errors.size))]
    return RunResult(errors[1:], float(picked),
                     {"rig": sim_rig.to_dict(), "polygon_run": points.run_meta})


def budget_of(result: RunResult, leave_out: tuple[str, ...] = ()) -> Budget:
    """The run's budget as enc report builds it, without the declarations ``leave_out``."""
    rig = result.meta["rig"]
    declared = {k: v for k, v in rig["uncertainty"].items() if k not in leave_out}
    budget, _ = points_budget(result.meta | {"rig": rig | {"uncertainty": declared}},
                              "simulated run", one_approach=True)
    assert budget is not None
    return budget


def monte_carlo(runs: int, seed: int = 0, rig_name: str = "ciomp-23bit") -> list[RunResult]:
    """``runs`` simulated runs, reproducible by ``seed``."""
    rig = load_rig(rig_name)
    rng = np.random.default_rng(seed)
    return [one_run(rig, 1_000_000 * seed + i, rng) for i in range(runs)]


def coverage(results: list[RunResult], budgets: list[Budget]) -> tuple[float, int, float]:
    """The coverage of each run's U over every point, the count of runs whose random
    point is covered, and the standard deviation of error / u_c over every point."""
    every = np.concatenate([np.abs(r.errors) <= b.U for r, b in zip(results, budgets,
                                                                     strict=True)])
    picked = sum(abs(r.picked) <= b.U for r, b in zip(results, budgets, strict=True))
    z = np.concatenate([r.errors / b.u_c for r, b in zip(results, budgets, strict=True)])
    return float(every.mean()), int(picked), float(np.std(z))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    results = monte_carlo(args.runs, args.seed)
    budgets = [budget_of(r) for r in results]
    elapsed = time.perf_counter() - t0
    every, picked, z = coverage(results, budgets)
    n_points = sum(r.errors.size for r in results)
    print(f"budget Monte Carlo: {args.runs} simulated seed 001 polygon runs ({n_points} points) "
          f"in {elapsed:.1f} s ({elapsed / args.runs * 1000:.0f} ms a run)")
    print(f"  U (k {budgets[0].k:.3f}): median {np.median([b.U for b in budgets]):.4f}\"; "
          f"std of error/u_c {z:.3f}")
    per_run = [np.mean(np.abs(r.errors) <= b.U) for r, b in zip(results, budgets, strict=True)]
    se = np.std(per_run, ddof=1) / math.sqrt(len(per_run))  # runs independent, points not
    print(f"  coverage of U: {every:.2%} (standard error {se:.2%}, by runs) of every point; "
          f"{picked}/{args.runs} ({picked / args.runs:.2%}) of one random point per run")
    ok = BAND[0] <= every <= BAND[1]
    print(f"  {'within' if ok else 'OUTSIDE'} {BAND[0]:.0%}..{BAND[1]:.0%}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
