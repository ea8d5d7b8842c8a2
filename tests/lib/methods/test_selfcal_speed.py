"""What enc selfcal pays per revolution and at start-up, with the same answers (issue 35).

- methods.budget.coverage_factor: Student's k and the normal quantile (to 1e-12), without
  importing scipy.stats or scipy.special (0.5 s and 0.14-0.35 s of CPU at every start of a
  command that states a coverage).
- methods.selfcal_uncertainty.SampleRepeats: the share of a revolution's positions
  sampled in the first revolution, by a binary search in the first's sorted positions,
  equal to np.isin's (which sorted or hashed both arrays at every revolution).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np

from enctools.methods.revolutions import Revolution
from enctools.methods.selfcal_uncertainty import SampleRepeats, _among
from enctools.units import TWO_PI

PROBE = ("import json, math, sys\n"
         "from enctools.methods.budget import coverage_factor\n"
         "ks = [coverage_factor(nu, p) for nu in (1.0, 2.5, 5.0, 299.0, math.inf)\n"
         "      for p in (0.6827, 0.95, 0.9973)]\n"
         "print(json.dumps({'k': ks, 'scipy': sorted(m for m in sys.modules\n"
         "                                        if m in ('scipy.stats', 'scipy.special'))}))")


def test_coverage_factor_is_students_quantile_without_importing_scipy_stats() -> None:
    """k is Student's quantile (norm's at infinite dof) to 1e-12, by the inverse incomplete
    beta function (test_budget.t_quantile), and a process that asks for it has imported
    neither scipy.stats nor scipy.special."""
    from scipy.special import ndtri
    from test_budget import t_quantile

    r = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True,
                       check=True)
    got = json.loads(r.stdout)
    want = [float(ndtri(0.5 + p / 2)) if math.isinf(nu) else t_quantile(0.5 + p / 2, nu)
            for nu in (1.0, 2.5, 5.0, 299.0, math.inf) for p in (0.6827, 0.95, 0.9973)]
    np.testing.assert_allclose(got["k"], want, rtol=1e-12, atol=0)
    assert got["scipy"] == []


def test_among_is_isin() -> None:
    """_among answers as np.isin for values with repeats, outside, none, and an empty set."""
    rng = np.random.default_rng(7)
    for _ in range(300):
        values = rng.integers(-40, 40, rng.integers(0, 60))
        ordered = np.unique(rng.integers(-40, 40, rng.integers(0, 60)))
        np.testing.assert_array_equal(_among(values, ordered), np.isin(values, ordered))


def test_sample_repeats_share_as_isin() -> None:
    """The share of each revolution's positions met in the first is np.isin's mean: a
    revolution partly on the first's counts, one off them, one with a sample only."""
    quantum = TWO_PI / 2 ** 20
    rng = np.random.default_rng(3)
    first = np.sort(rng.integers(0, 2 ** 20, 4000))
    revs = [first, np.sort(np.concatenate([first[:1500], rng.integers(0, 2 ** 20, 2500)])),
            first + 1, first[:1]]
    repeats = SampleRepeats(quantum)
    for i, counts in enumerate(revs):
        start = i * TWO_PI
        u = np.concatenate([start + counts * quantum, [start + TWO_PI]])
        repeats.add(Revolution(i, start, u, np.zeros((1, u.size))))
    want = [float(np.mean(np.isin(c, np.unique(first)))) for c in revs[1:]]
    assert repeats._shares == want
