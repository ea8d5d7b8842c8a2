"""The harmonic core: per-revolution spectra from jittered samples, revolution cutting,
synthesis and analysis, bin averages, stroboscopic sampling. Tolerances in the tests."""

from __future__ import annotations

import numpy as np

from enctools.data.readings import HeadInfo, head_reading
from enctools.methods.harmonics import (
    analyse,
    bin_average,
    revolution_coefficients,
    synthesize,
)
from enctools.methods.revolutions import RevolutionSplitter
from enctools.methods.stroboscopic import stroboscopic_heads

TWO_PI = 2 * np.pi


def series(rng: np.random.Generator, kmax: int) -> np.ndarray:
    c = (rng.normal(size=kmax + 1) + 1j * rng.normal(size=kmax + 1)) / (1 + np.arange(kmax + 1))
    c[0] = c[0].real
    return c


def evaluate(c: np.ndarray, u: np.ndarray) -> np.ndarray:
    return np.real(np.exp(1j * np.outer(u, np.arange(c.size))) @ c)


def test_coefficients_from_jittered_samples() -> None:
    """Nearly uniform, jittered samples over one turn: c_n to 1e-8 of the largest."""
    rng = np.random.default_rng(1)
    c = series(rng, 100)
    s = 20000
    k = np.arange(s + 1)
    jitter = 2e-5 * np.sin(3 * TWO_PI * k / s) + 4e-6 * np.sin(42 * TWO_PI * k / s)
    u = 0.3 + k * TWO_PI / s + jitter
    u[-1] = 0.3 + TWO_PI
    got = revolution_coefficients(u, evaluate(c, u)[None, :], 0.3, 100)[0]
    assert np.max(np.abs(got - c)) < 1e-8 * np.max(np.abs(c))


def test_backwards_revolution() -> None:
    rng = np.random.default_rng(2)
    c = series(rng, 20)
    u = 1.0 - np.linspace(0, TWO_PI, 3001)
    got = revolution_coefficients(u, evaluate(c, u)[None, :], 1.0, 20)[0]
    assert np.max(np.abs(got - c)) < 1e-10


def test_splitter_blocks_do_not_matter() -> None:
    """Revolutions cut from small blocks equal those cut from one block; ends exact."""
    rng = np.random.default_rng(3)
    c = series(rng, 10)
    u = np.cumsum(rng.uniform(0.5, 1.5, 12000)) * (TWO_PI / 3000)
    v = evaluate(c, u)[None, :]
    whole = list(RevolutionSplitter().feed(u, v))
    split = RevolutionSplitter()
    parts = []
    for i in range(0, u.size, 777):
        parts += list(split.feed(u[i:i + 777], v[:, i:i + 777]))
    assert len(whole) == len(parts) == int((u[-1] - u[0]) // TWO_PI)
    for a, b in zip(whole, parts, strict=True):
        np.testing.assert_allclose(a.u, b.u)
        np.testing.assert_allclose(a.values, b.values)
        assert a.u[-1] - a.u[0] == TWO_PI or abs(a.u[-1] - a.u[0] - TWO_PI) < 1e-12
        got = revolution_coefficients(a.u, a.values, a.start, 10)[0]
        assert np.max(np.abs(got - c)) < 1e-5  # linear interpolation at the ends only


def test_close_fills_a_one_sample_gap() -> None:
    """A run of N turns from t = 0 lacks its last sample: close() completes turn N."""
    s = 1000
    u = np.arange(2 * s) * (TWO_PI / s)
    v = np.cos(3 * u)[None, :]
    sp = RevolutionSplitter()
    revs = list(sp.feed(u, v))
    assert len(revs) == 1
    last = sp.close(2.5 * TWO_PI / s)
    assert last is not None and last.index == 1
    got = revolution_coefficients(last.u, last.values, last.start, 5)[0]
    assert abs(got[3] - 1) < 1e-12
    assert RevolutionSplitter().close(0.1) is None


def test_synthesize_analyse_roundtrip() -> None:
    rng = np.random.default_rng(4)
    c = series(rng, 30)
    y = synthesize(c, 128)
    np.testing.assert_allclose(y, evaluate(c, np.arange(128) * TWO_PI / 128), atol=1e-12)
    np.testing.assert_allclose(analyse(y, 30), c, atol=1e-12)


def test_bin_average() -> None:
    u = np.linspace(0, TWO_PI, 10000, endpoint=False) + 7 * TWO_PI
    out = bin_average(u, np.sin(u)[None, :], 100)
    centres = (np.arange(100) + 0.5) * TWO_PI / 100
    assert np.max(np.abs(out[0] - np.sin(centres))) < 1e-3
    assert np.isnan(bin_average(np.array([0.1]), np.array([[1.0]]), 4)[0, 2])


def test_head_reading_removes_zeroing() -> None:
    cpr = 52000 * 4096
    alpha = np.radians(60.0)
    zero = round(float(alpha * 52000 / TWO_PI)) * 4096
    theta = 0.25
    counts = np.rint((theta + alpha) * cpr / TWO_PI) - zero
    assert abs(head_reading(np.array([counts]), cpr, zero, alpha)[0] - theta) < TWO_PI / cpr


def test_stroboscopic_sampling_detected() -> None:
    """3 ms at 1 r/min is 0.018 deg: exactly 9 periods of the ERP 880, 2.6 of the ERA 4282."""
    step = np.radians(0.018)
    p1 = HeadInfo("P1", "I", 0.0, 180000 * 4096, 180000, 4096, 0.063, 0)
    h1 = HeadInfo("H1", "II", 0.0, 52000 * 4096, 52000, 4096, 0.1657, 0)
    bad = stroboscopic_heads(step, (p1, h1))
    assert [b[0] for b in bad] == ["P1"] and abs(bad[0][1] - 9) < 1e-9
