"""ISO 230-2 figures against independent computations: a synthetic 5-run set, a simulated
step run with 5 readings per approach (one x_ij per approach, n counting runs), a hand-built
points stream whose rotary targets include 0 and 360 deg, and the runs and sweep rules."""

from __future__ import annotations

import json

import numpy as np
import pyarrow as pa
import pytest
from conftest import run

from enctools.data.schemas import field_meta
from enctools.data.streams import Header, write_table
from enctools.errors import DataError
from enctools.methods.points import points_schema
from enctools.report.iso230 import iso230_2
from enctools.units import ARCSEC

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


# ------------------------------------------- a step run with 5 readings per approach

def _standard(x_up: np.ndarray, x_dn: np.ndarray) -> dict[str, np.ndarray | float]:
    """ISO 230-2:2014 from one x_ij per approach: arrays (targets m, runs n) [arcsec]."""
    n_up, n_dn = x_up.shape[1], x_dn.shape[1]
    m_up, m_dn = x_up.mean(axis=1), x_dn.mean(axis=1)
    s_up = np.sqrt(((x_up - m_up[:, None]) ** 2).sum(axis=1) / (n_up - 1))
    s_dn = np.sqrt(((x_dn - m_dn[:, None]) ** 2).sum(axis=1) / (n_dn - 1))
    B_i = m_up - m_dn
    xbar = (m_up + m_dn) / 2
    R_i = np.maximum(np.maximum(2 * s_up + 2 * s_dn + np.abs(B_i), 4 * s_up), 4 * s_dn)
    both = np.concatenate([m_up, m_dn])
    return {"mean_up": m_up, "mean_down": m_dn, "s_up": s_up, "s_down": s_dn, "B_i": B_i,
            "R_i": R_i, "B": np.abs(B_i).max(), "B_mean": B_i.mean(),
            "R_up": 4 * s_up.max(), "R_down": 4 * s_dn.max(), "R": R_i.max(),
            "E_up": np.ptp(m_up), "E_down": np.ptp(m_dn), "E": both.max() - both.min(),
            "M": np.ptp(xbar),
            "A_up": (m_up + 2 * s_up).max() - (m_up - 2 * s_up).min(),
            "A_down": (m_dn + 2 * s_dn).max() - (m_dn - 2 * s_dn).min(),
            "A": max((m_up + 2 * s_up).max(), (m_dn + 2 * s_dn).max())
            - min((m_up - 2 * s_up).min(), (m_dn - 2 * s_dn).min())}


def _raw_positioning(path) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """From the readings stream's raw columns: the positioning deviation of encoder I
    (mean of its heads' angles - target, mean removed) [arcsec] and step, run, direction."""
    with pa.ipc.open_stream(str(path)) as reader:
        table = reader.read_all()
    heads = [f for f in table.schema if field_meta(f).get("encoder") == "I"]
    angle = np.mean([table.column(f.name).to_numpy().astype(float) * 2 * np.pi
                     / int(field_meta(f)["counts_per_rev"]) for f in heads], axis=0)
    diff = angle - table.column("target").to_numpy()
    dev = (np.mod(diff + np.pi, 2 * np.pi) - np.pi) * 180 / np.pi * 3600
    cols = {c: table.column(c).to_numpy() for c in ("step", "run", "direction")}
    return cols, dev - dev.mean()


def _per_approach(cols: dict[str, np.ndarray], dev: np.ndarray, direction: int) -> np.ndarray:
    """x_ij: the mean of the readings of run j at step i in one direction (targets, runs)."""
    steps, runs = np.unique(cols["step"]), np.unique(cols["run"])
    x = np.empty((steps.size, runs.size))
    for i, k in enumerate(steps):
        for j, r in enumerate(runs):
            sel = (cols["step"] == k) & (cols["run"] == r) & (cols["direction"] == direction)
            x[i, j] = dev[sel].mean()
    return x


@pytest.fixture(scope="module")
def step_runs(tmp_path_factory):
    """Simulated bidirectional step runs of sjtu-dual, 5 readings per approach: 5 runs and 2."""
    d = tmp_path_factory.mktemp("iso_steps")
    for runs in (5, 2):
        r = run(f"enc acquire --rig sjtu-dual --mode steps --count 8 --readings 5 --runs {runs} "
                f"--bidirectional --seed 11 -o {d}/runs{runs}.arrows")
        assert r.returncode == 0, r.stderr.decode()
    return d


