"""selfcal's passes in the compiled kernel against the numpy passes (issue 35, item 4).

The kernel (enctools/_kernel.c through enctools/kernel.py) turns a readings batch's counts
into the angle coordinate and the channels, maps a revolution's samples to theta, sums its
binned moments, and counts its sample positions met in the first revolution, each in one
loop. The numpy passes are the reference: the same doubles (the same operations in the
same order; each bin's sums over its samples in turn, as numpy's einsum adds them), so the
tests ask for equality, and the whole command's outputs are the same with either. Where the
numpy passes would choose another way (falling angles, a long stop, few samples) the kernel
leaves it to them.
"""

from __future__ import annotations

import itertools
import json

import numpy as np
import pyarrow as pa
import pytest
from conftest import run_in_process

from enctools import kernel
from enctools.data import limits
from enctools.data.readings import HeadInfo
from enctools.errors import DataError
from enctools.methods import harmonics
from enctools.methods.harmonics import FourierSeries, trapezoid_weights
from enctools.methods.revolutions import (
    ChannelSpec,
    Revolution,
    RunningMean,
    _kernel_channels,
    mean_reading,
)
from enctools.methods.selfcal_uncertainty import SampleRepeats, _among
from enctools.units import TWO_PI


@pytest.fixture
def compiled() -> None:
    kernel.library.cache_clear()
    if kernel.library() is None:
        pytest.skip("the compiled kernel is not built here")


def _revolution(rng: np.random.Generator, samples: int, start: float,
                channels: int) -> tuple[np.ndarray, np.ndarray]:
    """A jittered revolution of u from ``start`` (its ends exactly on the turn) and
    ``channels`` rows of values on it [rad]."""
    k = np.arange(samples + 1)
    u = start + k * (TWO_PI / samples) + 3e-5 * np.sin(5 * TWO_PI * k / samples)
    u += 1e-7 * rng.normal(size=u.size)
    u[0], u[-1] = start, start + TWO_PI
    values = 1e-5 * rng.normal(size=(channels, u.size)) + 2e-5 * np.sin(3 * u)
    return u, values


def _numpy_sums(u: np.ndarray, v: np.ndarray, start: float, band: int,
                shift: FourierSeries | None) -> np.ndarray | None:
    x = (u if shift is None else u - shift(u)) - start
    return harmonics._binned_sums(x, v, trapezoid_weights(x), band)


@pytest.mark.parametrize(("channels", "band", "mapped"),
                         [(4, 100, True), (4, 100, False), (1, 100, True), (7, 40, True),
                          (3, 250, False)])
def test_moments_are_numpy_s(compiled: None, channels: int, band: int, mapped: bool) -> None:
    """The binned sums of a revolution mapped through an angle map (or not), with the
    usual four heads and band and others (other terms, the generic loop): equal."""
    rng = np.random.default_rng(channels + band)
    u, v = _revolution(rng, 20000, 0.7, channels)
    shift = None
    if mapped:
        error = 1e-5 * (rng.normal(size=band + 1) + 1j * rng.normal(size=band + 1))
        shift = FourierSeries(error / (1 + np.arange(band + 1)))
    theta_start = 0.7 if shift is None else 0.7 - float(shift(np.array([0.7]))[0])
    got = harmonics._kernel_sums(u, (v,), theta_start, band, shift)
    want = _numpy_sums(u, v, theta_start, band, shift)
    assert got is not None and want is not None
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("cuts", [[7000], [1, 2, 2, 9000, 20000], [0, 255, 256, 257, 513]])
def test_moments_of_pieces_minus_offsets_are_numpy_s(compiled: None, cuts: list[int]) -> None:
    """A revolution's values as the pieces of the batches it was cut from (the splitter's
    views: one-sample and empty pieces, pieces ending inside and on a block of 256, a row
    stride of the whole batch), an offset taken off each channel: the sums of the joined
    values minus the offsets, equal; the pieces are not written to."""
    rng = np.random.default_rng(len(cuts))
    u, v = _revolution(rng, 20000, 0.3, 4)
    batch = np.empty((4, u.size + 100))          # the pieces' rows lie in a wider batch
    batch[:, 50:50 + u.size] = v
    whole = batch[:, 50:50 + u.size]
    edges = [0, *cuts, u.size]
    parts = tuple(whole[:, a:b] for a, b in itertools.pairwise(edges))
    offsets = np.array([3e-4, -2e-4, 1e-6, 0.0])
    kept = batch.copy()
    got = harmonics._kernel_sums(u, parts, 0.3, 100, None, offsets)
    want = _numpy_sums(u, v - offsets[:, None], 0.3, 100, None)
    assert got is not None and want is not None
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(batch, kept)
    np.testing.assert_array_equal(harmonics._kernel_sums(u, parts, 0.3, 100, None),
                                  _numpy_sums(u, v, 0.3, 100, None))


