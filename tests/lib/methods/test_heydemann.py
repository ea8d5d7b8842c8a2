"""The Heydemann ellipse fit (seed 001 sec. 5.2 signal quality): exactness, honest
uncertainties, partial arcs that give a right result or a clear error."""

from __future__ import annotations

import numpy as np
import pytest

from enctools.data.truth import SignalFaults, interpolation_error, signal_phase_error
from enctools.errors import DataError
from enctools.methods import heydemann as hd
from enctools.units import DEG, TWO_PI

TRUE = np.array([0.1, -0.05, 1.0, 0.9, 0.1])  # offset_cos, offset_sin, amplitude, ratio, phase


def signals(phi: np.ndarray, noise: float = 0.0, rng=None) -> tuple[np.ndarray, np.ndarray]:
    i = 0.1 + np.cos(phi)
    q = -0.05 + 0.9 * np.sin(phi + 0.1)
    if noise:
        i = i + rng.normal(0, noise, phi.size)
        q = q + rng.normal(0, noise, phi.size)
    return i, q


def test_noise_free_two_periods_exact():
    phi = np.linspace(0, 2 * TWO_PI, 500, endpoint=False)
    fit = hd.fit_ellipse(*signals(phi))
    assert np.abs(fit.params - TRUE).max() < 1e-9
    assert fit.noise < 1e-12 and fit.arc == pytest.approx(TWO_PI, abs=0.1)
    assert fit.warnings == []
    # the corrected phase is the true phase
    back = hd.corrected_phase(*signals(phi), *fit.params)
    assert np.abs(np.angle(np.exp(1j * (back - phi)))).max() < 1e-9


def test_predicted_error_follows_the_truth_convention():
    phi = np.linspace(0, TWO_PI, 200, endpoint=False)
    fit = hd.fit_ellipse(*signals(phi))
    faults = SignalFaults(**fit.relative_faults())
    assert faults.ratio == pytest.approx(0.9) and faults.offset_cos == pytest.approx(0.1)
    scale = np.linspace(0, 1e-3, 77)
    want = interpolation_error(faults, scale, 52000)
    got = hd.interpolation_error(fit, np.mod(scale, TWO_PI) * 52000, 52000)
    assert np.abs(got - want).max() < 1e-9
    # read-phase form: e(phi) looked up at phi + e(phi)
    e = hd.phase_error(fit, phi)
    assert np.abs(hd.read_phase_error(fit, phi + e) - e).max() < 1e-10
    assert np.abs(signal_phase_error(faults, phi) - e).max() < 1e-12


@pytest.mark.heavy
def test_noisy_estimates_within_stated_uncertainty():
    rng = np.random.default_rng(11)
    z = []
    for _ in range(150):
        phi = rng.uniform(0, TWO_PI) + np.linspace(0, TWO_PI, 300, endpoint=False)
        fit = hd.fit_ellipse(*signals(phi, 0.01, rng))
        u = np.array([fit.u[k] for k in hd.PARAMS])
        z.append((fit.params - TRUE) / u)
        assert fit.noise == pytest.approx(0.01, rel=0.2)
    z = np.array(z)
    assert np.abs(z).max() < 4.5
    assert np.all((z.std(axis=0) > 0.8) & (z.std(axis=0) < 1.25))


@pytest.mark.parametrize("arc_deg", [120, 180, 300])
def test_partial_arc_noise_free_is_exact(arc_deg):
    phi = 0.7 + np.linspace(0, arc_deg * DEG, 200)
    fit = hd.fit_ellipse(*signals(phi))
    assert np.abs(fit.params - TRUE).max() < 1e-8
    assert (len(fit.warnings) == 1) == (arc_deg < 270)


@pytest.mark.parametrize("arc_deg", [30, 60])
def test_short_arc_is_a_clear_error(arc_deg):
    phi = np.linspace(0, arc_deg * DEG, 200)
    with pytest.raises(DataError, match=r"cover .* deg of the Lissajous ellipse"):
        hd.fit_ellipse(*signals(phi))


@pytest.mark.slow
def test_partial_arcs_never_silently_wrong():
    """Noisy arcs of 60-300 deg: each fit is refused or within 5 stated u."""
    rng = np.random.default_rng(5)
    outcomes = {"refused": 0, "fitted": 0}
    for arc in (60, 90, 100, 120, 150, 200, 300):
        for noise in (0.003, 0.01, 0.03):
            for _ in range(12):
                phi = rng.uniform(0, TWO_PI) + np.linspace(0, arc * DEG, 200)
                try:
                    fit = hd.fit_ellipse(*signals(phi, noise, rng))
                except DataError as exc:
                    assert "\n" not in str(exc)
                    outcomes["refused"] += 1
                    continue
                outcomes["fitted"] += 1
                u = np.array([fit.u[k] for k in hd.PARAMS])
                assert np.all(np.abs(fit.params - TRUE) < 5 * u), (arc, noise)
    assert outcomes["refused"] > 20 and outcomes["fitted"] > 100


def test_four_phase_signals():
    phi = np.linspace(0, TWO_PI, 300, endpoint=False)
    s0, s180 = 2.0 + 0.55 * np.cos(phi), 2.0 - 0.45 * np.cos(phi) - 0.1
    s90 = 2.0 + 0.5 * 0.9 * np.sin(phi + 0.1) - 0.05
    s270 = 2.0 - 0.5 * 0.9 * np.sin(phi + 0.1)
    i, q = hd.from_four_phase(s0, s90, s180, s270)
    fit = hd.fit_ellipse(i, q)
    assert fit.params == pytest.approx([0.1, -0.05, 1.0, 0.9, 0.1], abs=1e-9)


def test_radius_variation_and_bad_input():
    phi = np.linspace(0, TWO_PI, 400, endpoint=False)
    assert hd.radius_variation(np.cos(phi), np.sin(phi))["variation"] < 1e-12
    assert hd.radius_variation(*signals(phi))["variation"] > 0.2
    with pytest.raises(DataError, match="at least 8"):
        hd.fit_ellipse([1, 2, 3], [1, 2, 3])
    line = np.linspace(0, 1, 50)
    with pytest.raises(DataError):
        hd.fit_ellipse(line, 2 * line + 1)
    with pytest.raises(DataError, match="differ in length"):
        hd.fit_ellipse(np.ones(10), np.ones(11))
    u = hd.interpolation_error_u(hd.fit_ellipse(*signals(phi, 0.01, np.random.default_rng(1))),
                                 phi, 52000)
    assert np.all(u > 0) and np.all(u < 0.01)