def _report_json(path) -> dict:
    r = run(f"enc report --json {path}")
    assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout)["sections"][0]


def test_iso230_of_a_step_run_is_computed_per_approach(step_runs):
    from scipy import stats  # 0.5 s of CPU to import: not at collection
    path = step_runs / "runs5.arrows"
    sec = _report_json(path)
    cols, dev = _raw_positioning(path)
    x_up, x_dn = _per_approach(cols, dev, 1), _per_approach(cols, dev, -1)
    assert x_up.shape == (8, 5)
    want = _standard(x_up, x_dn)
    iso = sec["iso230_2"]
    for key, value in iso["axis"].items():
        assert value == pytest.approx(want[key], abs=1e-9), key
    assert set(iso["axis"]) == {k for k in want if not isinstance(want[k], np.ndarray)}
    rows = iso["positions"]
    assert [p["position_deg"] for p in rows] == pytest.approx(np.arange(8) * 45.0, abs=1e-9)
    for key in ("mean_up", "mean_down", "s_up", "s_down"):
        np.testing.assert_allclose([p[key] for p in rows], want[key], rtol=0, atol=1e-9)
    np.testing.assert_allclose([p["B"] for p in rows], want["B_i"], rtol=0, atol=1e-9)
    np.testing.assert_allclose([p["R"] for p in rows], want["R_i"], rtol=0, atol=1e-9)
    assert all(p["n_up"] == 5 and p["n_down"] == 5 for p in rows)      # runs, not readings
    assert not iso["warnings"]
    # the curve is x_i; its u combines s / sqrt(n) of each direction over the approaches
    # with the rounding of encoder I's heads, 1 count / sqrt(12 N), and encoder I's
    # accuracy as read (no calibrated curve applied to a step run) as sjtu-dual declares
    # it, a rectangular bound of 0.37" (Type B)
    curve = sec["curves"][0]
    with pa.ipc.open_stream(str(path)) as reader:
        heads = [f for f in reader.schema if field_meta(f).get("encoder") == "I"]
    u_q = 1296000.0 / int(field_meta(heads[0])["counts_per_rev"]) / np.sqrt(12 * len(heads))
    u_b = np.hypot(u_q, 0.37 / np.sqrt(3))
    u_a = np.sqrt(want["s_up"] ** 2 / 5 + want["s_down"] ** 2 / 5) / 2
    u = np.sqrt(u_a ** 2 + u_b ** 2)
    # U = k u, Student's k at the effective degrees of freedom (4 a direction, combined
    # by Welch-Satterthwaite on the directions' mean variances along the curve; the
    # rounding taken as exact)
    v_up, v_dn = np.mean(want["s_up"] ** 2 / 5) / 4, np.mean(want["s_down"] ** 2 / 5) / 4
    nu = (v_up + v_dn + u_b ** 2) ** 2 / (v_up ** 2 / 4 + v_dn ** 2 / 4)
    k = stats.t.ppf(0.975, nu)
    assert curve["coverage_k"] == pytest.approx(k, rel=1e-9)
    assert curve["expanded_u_max_arcsec"] == pytest.approx(k * u.max(), abs=1e-9)
    assert curve["pp_arcsec"] == pytest.approx(want["M"], abs=1e-9)
    # pooling the 25 readings per target gives another s: the test tells them apart
    pooled = np.array([dev[(cols["step"] == k) & (cols["direction"] == 1)].std(ddof=1)
                       for k in range(8)])
    assert np.max(np.abs(pooled - want["s_up"])) > 1e-3


def test_iso230_two_runs_warn_in_one_line_counting_runs(step_runs):
    sec = _report_json(step_runs / "runs2.arrows")
    iso = sec["iso230_2"]
    assert all(p["n_up"] == 2 and p["n_down"] == 2 for p in iso["positions"])
    assert len(iso["warnings"]) == 1
    line = iso["warnings"][0]
    assert "5 runs in each direction" in line and "up 2, down 2" in line
    assert "5 readings of one approach count once" in line and "\n" not in line
    assert sum("5 runs" in n for n in sec["notes"]) == 1
    text = run(f"enc report {step_runs / 'runs2.arrows'}")
    assert text.returncode == 0
    assert text.stdout.decode().count("asks for 5 runs") == 1


