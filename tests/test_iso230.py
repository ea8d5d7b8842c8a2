"""ISO 230-2 figures against an independent computation on a synthetic 5-run set."""

from __future__ import annotations

import numpy as np
import pytest

from enctools.errors import DataError
from enctools.report.iso230 import iso230_2

POSITIONS = np.arange(0.0, 360.0, 30.0)          # 12 targets [deg]
RUNS = 5


def _dataset(seed: int = 7):
    """5 bidirectional runs with known per-position means and scatters [arcsec]."""
    rng = np.random.default_rng(seed)
    m = POSITIONS.size
    mean_up = 1.5 * np.sin(np.radians(2 * POSITIONS)) + 0.3
    mean_dn = mean_up - 0.4 - 0.2 * np.cos(np.radians(POSITIONS))   # reversal B_i
    s_up = 0.05 + 0.1 * rng.random(m)
    s_dn = 0.05 + 0.1 * rng.random(m)
    pos, dev, direction = [], [], []
    for _ in range(RUNS):
        for i in range(m):
            pos.append(POSITIONS[i])
            dev.append(mean_up[i] + s_up[i] * rng.standard_normal())
            direction.append(1)
        for i in reversed(range(m)):
            pos.append(POSITIONS[i])
            dev.append(mean_dn[i] + s_dn[i] * rng.standard_normal())
            direction.append(-1)
    return np.array(pos), np.array(dev), np.array(direction)


def _independent(pos, dev, direction):
    """ISO 230-2:2014 sec. 3, written out position by position with plain loops."""
    out = {}
    per = {}
    for p in POSITIONS:
        for d, name in ((1, "up"), (-1, "dn")):
            x = [v for q, v, e in zip(pos, dev, direction) if q == p and e == d]
            n = len(x)
            mean = sum(x) / n
            s = (sum((v - mean) ** 2 for v in x) / (n - 1)) ** 0.5
            per[(p, name)] = (mean, s)
    up = [per[(p, "up")] for p in POSITIONS]
    dn = [per[(p, "dn")] for p in POSITIONS]
    B_i = [u[0] - d[0] for u, d in zip(up, dn)]
    out["B"] = max(abs(b) for b in B_i)
    out["R_up"] = max(4 * u[1] for u in up)
    out["R_down"] = max(4 * d[1] for d in dn)
    out["R"] = max(max(2 * u[1] + 2 * d[1] + abs(b), 4 * u[1], 4 * d[1])
                   for u, d, b in zip(up, dn, B_i))
    out["E_up"] = max(u[0] for u in up) - min(u[0] for u in up)
    out["E"] = max(max(u[0], d[0]) for u, d in zip(up, dn)) - \
        min(min(u[0], d[0]) for u, d in zip(up, dn))
    xbar = [(u[0] + d[0]) / 2 for u, d in zip(up, dn)]
    out["M"] = max(xbar) - min(xbar)
    out["A_up"] = max(u[0] + 2 * u[1] for u in up) - min(u[0] - 2 * u[1] for u in up)
    out["A"] = max(max(u[0] + 2 * u[1], d[0] + 2 * d[1]) for u, d in zip(up, dn)) - \
        min(min(u[0] - 2 * u[1], d[0] - 2 * d[1]) for u, d in zip(up, dn))
    return out, up, dn


def test_iso230_matches_independent_computation():
    pos, dev, direction = _dataset()
    r = iso230_2(pos, dev, direction)
    want, up, dn = _independent(pos, dev, direction)
    axis = r.axis()
    for key, value in want.items():
        assert axis[key] == pytest.approx(value, abs=1e-12), key
    np.testing.assert_allclose(r.up.mean, [u[0] for u in up], atol=1e-12)
    np.testing.assert_allclose(r.down.s, [d[1] for d in dn], atol=1e-12)
    assert r.positions.tolist() == POSITIONS.tolist()
    assert not r.warnings                          # 5 runs: what the standard asks


def test_iso230_definitions_that_differ_from_shortcuts():
    pos, dev, direction = _dataset()
    r = iso230_2(pos, dev, direction)
    axis = r.axis()
    # bidirectional R is the max of R_i, not max(R_up, R_down) nor 2s_up+2s_dn+B of the axis
    assert axis["R"] >= max(axis["R_up"], axis["R_down"])
    assert axis["R"] == pytest.approx(np.max(r.bidirectional["R_i"]))
    # E uses the extremes of both directions: here the down means lie below the up means
    assert axis["E"] > axis["E_up"]
    assert axis["E"] == pytest.approx(max(r.up.mean.max(), r.down.mean.max())
                                      - min(r.up.mean.min(), r.down.mean.min()))
    # R = 4 s (coverage +/-2 s), never 6 s
    assert r.up.R_i == pytest.approx(4 * r.up.s)
    assert axis["A"] >= axis["E"]                    # A adds the +/-2 s bands to E
    assert axis["M"] <= axis["E"]


def test_iso230_recovers_known_means_and_scatter():
    # Many runs: the estimates approach the generating means and scatters.
    rng = np.random.default_rng(3)
    mean = np.array([0.0, 1.0, -0.5, 2.0])
    s = np.array([0.1, 0.2, 0.05, 0.15])
    n = 4000
    pos = np.repeat(np.arange(4) * 90.0, n)
    dev = np.repeat(mean, n) + np.repeat(s, n) * rng.standard_normal(4 * n)
    r = iso230_2(pos, dev, None)
    np.testing.assert_allclose(r.up.mean, mean, atol=0.02)
    np.testing.assert_allclose(r.up.s, s, rtol=0.05)
    assert r.down is None and not r.is_bidirectional
    assert r.axis()["E_up"] == pytest.approx(2.5, abs=0.02)


def test_iso230_fewer_than_five_runs_warns():
    pos, dev, direction = _dataset()
    keep = np.arange(pos.size) < 3 * 2 * POSITIONS.size   # the first 3 runs
    r = iso230_2(pos[keep], dev[keep], direction[keep])
    assert any("5 runs" in w for w in r.warnings)


@pytest.mark.parametrize("bad", ["nan", "direction", "single", "missing"])
def test_iso230_rejects_bad_data(bad):
    pos, dev, direction = _dataset()
    if bad == "nan":
        dev[3] = np.nan
    elif bad == "direction":
        direction[0] = 0
    elif bad == "single":
        pos, dev, direction = POSITIONS, np.zeros(POSITIONS.size), np.ones(POSITIONS.size)
    else:
        drop = (pos == 30.0) & (direction == -1)
        pos, dev, direction = pos[~drop], dev[~drop], direction[~drop]
    with pytest.raises(DataError):
        iso230_2(pos, dev, direction)