def test_pieces_that_do_not_make_the_revolution_are_left_to_numpy(compiled: None) -> None:
    """Pieces one sample short of u, or of another channel count: the kernel declines."""
    rng = np.random.default_rng(3)
    u, v = _revolution(rng, 4000, 0.0, 2)
    assert harmonics._kernel_sums(u, (v[:, :100], v[:, 100:-1]), 0.0, 50, None) is None
    assert harmonics._kernel_sums(u, (v[:, :100], v[:1, 100:]), 0.0, 50, None) is None


def test_a_revolution_joins_its_pieces_once_and_never_into_them() -> None:
    """Revolution.values: the pieces joined into a new array, made once; writing to it
    leaves the pieces (shared with the next revolution) as they were."""
    a, b = np.arange(6.0).reshape(2, 3), np.arange(6.0, 8.0).reshape(2, 1)
    rev = Revolution(0, 0.0, np.arange(4.0), (a, b))
    assert rev.parts == (a, b)
    np.testing.assert_array_equal(rev.values, [[0, 1, 2, 6], [3, 4, 5, 7]])
    assert rev.values is rev.values
    rev.values -= 1.0
    np.testing.assert_array_equal(a, np.arange(6.0).reshape(2, 3))
    np.testing.assert_array_equal(b, [[6.0], [7.0]])
    whole = np.ones((1, 3))
    assert Revolution(0, 0.0, np.arange(3.0), whole).values is whole


def test_a_last_sample_past_the_turn_goes_to_the_last_bin(compiled: None) -> None:
    """x's last sample rounded past 2 pi (and the first below 0): the same bins as numpy's."""
    rng = np.random.default_rng(5)
    u, v = _revolution(rng, 5000, 0.0, 4)
    u[-1] = np.nextafter(TWO_PI, 10.0)
    u[0] = -1e-17
    np.testing.assert_array_equal(harmonics._kernel_sums(u, (v,), 0.0, 60, None),
                                  _numpy_sums(u, v, 0.0, 60, None))


def test_what_the_kernel_leaves_to_numpy(compiled: None) -> None:
    """Falling angles, a long stop (bins too unevenly filled for numpy's padded layout) and
    few samples: the kernel declines, and the coefficients are numpy's."""
    rng = np.random.default_rng(9)
    u, v = _revolution(rng, 4000, 0.0, 2)
    falling = (u[::-1] - TWO_PI).copy()
    stop = np.concatenate([np.linspace(0.0, 1.0, 1000), np.full(30000, 1.0) +
                           np.linspace(0, 1e-9, 30000), np.linspace(1.0, TWO_PI, 1000)[1:]])
    for uu in (falling, stop, u[:200]):
        vv = np.ascontiguousarray(1e-5 * np.sin(3 * uu)[None, :])
        assert harmonics._kernel_sums(uu, (vv,), float(uu[0]), 50, None) is None
    np.testing.assert_array_equal(
        harmonics.revolution_coefficients(falling, v[:, ::-1], 0.0, 50),
        _reference(falling, v[:, ::-1], 0.0, 50))


def _reference(u: np.ndarray, v: np.ndarray, start: float, band: int) -> np.ndarray:
    """revolution_coefficients by the numpy passes alone."""
    kernel.library.cache_clear()
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(kernel.ENV, "numpy")
        out = harmonics.revolution_coefficients(u, v, start, band)
    kernel.library.cache_clear()
    return out


def test_repeat_share_is_the_binary_search_s(compiled: None) -> None:
    """The share of a revolution's positions met in the first: the kernel's merge equals the
    binary search's, on a revolution partly on the first's positions; falling u (positions
    that fall) is left to the search."""
    quantum = TWO_PI / 2 ** 22
    rng = np.random.default_rng(2)
    first = np.unique(rng.integers(0, 2 ** 22, 6000))
    part = np.sort(np.concatenate([first[:2000], rng.integers(0, 2 ** 22, 4000)]))
    repeats = SampleRepeats(quantum)
    for start, counts in ((0.0, part), (TWO_PI, part[::-1] - 2 ** 22)):
        u = np.concatenate([start + counts * quantum, [start + TWO_PI]])
        rev = Revolution(1, start, u, np.zeros((1, u.size)))
        want = float(np.mean(_among(repeats._positions(rev), first)))
        assert repeats._share(rev, first) == want


