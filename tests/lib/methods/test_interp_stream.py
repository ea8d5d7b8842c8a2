"""enc interp-check on continuous runs, streamed (seed 000 sec. 4, eqs. 19-20).

A continuous run has a trend per window of the reference angle (default 1800",
0.5 deg): a line per window leaves 0.004" rms of the sjtu-dual graduation errors
(harmonics up to 180 per turn), below the heads' noise (0.02" for H, 0.01" for P).
The runs here are sampled every 5.05 ms at 1 r/min (109" per sample: 4.38 H periods,
15.15 P periods), so that the aliased phase steps of H1's 1st/2nd and P1's 1st/2nd
harmonics (0.377, 0.247, 0.15, 0.30 cycles per sample) are apart and away from 0
and 0.5: every harmonic goes through several cycles within a window (5.05 ms is the
rig's default). At the paper's 3 ms encoder I is sampled at 9.0 periods per sample
(stroboscopic).
"""

from __future__ import annotations

import shutil
import sys

import numpy as np
import pytest
from conftest import run
from test_interp import one_line_error, read_phase_truth

from enctools.data.streams import read_table
from enctools.data.truth import Truth
from enctools.methods.interp.coverage import PhaseCoverage
from enctools.methods.interp.settings import DEFAULT_WINDOW_ARCSEC
from enctools.methods.trend_lsq import StackedTrendLSQ, TrendProjectedLSQ, group_batch
from enctools.units import TWO_PI

#: every test with the compiled kernel and with the numpy passes (conftest.kernel_path)
pytestmark = pytest.mark.usefixtures("kernel_path")

ACQUIRE = "enc acquire --rig sjtu-dual --interval 0.00505 --heads H1,P1"


