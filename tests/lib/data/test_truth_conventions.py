"""The simulator's ground truth follows the conventions its text states (the docstring
of enctools.data.truth), and the tests that score enc interp-check read it that way.

The text's interpolation-error convention is re-implemented here from the words alone:
psi is interpolation_error of the true scale angle s under the head; the head reads
r = s + psi; a method sees psi as a function of r. Each step is checked against the
code that makes or evaluates it: the simulator's noise-free readings, and
:func:`enctools.data.truth.interpolation_error_read`, by which every interp-check test
(``read_phase_truth``) and benchmarks/accuracy.py score a result (its fixed-point
iteration is one way to do what the text says; here the map s -> r is tabulated
forward and inverted by interpolation, another).
"""

from __future__ import annotations

import numpy as np
import pytest

import enctools.data.truth as truth_module
from enctools.data.rig import load_rig
from enctools.data.truth import interpolation_error, interpolation_error_read
from enctools.hw.sim import VirtualRig
from enctools.hw.sim_truth import make_truth
from enctools.units import ARCSEC, TWO_PI

RIG = load_rig("sjtu-dual")
TRUTH = make_truth(RIG)


def test_the_text_says_what_is_checked_here() -> None:
    """The sentences this file follows are the module's (a change to one is seen here)."""
    text = " ".join(truth_module.__doc__.split())
    for said in ("is :func:`interpolation_error` of the true scale angle under the head, "
                 "s = theta + alpha + eps(theta + alpha) + (x sin alpha - y cos alpha) / R",
                 "The head then reads r = s + psi",
                 "psi(s) at the s with s + psi(s) = r, not interpolation_error at r itself"):
        assert said in text


@pytest.mark.parametrize("head", ["P1", "H4", "H7"])
def test_simulated_readings_are_the_scale_angle_plus_psi(head: str) -> None:
    """r - alpha, the simulator's noise-free reading, is s - alpha + psi(s), with s and psi
    as the text defines them from the truth alone (to 1e-6", the simulator's tabulated
    graduation error)."""
    sim = VirtualRig(RIG, seed=3)
    truth = sim._truth
    enc = next(e for e, h in RIG.heads if h.name == head)
    k = [h.name for h in enc.heads].index(head)
    alpha = enc.heads[k].angle
    theta = np.random.default_rng(4).uniform(0, TWO_PI, 1000)
    x, y = truth.radial[enc.name]["x"](theta), truth.radial[enc.name]["y"](theta)
    s = (theta + alpha + truth.graduation[enc.name](theta + alpha) * ARCSEC
         + (x * np.sin(alpha) - y * np.cos(alpha)) * 1e-9 / enc.radius_m)
    psi = interpolation_error(truth.signals[head], s, enc.periods_per_rev)
    reading, _phase = sim.head_reading(enc, k, theta, noise=False)
    assert np.abs((reading + alpha - s) / ARCSEC - psi).max() < 1e-6
    assert np.ptp(psi) > 0.05  # the check is not empty


@pytest.mark.parametrize("head", [h.name for _, h in RIG.heads])
def test_interp_check_is_scored_as_the_text_says(head: str) -> None:
    """psi as a function of the read angle, following the text (tabulate s -> (s + psi,
    psi) over a period and interpolate at r), equals ``interpolation_error_read`` to 1e-9";
    interpolation_error at r itself does not (what the text once said: up to 0.0115")."""
    enc = next(e for e, h in RIG.heads if h.name == head)
    ppr = enc.periods_per_rev
    faults = TRUTH.signals[head]
    period = TWO_PI / ppr
    s = np.linspace(-0.1 * period, 1.1 * period, 120_001)  # the period and a margin
    psi = interpolation_error(faults, s, ppr)
    r_of_s = s + psi * ARCSEC
    assert np.all(np.diff(r_of_s) > 0)  # one s for each r: "the s with s + psi(s) = r"
    r = np.linspace(0.0, period, 997, endpoint=False)
    by_text = np.interp(r, r_of_s, psi)
    by_tests = interpolation_error_read(faults, r * ppr, ppr)
    assert np.abs(by_text - by_tests).max() < 1e-9
    at_r = interpolation_error(faults, r, ppr)
    assert np.abs(at_r - by_tests).max() > 2e-4  # the other reading is measurably wrong


class _Forgetful(VirtualRig):
    """The simulator working out every held reading and every settled angle afresh."""

    def _held_truth(self, enc, shape):  # type: ignore[no-untyped-def]
        self._held_cache = {}
        return super()._held_truth(enc, shape)

    def settled(self, angle: float) -> float:
        self._settled = {}
        return super().settled(angle)


@pytest.mark.heavy
@pytest.mark.parametrize("rig", ["ciomp-23bit", "sjtu-dual"])
def test_what_the_simulator_remembers_is_what_it_would_work_out(rig: str) -> None:
    """A held position's truth and the angle settled at for a target are remembered; the
    counts equal those of a simulator that remembers nothing, bit for bit, through runs
    that return to their positions and a block sampled in between (which may tabulate the
    truth, so that what was remembered must be worked out anew)."""
    r = load_rig(rig)
    sims = VirtualRig(r, seed=5), _Forgetful(r, seed=5)
    got: list[list[np.ndarray]] = [[], []]
    targets = np.radians([0.0, 15.0, 200.0, 15.0, 0.0, 15.0])
    for k, sim in enumerate(sims):
        for n, angle in enumerate(targets):
            sim.axis.move_to(float(angle))
            for _ in range(3):
                got[k] += list(sim.counter.read_now().values())
            if n == 2:  # a block between the runs
                sim.counter.start(1e-3)
                got[k] += list(sim.counter.read_block(50_000).values())
                sim.counter.stop()
                sim.axis.move_to(float(angle))
    assert len(got[0]) == len(got[1]) > 0
    for a, b in zip(*got, strict=True):
        assert np.array_equal(a, b)
    assert sims[0]._settled and sims[0]._held_cache  # the remembering did happen