def _batch(rng: np.random.Generator, rows: int) -> tuple[pa.RecordBatch, ChannelSpec]:
    cpr = 212992000
    heads = [HeadInfo(f"H{k + 1}", "II", k * 0.7, cpr, 52000, 4096, 0.165655,
                      int(k * 35500032)) for k in range(6)]
    base = np.cumsum(rng.integers(800, 1400, rows)) - 5 * 10 ** 8
    cols = {h.name: base + h.zero_count + rng.integers(-50, 50, rows) for h in heads}
    batch = pa.RecordBatch.from_pydict({k: pa.array(v, pa.int64()) for k, v in cols.items()})
    return batch, ChannelSpec(tuple(heads[2:]), tuple(heads[:4]))


def test_channels_are_mean_reading_s(compiled: None) -> None:
    """The coordinate (four heads' mean) and the channels minus it from a batch's counts,
    and the sense of u: the same doubles as mean_reading's."""
    batch, spec = _batch(np.random.default_rng(4), 70000)
    fused = _kernel_channels(batch, spec)
    assert fused is not None
    u, values, sense, step = fused
    want_u = mean_reading(batch, spec.coordinate)
    np.testing.assert_array_equal(u, want_u)
    for row, h in zip(values, spec.channels, strict=True):
        np.testing.assert_array_equal(row, mean_reading(batch, (h,), minus=want_u))
    assert sense == 1
    assert step == float(np.abs(np.diff(want_u)).max())


@pytest.mark.parametrize("where", [1, 35000, 69999])
def test_a_step_of_half_a_turn_within_a_batch_is_refused(compiled: None, where: int) -> None:
    """A batch whose coordinate jumps half a turn between two samples (the kernel finds
    the largest step): the one-line DataError of the numpy check, naming the jump."""
    from enctools.methods.revolutions import RevolutionCutter

    batch, spec = _batch(np.random.default_rng(6), 70000)
    cols = {n: batch.column(n).to_numpy().copy() for n in batch.schema.names}
    for h in spec.coordinate:     # the mean of the coordinate heads moves on by 0.6 turn
        cols[h.name][where:] += int(0.6 * h.counts_per_rev)
    arrays = {k: pa.array(v, pa.int64()) for k, v in cols.items()}
    arrays["t"] = pa.array(np.arange(70000) * 0.003)   # (pyarrow 14 has no append_column)
    with pytest.raises(DataError, match=r"moves 0\.6 turns between two samples"):
        RevolutionCutter(spec, "x")(pa.RecordBatch.from_pydict(arrays))


def test_running_mean_rows_are_their_own() -> None:
    """A running mean of stacked arrays, row by row: what one running mean per row holds."""
    rng = np.random.default_rng(8)
    stacked, single = RunningMean(), [RunningMean() for _ in range(3)]
    for _ in range(7):
        x = rng.normal(size=(3, 11)) + 1j * rng.normal(size=(3, 11))
        stacked.add(x)
        for r, row in zip(single, x, strict=True):
            r.add(row)
    for got, want in zip(stacked.rows(), single, strict=True):
        np.testing.assert_array_equal(got.mean, want.mean)
        np.testing.assert_array_equal(got.sem(), want.sem())


def test_large_integer_column_checked_as_before() -> None:
    """A count column of 2^16 rows (Arrow's one-pass range) holding a value beyond the
    limits: the same one-line DataError naming it; within them, accepted."""
    checks = [("H1", -2.0 ** 62, 2.0 ** 62, "count", False)]
    counts = np.arange(1 << 16, dtype=np.int64)
    limits.check_batch(pa.RecordBatch.from_pydict({"H1": counts}), checks, "x")
    counts[40000] = 2 ** 62 + 2 ** 20
    with pytest.raises(DataError, match=r"column 'H1' holds 4611686018428436480 count"):
        limits.check_batch(pa.RecordBatch.from_pydict({"H1": counts}), checks, "x")


def test_selfcal_same_outputs_either_way(kernel_path: str, sjtu_raw, tmp_path) -> None:
    """enc selfcal's deviations, spectrum and JSON summary, with the kernel and with the
    numpy passes: each compared with a reference made by the numpy passes."""
    args = ["selfcal", str(sjtu_raw), "--method", "esa", "--ref-head", "H1", "--heads",
            "H5,H6,H7", "--json", "--force"]
    runs = {}
    for name, env in (("reference", {kernel.ENV: "numpy"}), ("this", None)):
        out, spectrum = tmp_path / f"{name}.arrows", tmp_path / f"{name}-spectrum.arrows"
        kernel.library.cache_clear()
        r = run_in_process([*args, "-o", out, "--spectrum", spectrum], env=env)
        assert r.returncode == 0, r.stderr.decode()
        runs[name] = (json.loads(r.stdout), pa.ipc.open_stream(out.read_bytes()).read_all(),
                      pa.ipc.open_stream(spectrum.read_bytes()).read_all())
    kernel.library.cache_clear()
    ref, this = runs["reference"], runs["this"]
    assert this[0] == ref[0]
    assert this[1].equals(ref[1]) and this[2].equals(ref[2])
