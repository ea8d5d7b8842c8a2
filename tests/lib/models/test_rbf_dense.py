"""enc fit-rbf's default network against a reference written here: the seed's 24 points,
the real MagAlpha tables and dense tables fitted by blocks (enctools.models.rbfdense).

The reference is the straightforward one: the whole design matrix of seed 001 eq. (6)
(the chord distance), centred; for each spread and smoothing the ridge least squares by
an augmented QR ``[P Phi; sqrt(lambda) I]`` (no SVD, no closed form of enctools), the hat
matrix's diagonal from that QR's Q, the leave-one-out residual ``r_i / (1 - H_ii)``, and
the blocked hold-out by refitting without each 15-deg block. The search keeps the pair of
the smallest RMS leave-one-out residual (a tie: within 1e-9 of it), never one whose
weights exceed 1296000 arcsec, as enc-fit-rbf(1) describes it.

Tolerance: the model evaluated on a 0.01-deg grid, the leave-one-out and the blocked
residuals equal the reference's to 1e-8 of the deviations' largest magnitude; the spread
and the smoothing equal exactly.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import DATA

from enctools.data.usertables import read
from enctools.methods.points import distinct, points_from_table
from enctools.models import fitting, rbf, rbfdense
from enctools.models.rbf import choose_network

DEG = np.pi / 180.0
ARCSEC = DEG / 3600.0
SPREAD_FACTOR = 0.8326            # seed 001 eq. (6)
STEPS = 2.0 ** np.arange(-1.0, 5.01, 0.5)    # spreads: centre spacings (enc-fit-rbf(1))
SMOOTHINGS = 10.0 ** np.arange(-12.0, 0.01, 0.5)
MAX_WEIGHT = 1296000.0
TOL = 1e-8                        # of the deviations' largest magnitude
MAGALPHA = Path(__file__).resolve().parents[4] / "shared" / "data" / "magalpha"
REAL = sorted(MAGALPHA.glob("*.csv")) if MAGALPHA.is_dir() else []


# ------------------------------------------------------------------ the reference

def units(x_deg: np.ndarray, centres_deg: np.ndarray, spread_deg: float) -> np.ndarray:
    chord = 2.0 * np.abs(np.sin((x_deg[:, None] - centres_deg[None, :]) * DEG / 2.0))
    width = 2.0 * np.sin(min(spread_deg, 359.999) * DEG / 2.0)
    return np.exp(-SPREAD_FACTOR ** 2 * chord ** 2 / width ** 2)


def largest_squared(phi: np.ndarray) -> float:
    """The largest squared singular value of the centred design."""
    return float(np.linalg.norm(phi - phi.mean(axis=0), 2) ** 2)


class Ridge:
    """min |y - b - Phi w|^2 + lambda |w|^2, lambda = smoothing x the largest squared
    singular value of the centred design, by the complete QR of the augmented system
    ``A = [1 Phi; 0 sqrt(lambda) I]``: the residuals are the projection of ``[y; 0]`` on
    the columns of Q past A's, and 1 - H_ii the squared norm of row i there (a sum of
    squares: accurate where the network nearly interpolates)."""

    def __init__(self, x, y, centres, spread, smoothing, phi=None):
        phi = units(x, centres, spread) if phi is None else phi
        lam = smoothing * largest_squared(phi)
        n, m = phi.shape
        a = np.zeros((n + m, m + 1))
        a[:n, 0], a[:n, 1:], a[n:, 1:] = 1.0, phi, np.sqrt(lam) * np.eye(m)
        b = np.r_[y, np.zeros(m)]
        q, r = np.linalg.qr(a, mode="complete")
        coef = np.linalg.solve(r[:m + 1], (q.T @ b)[:m + 1])
        self.bias, self.w = coef[0], coef[1:]
        self.centres, self.spread = centres, spread
        outside = q[:, m + 1:]
        self.resid = (outside @ (outside.T @ b))[:n]
        self.loo = self.resid / np.sum(outside[:n] ** 2, axis=1)

    def __call__(self, x):
        return self.bias + units(x, self.centres, self.spread) @ self.w


def centres_of(n: int, most: int = 256) -> np.ndarray:
    m = min(n, most)
    return np.arange(m) * (360.0 / m)


def spreads_of(n: int, most: int = 256) -> list[float]:
    spacing = 360.0 / min(n, most)
    return sorted({min(float(f) * spacing, 180.0) for f in STEPS})


def search(x, y, spreads, centres):
    """(spread, smoothing) of the smallest RMS leave-one-out residual."""
    best = None
    for spread in spreads:
        phi = units(x, centres, spread)
        for smoothing in SMOOTHINGS:
            fit = Ridge(x, y, centres, spread, smoothing, phi)
            if np.max(np.abs(fit.w)) > MAX_WEIGHT:
                continue
            rms = np.sqrt(np.mean(fit.loo ** 2))
            if np.isfinite(rms) and (best is None or rms < best[0] * (1 - 1e-9)):
                best = (rms, spread, float(smoothing))
    return best[1], best[2]


def blocked(x, y, centres, spread, smoothing):
    """Each point predicted by the network refitted without its 15-deg block."""
    block = np.floor(np.mod(x / 15.0 + 0.5, 24)).astype(int)
    out = np.empty(x.size)
    for k in np.unique(block):
        held = block == k
        fit = Ridge(x[~held], y[~held], centres, spread, smoothing)
        out[held] = y[held] - fit(x[held])
    return out


def assert_same_model(model, ref, y):
    scale = np.max(np.abs(y))
    grid = np.arange(0.0, 360.0, 0.01)
    assert np.max(np.abs(model(grid) - ref(grid))) < TOL * scale


# ------------------------------------------------------------------ tables

def seed_table1():
    return distinct(points_from_table(read(str(DATA / "seed001_table1.csv")))[0])[:2]


def magalpha(path: Path):
    rows = np.loadtxt(path, delimiter=",", skiprows=1)
    diff = (rows[:, 1] - rows[:, 0]) * DEG
    diff = np.angle(np.exp(1j * (diff - np.angle(np.mean(np.exp(1j * diff))))))
    return np.mod(rows[:, 1], 360.0), diff / ARCSEC


def dense(n: int, seed: int = 3):
    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(0.0, 360.0, n))
    r = x * DEG
    y = 1.5 * np.sin(r + 0.3) + 0.8 * np.sin(2 * r + 1.1) + 0.3 * np.sin(24 * r)
    return x, y + rng.normal(0.0, 0.2, n)


def check_search(x, y):
    """fit-rbf's default network on all points equals the reference search."""
    fit = fitting.fit_points(x, y, fitting.Settings())
    spread, smoothing = search(x, y, spreads_of(x.size), centres_of(x.size))
    assert (fit.model.spread_deg, fit.choice["smoothing"]) == (spread, smoothing)
    ref = Ridge(x, y, centres_of(x.size), spread, smoothing)
    assert_same_model(fit.model, ref, y)
    _, choice = choose_network(x, y)
    assert np.max(np.abs(choice.loo - ref.loo)) < TOL * np.max(np.abs(y))


