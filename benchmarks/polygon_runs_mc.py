"""Monte Carlo check (GUM Supplement 1) of the uncertainty budget of a polygon step run of
several runs in both directions (ISO 230-2 on the polygon; enc report's budget of its
points: the Type A over the approaches with the polygon run's Type B rows).

Each simulated run is seed 001's polygon calibration (ciomp-23bit, 24 faces) made
``runs`` times in each direction, one reading per stop, on a rig whose polygon and
autocollimator scale error are drawn anew from its declarations
(benchmarks/budget_mc.py's :func:`simulated_rig`). The points are made as ``enc points``
makes them (each run, both its directions, relative to its first position), each
target's mean over the directions' means and its Type A u as enc report forms them,
the budget as it builds it, and each target's error against the simulator's truth
(the encoder's own error at each stop, relative to its run's first stop, averaged as
the points are) compared with the target's U = k sqrt(u_A^2 + u_B^2).

Targets of one run share its datums and faces: they are not independent; the test's
binomial count takes one random target per run.

    .venv/bin/python benchmarks/polygon_runs_mc.py            # 2000 runs (make bench)
    .venv/bin/python benchmarks/polygon_runs_mc.py --runs 300

tests/lib/methods/test_budget_steprun.py runs the same function on fewer runs.
Units: arcsec.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from budget_mc import simulated_points, simulated_rig
from coverage_band import report_band

from enctools.data.rig import Rig, load_rig
from enctools.report.budget import points_budget, stop_scatter
from enctools.report.iso230 import approaches
from enctools.report.sections import _means_and_u

#: the coverage make bench requires of the expanded uncertainty over its targets
BAND = (0.93, 0.97)
FACES = 24


def one_run(rig: Rig, seed: int, rng: np.random.Generator, runs: int,
            leave_out: tuple[str, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
    """The errors of every target's mean against the truth and their U [arcsec]."""
    sim_rig = simulated_rig(rig, rng)
    p, own = simulated_points(sim_rig, seed, {"runs": runs, "bidirectional": True,
                                              "readings": 1})
    key = p.run.astype(np.int64)       # a run's both directions against its first stop
    first = {k: int(np.flatnonzero(key == k)[0]) for k in np.unique(key)}
    truth = own - own[[first[k] for k in key]]
    target = np.rint(np.mod(p.position_deg, 360.0) / (360.0 / FACES)).astype(np.int64) % FACES
    d = p.direction.astype(np.int64)
    _, _, a_err, _ = approaches(target, p.deviation - truth, d, p.run)
    a_index, a_dir, a_x, _ = approaches(target, p.deviation, d, p.run)
    _, u_a, _, dof = _means_and_u(a_index, a_dir, a_x, FACES)
    errors, _, _, _ = _means_and_u(a_index, a_dir, a_err, FACES)
    assert u_a is not None
    rms = float(np.sqrt(np.mean(u_a ** 2)))
    meta = {"rig": sim_rig.to_dict(), "polygon_run": p.run_meta}
    declared = {k: v for k, v in meta["rig"]["uncertainty"].items() if k not in leave_out}
    meta["rig"] = meta["rig"] | {"uncertainty": declared}
    scatter = stop_scatter(p.position_deg, np.radians(np.arange(FACES) * 360.0 / FACES))
    budget, _ = points_budget(meta, "simulated run", one_approach=False,
                              type_a=(rms, dof, scatter))
    assert budget is not None
    u_b2 = sum(c.u_arcsec ** 2 for c in budget.contributions if c.kind == "B")
    return errors, budget.k * np.sqrt(u_a ** 2 + u_b2)


def monte_carlo(count: int, seed: int = 0, runs: int = 3,
                leave_out: tuple[str, ...] = ()) -> tuple[float, float, float]:
    """The coverage of U over every target of ``count`` simulated runs, over one random
    target per run, and the standard error of the first (by runs: targets of one run are
    not independent, runs are)."""
    rig = load_rig("ciomp-23bit")
    rng = np.random.default_rng(seed)
    every, picked = [], []
    for i in range(count):
        errors, U = one_run(rig, 1_000_000 * seed + i, rng, runs, leave_out)
        inside = np.abs(errors) <= U
        every.append(inside.mean())
        picked.append(inside[int(rng.integers(1, FACES))])
    se = float(np.std(every, ddof=1) / np.sqrt(count)) if count > 1 else float("nan")
    return float(np.mean(every)), float(np.mean(picked)), se


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=2000, help="simulated runs")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    every, one, se = monte_carlo(args.runs, seed=1)
    without, _, _ = monte_carlo(min(args.runs, 200), seed=1, leave_out=("polygon",))
    ok = report_band("polygon step-run budget (3 runs a direction)", every,
                     f"every target of {args.runs} runs (standard error {se:.3f}), "
                     f"{one:.3f} of one random target a run", BAND,
                     f"without the polygon's rows {without:.3f} ({min(args.runs, 200)} runs); "
                     f"{time.perf_counter() - t0:.1f} s")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
