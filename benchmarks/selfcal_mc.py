"""Monte Carlo check (GUM Supplement 1) of the uncertainty budget of a self-calibration
(enc report's budget of an ``enc selfcal`` curve: the Type A over the revolutions, the
method's bound and the heads' mounting through the method's own transfer function).

Each simulated run draws a scale from the simulator's own truth generator
(:func:`enctools.hw.sim_truth.graduation_truth` of sjtu-dual's encoder II, its seed
drawn anew: a different graduation error each run, harmonics 1..K of the band: the
measurand is the curve of the band), mounts the four heads of the demo arrangement
(esa, H1/H5/H6/H7 at 0/60/135/228 deg) each off its nominal angle by an error drawn from
the rig's ``[uncertainty.head_mounting]`` (rectangular +-0.1 deg), and reads R
revolutions: each head's spectrum is that of the simulator's head equation (seed 000
eq. (1): eps(theta + alpha_k) at the head's true angle, taken against the reference
head's reading, which is the curve's argument) plus white noise of a standard
deviation drawn per run, log-uniform (the revolutions' Type A then weighs from far
less to far more than the mounting's u). The method solves each revolution with the
nominal angles, as enc selfcal does; the sensitivity to the mounting is worked out from
the mean solution (:func:`enctools.methods.selfcal_uncertainty.mounting_changes`), the
budget built as enc report builds it (:func:`enctools.methods.budget.selfcal_budget`;
each point's U with the mounting's u at that point) and each run's U at one point drawn
at random compared with the error of the curve there against the truth. The
acquisition itself (sampling, interpolation error, quantisation, radial motion: the
method's bound) is not drawn here: tests/lib/methods/test_selfcal.py scores it against
the simulator; the method's mounting sensitivity is checked against the simulator with
a head moved in tests/lib/methods/test_budget_selfcal.py.

    .venv/bin/python benchmarks/selfcal_mc.py            # 2000 runs (make bench)
    .venv/bin/python benchmarks/selfcal_mc.py --runs 300

tests/lib/methods/test_budget_selfcal.py runs the same function on fewer runs.
Units: arcsec (curves), rad (angles).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time

import numpy as np
from coverage_band import report_band

from enctools.data.rig import load_rig
from enctools.data.uncertainty import Declaration, declaration
from enctools.hw.sim_truth import graduation_truth
from enctools.methods.budget import selfcal_budget
from enctools.methods.harmonics import synthesize
from enctools.methods.selfcal import Method, solution_parts
from enctools.methods.selfcal_uncertainty import mounting_changes, mounting_sensitivity
from enctools.units import ARCSEC

#: the coverage make bench requires of the expanded uncertainty over its runs
BAND = (0.93, 0.97)
#: the demo arrangement (reference first) [deg], its band and the curve's grid
HEADS = ("H1", "H5", "H6", "H7")
K = 100
POINTS = 512


def declared() -> dict[str, Declaration]:
    """The head mounting declaration of the bundled sjtu-dual rig."""
    rig = load_rig("sjtu-dual")
    return {"head_mounting": declaration("head_mounting", rig.uncertainty["head_mounting"],
                                         "sjtu-dual")}


def _draw_mounting(rng: np.random.Generator, d: Declaration, heads: int) -> np.ndarray:
    """Each head's mounting error [rad] drawn from its declaration (rectangular or normal)."""
    half = d.base_value * ARCSEC / d.k      # half-width or standard deviation [rad]
    if d.distribution == "rectangular":
        return rng.uniform(-half, half, heads)
    return rng.normal(0.0, half, heads)


def one_run(rng: np.random.Generator, method: Method, enc, decl: dict[str, Declaration],
            revolutions: int, leave_out_mounting: bool) -> bool:
    """One simulated self-calibration: is the curve's error at a random point within U?"""
    g = dataclasses.replace(enc, graduation={**enc.graduation,
                                             "seed": int(rng.integers(1 << 31))})
    truth = graduation_truth(g).harmonics(K) * ARCSEC            # [rad]
    truth[0] = 0.0
    d = _draw_mounting(rng, decl["head_mounting"], method.all_alphas.size)
    n = np.arange(K + 1)
    true_alphas = method.all_alphas + d - d[0]                   # against the reference
    clean = np.exp(1j * np.outer(true_alphas, n)) * truth
    # per head and harmonic [rad]: the curve's u_A from about 0.0005" to 0.03"
    sigma = math.exp(rng.uniform(math.log(2e-5), math.log(5e-3))) * ARCSEC
    solved = []
    for _ in range(revolutions):
        noise = sigma * (rng.normal(size=clean.shape) + 1j * rng.normal(size=clean.shape))
        solved.append(method.solve(clean + noise).graduation)
    curves = synthesize(np.array(solved), POINTS) / ARCSEC        # (R, points) [arcsec]
    mean = curves.mean(axis=0)
    sem = curves.std(axis=0, ddof=1) / math.sqrt(revolutions)
    changes = mounting_changes(lambda s: solution_parts(method.solve(s)), method.all_alphas,
                               {"graduation": np.mean(solved, axis=0)}, method.radius_m)
    sens = mounting_sensitivity(changes) / ARCSEC                   # [arcsec per rad]
    budget = selfcal_budget(float(np.sqrt(np.mean(sem ** 2))), revolutions, 0.0, None,
                            {} if leave_out_mounting else decl, sens)
    j = int(rng.integers(POINTS))
    # as enc report: the mounting's u at the point, sqrt(sum_k c_k(theta)^2) of the heads
    at_point = float(np.sqrt(np.sum(synthesize(changes, POINTS)[:, j] ** 2))) / ARCSEC
    added = math.fsum(c.u_arcsec ** 2 for c in budget.contributions[2:]
                      if c.quantity != "head_mounting")
    if not leave_out_mounting:
        added += (budget.contributions[2].u_arcsec * at_point / sens) ** 2
    error = mean[j] - float(synthesize(truth, POINTS)[j]) / ARCSEC
    return abs(error) <= budget.k * math.sqrt(sem[j] ** 2 + added)


def monte_carlo(runs: int, revolutions: int = 5, seed: int = 0,
                leave_out_mounting: bool = False) -> float:
    """The fraction of ``runs`` self-calibrations whose error at a random point of the
    curve is within the budget's U there. ``leave_out_mounting``: the budget without the
    heads' mounting row, which must cover less."""
    rng = np.random.default_rng(seed)
    rig = load_rig("sjtu-dual")
    enc = next(e for e in rig.encoders if e.name == "II")
    angle = {h.name: h.angle for h in enc.heads}
    method = Method("esa", angle[HEADS[0]], np.array([angle[h] for h in HEADS[1:]]), K,
                    enc.radius_m, list(HEADS))
    decl = declared()
    covered = sum(one_run(rng, method, enc, decl, revolutions, leave_out_mounting)
                  for _ in range(runs))
    return covered / runs


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=2000)
    parser.add_argument("--revolutions", type=int, default=5)
    args = parser.parse_args(argv)
    start = time.perf_counter()
    p = monte_carlo(args.runs, args.revolutions, seed=1)
    without = monte_carlo(args.runs, args.revolutions, seed=1, leave_out_mounting=True)
    ok = report_band("self-calibration budget", p,
                     f"{args.runs} runs of {args.revolutions} revolutions", BAND,
                     f"without the head mounting row {without:.3f}; "
                     f"{time.perf_counter() - start:.1f} s")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