def test_seed_table1_is_the_reference_network():
    check_search(*seed_table1())


@pytest.mark.slow
@pytest.mark.skipif(not REAL, reason="../shared/data/magalpha is not beside the clone")
@pytest.mark.parametrize("path", REAL, ids=[p.stem for p in REAL])
def test_real_tables_are_the_reference_network(path):
    check_search(*magalpha(path))


# ------------------------------------------------------------------ by blocks

#: units of the scaled-down dense tables
UNITS = 24


@pytest.fixture
def small_blocks(monkeypatch):
    """A dense table's code at a size the reference searches quickly: 24 units, the
    spread on 100 points, blocks of 64 points (many blocks, cut at the 15-deg blocks
    too)."""
    monkeypatch.setattr(rbf, "MAX_UNITS", UNITS)
    monkeypatch.setattr(rbfdense, "SEARCH_POINTS", 100)
    monkeypatch.setattr(fitting, "SEARCH_POINTS", 100)
    monkeypatch.setattr(rbfdense, "BLOCK", 64)


def even_subset(x: np.ndarray, most: int) -> np.ndarray:
    order = np.argsort(x, kind="stable")
    return order[np.floor(np.arange(most) * (x.size / most)).astype(int)]


@pytest.mark.heavy
def test_dense_table_by_blocks_is_the_reference(small_blocks):
    """The spread by the reference search on the even subset, the smoothing by the
    reference over every point at that spread; the model, its leave-one-out residuals
    and its blocked hold-out as the reference's."""
    x, y = dense(700)
    centres = centres_of(x.size, UNITS)
    pick = even_subset(x, 100)
    spread, _ = search(x[pick], y[pick], spreads_of(x.size, UNITS), centres)
    _, smoothing = search(x, y, [spread], centres)
    fit = fitting.fit_points(x, y, fitting.Settings())
    assert (fit.model.spread_deg, fit.choice["smoothing"]) == (spread, smoothing)
    assert "the spread on an even 100 of the 700 points" in fit.choice["selection"]
    ref = Ridge(x, y, centres, spread, smoothing)
    assert_same_model(fit.model, ref, y)
    scale = np.max(np.abs(y))
    d = rbfdense.choose_dense(x, y)
    assert np.max(np.abs(d.choice.loo - ref.loo)) < TOL * scale
    assert np.max(np.abs(d.blocked - blocked(x, y, centres, spread, smoothing))) < TOL * scale
    assert fit.gain is not None and fit.gain.model.blocked_rms == pytest.approx(
        np.sqrt(np.mean(d.blocked ** 2)), rel=1e-12)