@pytest.fixture(scope="module")
def run20(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("interp_stream") / "c20.arrows"
    r = run(f"{ACQUIRE} --revolutions 20 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    return out


def kept_truth(truth: Truth, head: str, theta: np.ndarray, ppr: int, keep) -> np.ndarray:
    """The truth at the read phase restricted to the kept harmonics [arcsec]."""
    want = read_phase_truth(truth.signals[head], theta, ppr)
    c = np.fft.rfft(want) / theta.size * 2
    return sum((c[n] * np.exp(1j * n * theta)).real for n in keep)


@pytest.mark.slow
def test_continuous_h1_by_p1_matches_truth(run20, tmp_path):
    """20 revolutions (238 000 samples): H1's 1st and 2nd harmonics within 0.001" of the
    truth at every phase (0.8 % of its 0.12" 1st harmonic; the statistical u is 1e-4",
    the rest is what a line per window leaves of the graduation error, 0.004" rms,
    whose projection on the phase columns averages over 14 400 windows), and within
    5 u + 0.0005"; P1's own 1st harmonic, fitted alongside, within 0.001"."""
    out = tmp_path / "c.parquet"
    r = run(f"enc interp-check {run20} --reference P1 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    assert "WARNING" not in r.stderr.decode()
    header, table = read_table(out, "deviations")
    truth = Truth.from_dict(header.meta["truth"])
    meta = header.meta["curves"]["H1"]
    assert meta["kept"] == [1, 2] and meta["periods_per_rev"] == 52000
    assert meta["window_arcsec"] == DEFAULT_WINDOW_ARCSEC == 1800
    assert meta["windows"] == pytest.approx(20 * 720, rel=0.002)  # speed 1000 ppm off
    assert meta["samples"] > 230_000
    # the residual is the heads' noise (0.02" and 0.01"): the trends follow the graduation
    assert meta["residual_rms_arcsec"] == pytest.approx(np.hypot(0.02, 0.01), rel=0.1)
    theta = table["theta"].to_numpy()
    want = kept_truth(truth, "H1", theta, 52000, [1, 2])
    got = table["H1"].to_numpy()
    u = table["u_H1"].to_numpy()
    assert np.abs(got - want).max() < 0.001
    assert np.all(np.abs(got - want) < 5 * u + 0.0005)
    p1 = header.meta["curves"]["H1"]["reference_harmonics"][0]
    c1 = np.fft.rfft(read_phase_truth(truth.signals["P1"], theta, 180000))[1] / theta.size * 2
    assert p1["amplitude"] == pytest.approx(abs(c1), abs=0.001)


@pytest.mark.slow
def test_window_choice_and_bad_windows(run20, tmp_path):
    """A wider window (2 deg) leaves more graduation error: a larger residual and u, the
    same curve within 0.002"; a window shorter than the signal period is refused."""
    out = tmp_path / "w.parquet"
    assert run(f"enc interp-check {run20} --reference P1 -q -o {out}").returncode == 0
    _, base = read_table(out)
    r = run(f"enc interp-check {run20} --reference P1 --window 7200 -q -o {out} --force")
    assert r.returncode == 0, r.stderr.decode()
    header, wide = read_table(out)
    assert header.meta["curves"]["H1"]["residual_rms_arcsec"] > 0.04
    assert np.abs(wide["H1"].to_numpy() - base["H1"].to_numpy()).max() < 0.002
    assert header.meta["settings"]["window_arcsec"] == 7200
    bad = tmp_path / "b.parquet"
    assert "shorter than the signal period" in one_line_error(
        run(f"enc interp-check {run20} --reference P1 --window 20 -o {bad}"), bad)
    assert "--window" in one_line_error(
        run(f"enc interp-check {run20} --window -5 -o {bad}"), bad)
    assert "--signals" in one_line_error(
        run(f"enc interp-check {run20} --signals --window 900 -o {bad}"), bad)


@pytest.mark.slow
def test_stroboscopic_heads_are_named(tmp_path):
    """At 3 ms encoder I is sampled at 9.0 periods per sample: P2 asked for is refused in
    one line naming it; by default it is skipped with a warning, and P1 as the reference
    is not fitted (its error goes into the trends)."""
    raw = tmp_path / "r.arrows"
    r = run(f"enc acquire --rig sjtu-dual --interval 0.003 --revolutions 2 --heads P1,P2,H1 "
            f"-o {raw}")
    assert r.returncode == 0
    out = tmp_path / "o.parquet"
    err = one_line_error(run(f"enc interp-check {raw} --heads P2 --reference P1 -o {out}"), out)
    assert "P2" in err and "synchronous" in err and "--interval" in err
    r = run(f"enc interp-check {raw} --reference P1 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    text = r.stderr.decode()
    assert "P2: sampling is nearly synchronous" in text and "not checked" in text
    header, table = read_table(out)
    assert "P2" not in table.column_names
    assert "reference_harmonics" not in header.meta["curves"]["H1"]


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
@pytest.mark.parametrize("consecutive", [True, False])
def test_trend_projection_is_the_joint_fit(degree, consecutive):
    """TrendProjectedLSQ fed in uneven batches = one lstsq with a trend per group.

    Windows met in order (a continuous run) or groups interleaved (a sweep's runs),
    with groups of one sample and of one repeated abscissa among them: their trend
    fits them exactly and only as many trend terms as they determine are counted.
    Three such problems fed as one (StackedTrendLSQ, the heads of a run) each give
    the same sums as alone, to rounding.
    """
    rng = np.random.default_rng(5 + degree)
    n, width = 5000, 0.37
    x = np.cumsum(rng.uniform(0.0, 0.01, n))
    keys = np.floor(x / width).astype(np.int64)
    keys[1234] = 10_000                               # a group of one sample
    keys[2000:2006], x[2000:2006] = 10_001, x[2000]    # one abscissa, six samples
    if not consecutive:
        keys = rng.permutation(5)[keys % 5] * 100_003 + keys // 5 % 3   # interleaved runs
        keys[1234], keys[2000:2006] = 10_000, 10_001
    cols = np.column_stack([np.cos(7.3 * x * 40), np.sin(7.3 * x * 40), np.cos(3.1 * x * 40)])
    y = cols @ [0.3, -0.2, 0.05] + np.sin(x) * 3 + x ** 2 + rng.normal(0, 0.01, n) + 100.0
    closed = []
    lsq = TrendProjectedLSQ(3, degree, consecutive=consecutive,
                            on_close=lambda counts, seen, lo, hi: closed.append((counts, seen)))
    labels = rng.integers(0, 3, n)
    bits = np.left_shift(1, labels).astype(np.uint8)
    groups = np.unique(keys)
    # off-centre (the group's least abscissa), so that the trend's terms are not orthogonal
    centre = np.array([x[keys == k].min() for k in groups])[np.searchsorted(groups, keys)]
    scale = width / 2 if consecutive else np.ptp(x) / 2    # z within about [-1, 1]
    parts = [(0, 1), (1, 700), (700, 701), (701, 3333), (3333, n)]
    for a, b in parts:
        lsq.add(cols[a:b].T, y[a:b], x[a:b], keys[a:b], scale, centre=centre[a:b],
                labels=bits[a:b])
    lsq.close_all()
    coef = np.linalg.solve(lsq.xtx, lsq.xty)
    trend = np.column_stack([np.where(keys == k, ((x - centre) / scale) ** d, 0.0)
                             for k in groups for d in range(degree + 1)])
    full, _, rank, _ = np.linalg.lstsq(np.column_stack([cols, trend]), y, rcond=None)
    assert np.allclose(coef, full[:3], atol=1e-9)
    resid = y - np.column_stack([cols, trend]) @ full
    assert lsq.yty - coef @ lsq.xty == pytest.approx(resid @ resid, rel=1e-6)
    assert lsq.n_trend == rank - 3 and lsq.n == n and lsq.groups == groups.size
    # per group: its samples, and the bits of the labels its samples carry
    counts = np.concatenate([c for c, _ in closed])
    seen = np.concatenate([s for _, s in closed])
    assert counts.shape == seen.shape == (groups.size,)
    sizes = np.bincount(np.searchsorted(groups, keys))
    want = np.zeros(groups.size, np.uint8)
    np.bitwise_or.at(want, np.searchsorted(groups, keys), bits)
    assert sorted(zip(counts.tolist(), seen.tolist(), strict=True)) \
        == sorted(zip(sizes.tolist(), want.tolist(), strict=True))

    # the same problem and two others (other columns, other y) stacked
    others = [cols[:, ::-1] * [1.0, 2.0, 0.5], np.cos(cols * 3.0)]
    ys = [y, y[::-1] * 0.5, rng.normal(size=n)]
    alone = []
    for c, yy in zip([cols, *others], ys, strict=True):
        one = TrendProjectedLSQ(3, degree, consecutive=consecutive)
        for a, b in parts:
            one.add(c[a:b].T, yy[a:b], x[a:b], keys[a:b], scale, centre=centre[a:b])
        one.close_all()
        alone.append(one)
    members = [TrendProjectedLSQ(3, degree, consecutive=consecutive) for _ in ys]
    stack = StackedTrendLSQ(members)
    for a, b in parts:
        g = group_batch(keys[a:b], x[a:b], degree, scale, centre[a:b])
        stack.add(x[a:b], scale, g, [(np.vstack([c[a:b].T, yy[a:b]]), None, None)
                                     for c, yy in zip([cols, *others], ys, strict=True)])
    stack.close_all()
    for one, member in zip(alone, members, strict=True):
        assert np.allclose(member.xtx, one.xtx, rtol=1e-12, atol=1e-12)
        assert np.allclose(member.xty, one.xty, rtol=1e-12, atol=1e-12)
        assert member.yty == pytest.approx(one.yty, rel=1e-12)
        assert (member.n, member.n_trend, member.groups) == (one.n, one.n_trend, one.groups)
    assert np.allclose(members[0].xtx, lsq.xtx, rtol=1e-12, atol=1e-12)


def test_moments_are_the_per_sample_sums():
    """The moments held per open group and the cross products, against the sums taken
    sample by sample as the fit before the shared grouping took them (y less its
    group's first value, T of z = (x - centre) / scale): equal to rounding."""
    rng = np.random.default_rng(11)
    n, degree = 3000, 2
    x = np.sort(rng.uniform(0.0, 3.0, n))
    keys = np.floor(x / 0.25).astype(np.int64)
    centre = (keys + 0.5) * 0.25
    cols = rng.normal(size=(3, n))
    y = rng.normal(size=n) + 1e4 + x
    labels = rng.integers(0, 4, n)
    lsq = TrendProjectedLSQ(3, degree, consecutive=False)
    rows = np.vstack([cols, np.zeros(n)])            # with the free row for y
    lsq.add(rows, y, x, keys, 0.125, centre=centre,
            labels=np.left_shift(1, labels).astype(np.uint8))
    first = np.searchsorted(keys, keys)
    yc = y - y[first]
    assert np.allclose(lsq.xtx, cols @ cols.T, rtol=1e-13, atol=0)
    assert np.allclose(lsq.xty, cols @ yc, rtol=1e-12, atol=1e-12)
    assert lsq.yty == pytest.approx(yc @ yc, rel=1e-13)
    z = (x - centre) / 0.125
    t = np.polynomial.legendre.legvander(z, degree)               # (n, d)
    d, p = degree + 1, 3
    held = lsq._open
    assert held.txy.shape == (d, 1, p + 1, np.unique(keys).size)
    for g, k in enumerate(np.unique(keys)):
        m = keys == k
        assert np.allclose(held.gram[..., g], t[m].T @ t[m], rtol=1e-12, atol=1e-9), g
        want = t[m].T @ np.vstack([cols[:, m], yc[m]]).T              # (d, p + 1)
        assert np.allclose(held.txy[:, 0, :, g], want, rtol=1e-12, atol=1e-9), g
        assert held.seen[0, g] == np.bitwise_or.reduce(np.left_shift(1, labels[m]))
        assert held.y0[0, g] == y[m][0]


def test_devices_sharing_the_windows_fit_as_alone():
    """Fits of several devices against one reference share each batch's windows
    (SharedGrouping); each result is the one it gets alone, bit for bit, also when a
    device's NaN reading leaves it other samples than the others in a batch."""
    from enctools.methods.interp.fit import InterpolationFit, SharedGrouping

    rng = np.random.default_rng(3)
    n, ppr = 40_000, 4096
    ref = np.cumsum(rng.uniform(0.0, 2e-4, n))
    devices = []
    for k in range(3):
        phase = np.mod((ref + 0.1 * k) * ppr, TWO_PI)
        dev = ref + 1e-6 * np.sin(phase + k) + 1e-7 * rng.normal(size=n) + 0.3 * k
        devices.append((dev, phase))
    devices[2][0][12_345] = np.nan

    def fits(share: bool) -> list:
        one = SharedGrouping()
        out = [InterpolationFit(ppr, window=0.01, shared=one if share else None)
               for _ in devices]
        for a in range(0, n, 7_001):
            r = ref[a:a + 7_001]
            for f, (dev, phase) in zip(out, devices, strict=True):
                f.add(dev[a:a + 7_001], phase[a:a + 7_001], r)
        return [f.result() for f in out]

    alone, together = fits(False), fits(True)
    for a, b in zip(alone, together, strict=True):
        assert np.array_equal(a.fitted.coef, b.fitted.coef) and a.fitted.coef.any()
        assert a.residual_rms == b.residual_rms and a.windows == b.windows


@pytest.mark.parametrize("nan_at", [None, 33_333])
def test_devices_fed_as_one_fit_as_alone(nan_at):
    """A FitBank of three devices against one reference (phases from counts, as in a run)
    gives each device the result it gets alone, to rounding; a NaN reading of one device
    mid-run parts the bank from that batch on, and the results still agree."""
    from enctools.methods.interp.bank import FitBank
    from enctools.methods.interp.fit import InterpolationFit, SharedGrouping

    rng = np.random.default_rng(4)
    n, ppr, steps = 60_000, 512, 1024
    per_count = TWO_PI / (ppr * steps)
    ref_counts = np.cumsum(rng.integers(0, 60, n))
    ref = ref_counts * per_count
    devices = []
    for k in range(3):
        true = ref + 4e-5 * np.sin(ref * ppr + k) + 1e-5 * np.cos(2 * ref * ppr) + 1e-3 * k
        counts = np.rint((true + 3e-6 * rng.normal(size=n)) / per_count).astype(np.int64)
        devices.append(counts)

    def feed(as_one: bool) -> list:
        shared = SharedGrouping()
        fits = [InterpolationFit(ppr, harmonics=3, window=0.02, shared=shared) for _ in devices]
        banks = FitBank.of(fits) if as_one else []
        assert not as_one or len(banks) == 1
        for a in range(0, n, 7_001):
            r = ref[a:a + 7_001]
            angles = [c[a:a + 7_001] * per_count for c in devices]
            if nan_at is not None and a <= nan_at < a + 7_001:
                angles[2][nan_at - a] = np.nan
            st = [(c[a:a + 7_001] % steps, steps, None, 0) for c in devices]
            if as_one:
                banks[0].add(angles, r, st)
            else:
                for f, d, s in zip(fits, angles, st, strict=True):
                    f.add(d, None, r, steps=s)
        for b in banks:
            b.close()
        return [f.result() for f in fits]

    alone, together = feed(False), feed(True)
    for a, b in zip(alone, together, strict=True):
        assert np.allclose(a.fitted.coef, b.fitted.coef, rtol=1e-11, atol=1e-15)
        assert np.all(np.abs(a.fitted.coef[:2]) > 1.0)
        assert np.allclose(a.fitted.cov, b.fitted.cov, rtol=1e-9, atol=0)
        assert a.residual_rms == pytest.approx(b.residual_rms, rel=1e-11)
        assert (a.samples, a.windows) == (b.samples, b.windows)
    assert together[2].samples == n - (nan_at is not None)


@pytest.mark.parametrize("steps", [4096, 1000, 3])
def test_sectors_looked_up_are_the_quarters(steps):
    from enctools.methods.interp.coverage import SECTORS, sector_bits
    step = np.arange(steps)[::-1]
    want = np.left_shift(1, step * SECTORS // steps)
    assert np.array_equal(sector_bits(step * (TWO_PI / steps), step, steps), want)
    assert np.array_equal(sector_bits(step * (TWO_PI / steps)), want)  # from the phase


def test_phase_coverage_bitmap_matches_sorted_gaps():
    rng = np.random.default_rng(2)
    phase = np.floor(rng.uniform(0, 4096, 300)) * (TWO_PI / 4096)
    cover = PhaseCoverage()
    for part in np.array_split(phase, 7):
        cover.add(part)
    p = np.sort(phase)
    gap = np.max(np.diff(np.append(p, p[0] + TWO_PI)))
    assert cover.gap() == pytest.approx(gap, abs=1e-12)
    assert cover.resolvable() == int(np.floor(np.pi / gap - 1e-9))


@pytest.mark.skipif(not shutil.which("/usr/bin/time") or sys.platform != "linux",
                    reason="needs GNU time for the peak memory")
@pytest.mark.slow
def test_peak_memory_does_not_grow_with_revolutions(run20, tmp_path):
    """Peak memory (max RSS) of interp-check at 200 revolutions (2.4 M samples) within
    1.2x of 20 (the fit keeps sums, not samples)."""
    long = tmp_path / "c200.arrows"
    assert run(f"{ACQUIRE} --revolutions 200 -o {long}").returncode == 0
    peaks = []
    for f in (run20, long):
        r = run(f"cat {f} | /usr/bin/time -f %M enc interp-check -q --reference P1 > /dev/null")
        assert r.returncode == 0, r.stderr.decode()
        peaks.append(int(r.stderr.decode().split()[-1]))
    assert peaks[1] < 1.2 * peaks[0], peaks


def test_batches_are_made_ready_on_the_reader_thread(tmp_path, monkeypatch):
    """A stream's batches are made ready (the reference's angle and step, the heads'
    counts: interp/batches.py) on the stream's reader thread while the fits sum the
    batch before; the same readings as one table give the same curves and u, bit for
    bit, and every batch of a table is made on the caller's thread."""
    import threading

    from enctools.data.streams import open_input
    from enctools.methods.interp.readings import check_readings
    from enctools.methods.interp.reference import HeadReference
    from enctools.methods.interp.settings import Settings

    out = tmp_path / "c3.arrows"
    r = run(f"{ACQUIRE} --revolutions 3 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    threads: list[str] = []
    read = HeadReference.read

    def on_thread(self, batch):
        threads.append(threading.current_thread().name)
        return read(self, batch)

    monkeypatch.setattr(HeadReference, "read", on_thread)
    settings = Settings(heads=["H1"], reference="P1")
    with open_input(out, "readings") as source:
        streamed = check_readings(source, settings, continuous=True)
    assert threads and set(threads) == {"enc-read-ahead"}, threads
    threads.clear()
    with open_input(out, "readings") as source:
        table = source.read_all()
    whole = check_readings(table, settings, continuous=True)
    assert set(threads) == {threading.current_thread().name}
    assert [c.name for c in streamed] == [c.name for c in whole] == ["H1"]
    for s, w in zip(streamed, whole, strict=True):
        assert np.array_equal(s.error, w.error) and np.array_equal(s.u, w.u)
        assert s.meta["windows"] == w.meta["windows"] > 1
