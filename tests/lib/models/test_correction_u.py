"""The uncertainty of a correction model at any angle (enctools.models.correction_u): its
terms, and its coverage of the true residual between the points a model was fitted to."""

from __future__ import annotations

import math

import numpy as np
import pytest

from enctools.models import fitting
from enctools.models.correction_u import CorrectionU, correction_u, top_octave_rms


def test_top_octave_holds_only_the_orders_from_m_over_4_below_m_over_2():
    """At 24 points: a harmonic of order 8 (in 6..11) counts with its RMS A/sqrt(2); one of
    order 3 (below the octave) does not; the orders are 6 and 12."""
    x = np.arange(24) * 15.0
    y8 = 0.4 * np.cos(np.radians(8 * x) + 0.3)
    band, low, top = top_octave_rms(x, y8)
    assert (low, top) == (6, 12)
    assert band == pytest.approx(0.4 / math.sqrt(2), rel=1e-9)
    assert top_octave_rms(x, 0.4 * np.sin(np.radians(3 * x)))[0] < 1e-12


def test_quantisation_is_half_an_lsb_rectangular():
    """A table of LSB q adds q / sqrt(12) in quadrature; U = 2 u_c."""
    c = CorrectionU(0.3, 0.4, 24, 6, 12).with_lsb(0.1544952392578125)
    assert c.quantisation == pytest.approx(0.1544952392578125 / math.sqrt(12))
    want = 2 * math.sqrt(0.09 + 0.16 + c.quantisation ** 2)
    assert math.isclose(c.U, want, rel_tol=1e-12)
    assert CorrectionU.from_meta(c.to_meta()) == CorrectionU(0.3, 0.4, 24, 6, 12)


def _truth(rng: np.random.Generator, n_max: int = 48) -> tuple[np.ndarray, np.ndarray]:
    """A graduation error [arcsec]: orders 1..n_max, amplitudes ~ 2.5 n^-1.5 (times a
    factor 0.5..1.5), random phases."""
    n = np.arange(1, n_max + 1)
    amp = 2.5 * n ** -1.5 * rng.uniform(0.5, 1.5, n.size)
    return n, amp * np.exp(1j * rng.uniform(0, 2 * np.pi, n.size))


def _eval(n: np.ndarray, c: np.ndarray, x_deg: np.ndarray) -> np.ndarray:
    return np.real(np.exp(1j * np.outer(np.radians(x_deg), n)) @ c)


@pytest.mark.heavy
def test_u_covers_the_true_residual_between_the_points():
    """24 points every 15 deg (noise 0.02") of 24 truths with orders up to 48: the model's
    true residual at 3600 angles (about its mean: the datum is the encoder's zero) lies
    within U = 2 u_c at 95-100 % of them pooled, at >= 85 % for every truth; the
    held-out term alone (no band limit) leaves truths well below that."""
    rng = np.random.default_rng(41)
    dense = np.arange(3600) * 0.1
    pooled, alone, worst = [], [], 1.0
    for _ in range(24):
        n, c = _truth(rng)
        x = np.arange(24) * 15.0 + 3.0
        y = _eval(n, c, x) + rng.normal(0.0, 0.02, x.size)
        fit = fitting.fit_points(x, y, fitting.Settings())
        cu = fit.correction_u
        assert cu is not None and cu.quantisation is None
        r = _eval(n, c, dense) - fit.model(dense)
        r -= r.mean()
        inside = np.abs(r) <= cu.U
        pooled.append(inside.mean())
        alone.append(np.mean(np.abs(r) <= 2 * cu.held_out))
        worst = min(worst, float(inside.mean()))
    assert 0.95 <= float(np.mean(pooled)) <= 1.0
    assert worst >= 0.85
    assert min(alone) < worst


def test_too_few_points_state_none():
    """Below 8 points no octave is resolved to bound the tail with: no U."""
    assert correction_u(np.arange(6) * 60.0, np.zeros(6), np.zeros(6)) is None