def test_dense_table_with_a_spread_given(small_blocks):
    x, y = dense(500, seed=4)
    x = x[::-1].copy()                 # any order in, the residuals in that order out
    y = y[::-1].copy()
    centres = centres_of(x.size, UNITS)
    _, smoothing = search(x, y, [7.5], centres)
    d = rbfdense.choose_dense(x, y, spread_deg=7.5)
    assert (d.model.spread_deg, d.choice.smoothing) == (7.5, smoothing)
    ref = Ridge(x, y, centres, 7.5, smoothing)
    assert_same_model(d.model, ref, y)
    assert np.max(np.abs(d.choice.loo - ref.loo)) < TOL * np.max(np.abs(y))


@pytest.mark.slow
def test_dense_and_whole_searches_agree_where_both_run():
    """Above SEARCH_POINTS the spread is searched on a subset: on this table the subset
    finds the spread and smoothing the search over every point finds."""
    x, y = dense(3000)
    whole, choice = choose_network(x, y)
    d = rbfdense.choose_dense(x, y)
    assert (d.choice.spread_deg, d.choice.smoothing) == (choice.spread_deg, choice.smoothing)
    grid = np.arange(0.0, 360.0, 0.01)
    assert np.max(np.abs(d.model(grid) - whole(grid))) < TOL * np.max(np.abs(y))
    assert np.max(np.abs(d.choice.loo - choice.loo)) < TOL * np.max(np.abs(y))


def test_a_block_factor_leaves_out_the_units_negligible_there():
    """A 15-deg block at a 7.5-deg spread of 24 units 15 deg apart: the units further
    than about 8 spreads give outputs below 1e-20 at every point and are left out of
    the block's R (its columns 0); R^T R is still the Gram of the block's columns
    [1, Phi, y] to rounding, and the R of the ones column comes first (row echelon)."""
    x = np.sort(np.random.default_rng(6).uniform(-7.5, 7.5, 300)) % 360.0
    y = np.sin(x * DEG * 3)
    centres = centres_of(24, UNITS)
    part = rbfdense._Part.empty(UNITS)
    phi = part.add(rbfdense._Units(centres, 7.5), x, y)
    kept = np.any(part.r, axis=0)[1:UNITS + 1]
    assert 0 < kept.sum() < UNITS // 2
    assert np.max(phi[:, ~kept]) < rbfdense.NEGLIGIBLE
    a = np.column_stack([np.ones(x.size), phi, y])
    gram = a.T @ a
    assert np.max(np.abs(part.r.T @ part.r - gram)) < 1e-12 * np.max(np.abs(gram))
    assert np.all(part.r[1:, 0] == 0.0)


def test_leave_one_out_kept_from_the_scoring_pass_equals_a_last_pass(small_blocks, monkeypatch):
    """Up to KEEP_LOO_POINTS points the scoring pass keeps every smoothing's leave-one-out
    residuals and the chosen one's are taken from there; above, the last pass computes
    them again: the same residuals, blocked hold-out and training sum of squares."""
    x, y = dense(700)
    kept = rbfdense.choose_dense(x, y)
    monkeypatch.setattr(rbfdense, "KEEP_LOO_POINTS", 0)
    again = rbfdense.choose_dense(x, y)
    scale = np.max(np.abs(y))
    assert np.max(np.abs(kept.choice.loo - again.choice.loo)) < 1e-12 * scale
    assert np.array_equal(kept.blocked, again.blocked)
    assert kept.model.sse == pytest.approx(again.model.sse, rel=1e-12)
    assert np.array_equal(kept.model.weights, again.model.weights)


@pytest.mark.parametrize("spread", [0.703125, 2.8125, 45.0])
def test_search_factor_by_runs_is_the_one_qr(spread):
    """The search's subset (2048 points, 256 units) at a narrow spread is factored by
    runs of 256 points over the units each uses, their R stacked: the centred design's
    singular values and every smoothing's leave-one-out residuals equal those of one QR
    of every point's columns (at a wide spread that one QR is taken, bit for bit)."""
    x, y = dense(20000, seed=7)
    pick = rbfdense._even_subset(x, 2048)
    xs, ys = x[pick], y[pick]
    units = rbfdense._Units(centres_of(256), spread)
    runs, phi = rbfdense._subset_part(units, xs, ys)
    one = rbfdense._Part.empty(256)
    one.add(units, xs, ys)
    scores = []
    for part in (runs, one):
        sol = rbfdense._Solution(part, 256)
        res, one_minus_h = sol.residuals(phi, ys, rbfdense.SMOOTHING)
        scores.append((sol.s, res / one_minus_h))
    (s_runs, loo_runs), (s_one, loo_one) = scores
    assert np.max(np.abs(s_runs - s_one)) < 1e-12 * s_one[0]
    assert np.max(np.abs(loo_runs - loo_one)) < 1e-9 * np.max(np.abs(y))
    assert (spread < 3) == (not np.array_equal(runs.r, one.r))