def test_iso230_none_for_a_sweep_and_says_why(tmp_path):
    path = tmp_path / "sweep.arrows"
    r = run(f"enc acquire --rig sjtu-dual --mode sweep --range 25 --step 5 --readings 5 "
            f"--runs 2 --seed 11 -o {path}")
    assert r.returncode == 0, r.stderr.decode()
    sec = _report_json(path)
    assert sec["info"]["mode"] == "sweep"
    assert "iso230_2" not in sec
    why = [n for n in sec["notes"] if n.startswith("no ISO 230-2 figures")]
    assert len(why) == 1 and "sweep" in why[0]
    text = run(f"enc report {path}").stdout.decode()
    assert "ISO 230-2 (R = 4s" not in text and "no ISO 230-2 figures: a sweep" in text


def test_iso230_none_for_a_continuous_run_and_says_why(tmp_path):
    path = tmp_path / "cont.arrows"
    r = run(f"enc acquire --rig sjtu-dual --revolutions 0.05 -o {path}")
    assert r.returncode == 0, r.stderr.decode()
    sec = _report_json(path)
    assert "iso230_2" not in sec
    assert any(n.startswith("no ISO 230-2 figures: a continuous run") for n in sec["notes"])


# ------------------------------- a points stream: rad positions, 0 and 360 deg as one target

def test_iso230_points_stream_rotary_targets_and_approaches(tmp_path):
    """8 targets over a turn, the first visited at 0 deg going up and at 360 deg (2 pi)
    coming down; 3 readings per approach, 5 runs: one target at 0, n = 5 per direction."""
    rng = np.random.default_rng(5)
    m, runs, k = 8, 5, 3
    true_up = rng.normal(0, 0.5, m)
    true_dn = true_up - 0.3
    pos, dev, d, r = [], [], [], []
    for j in range(runs):
        shift = rng.normal(0, 0.05, (2, m))              # run-to-run scatter
        for direction, base in ((1, true_up), (-1, true_dn)):
            order = range(m) if direction == 1 else reversed(range(m))
            for i in order:
                p = i * 2 * np.pi / m if direction == 1 or i else 2 * np.pi
                for _ in range(k):
                    pos.append(p)
                    dev.append(base[i] + shift[(1 - direction) // 2, i] + rng.normal(0, 0.2))
                    d.append(direction)
                    r.append(j)
    pos, dev, d, r = map(np.array, (pos, dev, d, r))
    table = pa.table([pa.array(pos), pa.array(dev), pa.array(d, pa.int8()),
                      pa.array(r, pa.int32()), pa.array(pos - dev * ARCSEC)],
                     schema=points_schema())
    path = tmp_path / "points.arrows"
    write_table(str(path), Header("points", points_schema(), {"history": []}), table)
    sec = _report_json(path)
    iso = sec["iso230_2"]
    assert [p["position_deg"] for p in iso["positions"]] == pytest.approx(np.arange(m) * 45.0,
                                                                          abs=1e-9)
    target = np.round(np.mod(pos, 2 * np.pi) / (2 * np.pi / m)).astype(int) % m
    # the standard's x = actual - target: -deviation (a points stream's is indicated - true)
    x = {direction: np.array([[-dev[(target == i) & (d == direction) & (r == j)].mean()
                               for j in range(runs)] for i in range(m)])
         for direction in (1, -1)}
    want = _standard(x[1], x[-1])
    for key, value in iso["axis"].items():
        assert value == pytest.approx(want[key], abs=1e-9), key
    assert all(p["n_up"] == runs and p["n_down"] == runs for p in iso["positions"])
    # the same from the library, with the runs given and without (each reading one approach)
    lib = iso230_2(np.degrees(pos), dev, d, circular=True, run=r)
    assert lib.axis()["R"] == pytest.approx(want["R"], abs=1e-9)
    pooled = iso230_2(np.degrees(pos), dev, d, circular=True)
    assert int(pooled.up.runs.min()) == runs * k and pooled.axis()["R"] != pytest.approx(want["R"])


def test_iso230_rotary_targets_rule():
    """A rotary axis over a full turn asks for 8 targets: 4 give one more line; 8 none."""
    for m, lines in ((4, 1), (8, 0)):
        pos = np.tile(np.arange(m) * 360.0 / m, 5)
        dev = np.random.default_rng(m).normal(0, 0.1, pos.size)
        runs = np.repeat(np.arange(5), m)
        r = iso230_2(pos, dev, None, circular=True, run=runs)
        got = [w for w in r.warnings if "targets" in w]
        assert len(got) == lines
        assert all("8 targets" in w and "4 here" in w for w in got)
        assert not any("5 runs" in w for w in r.warnings)
