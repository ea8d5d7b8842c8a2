"""The compiled kernel of interp-check's fit against the numpy passes (issue 35, item 1).

The kernel (enctools/_kernel.c through enctools/kernel.py) sums a head's batch in one
loop; the numpy passes are the reference. On the same readings both give every curve
and its u to 1e-12 arcsec (the order of the additions differs, nothing else), over the
paths the kernel takes: a continuous run's windows with the devices fed as one bank, a
device alone, the reference's own harmonics fitted alongside (X^T X then made from the
steps), a trend of degree 0 to 3, a period of steps that is not a power of two, negative
counts and a zero count that shifts the step, a sweep's runs one after another.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import run_in_process

from enctools import kernel, kernel_build
from enctools.data.readings import HeadInfo
from enctools.methods.interp.bank import FitBank
from enctools.methods.interp.fit import InterpolationFit, SharedGrouping
from enctools.units import TWO_PI


@pytest.fixture
def compiled() -> None:
    kernel.library.cache_clear()
    if kernel.library() is None:
        pytest.skip("the compiled kernel is not built here")


def _counts_run(rng: np.random.Generator, n: int, ppr: int, steps: int, offset: int
                ) -> tuple[np.ndarray, list[np.ndarray]]:
    """A reference's counts and three devices' (of ``ppr`` periods of ``steps``)."""
    per_count = TWO_PI / (ppr * steps)
    ref_counts = np.cumsum(rng.integers(0, 60, n)) + offset
    ref = ref_counts * per_count
    devices = []
    for k in range(3):
        true = ref + 4e-5 * np.sin(ref * ppr + k) + 1e-5 * np.cos(2 * ref * ppr) + 1e-3 * k
        devices.append(np.rint((true + 3e-6 * rng.normal(size=n)) / per_count).astype(np.int64))
    return ref_counts, devices


def _feed(fused: bool, ref_counts: np.ndarray, devices: list[np.ndarray], ppr: int,
          steps: int, zero: int, degree: int, window: float | None, ref_orders: int,
          runs: np.ndarray | None) -> list:
    """The three devices' results fed as one bank, by the kernel or by the numpy passes."""
    per_count = TWO_PI / (ppr * steps)
    info = HeadInfo("H", "II", 0.0, ppr * steps, ppr, steps, 0.1, zero)
    ref_ppr = ppr * 7 // 4    # another encoder's period: its own harmonics land elsewhere
    fits = [InterpolationFit(ppr, harmonics=3, trend_degree=degree, window=window,
                             reference_orders=range(1, ref_orders + 1),
                             reference_periods_per_rev=ref_ppr, shared=SharedGrouping())
            for _ in devices]
    bank = FitBank.of(fits)[0]
    for a in range(0, ref_counts.size, 7_001):
        cut = slice(a, a + 7_001)
        r = ref_counts[cut] * per_count
        r_step = np.mod(np.floor(r * (ref_ppr * steps / TWO_PI)).astype(np.int64), steps) \
            if ref_orders else None
        groups = None if runs is None else runs[cut]
        if fused:
            assert bank.add_counts([c[cut] for c in devices], [info] * 3, r, r_step,
                                   steps if ref_orders else 0, groups)
            continue
        angles = [c[cut] * per_count for c in devices]
        st = [(np.mod(c[cut] + zero, steps), steps, r_step, steps if ref_orders else 0)
              for c in devices]
        phase = None if r_step is None else r_step * (TWO_PI / steps)
        bank.add(angles, r, st, groups, phase, None, [True] * 3)
    bank.close()
    return [f.result() for f in fits]


@pytest.mark.parametrize(("steps", "zero", "degree", "window", "ref_orders", "runs"), [
    (1024, 0, 1, 0.02, 0, False),        # windows, the devices' steps alone make X^T X
    (1024, 77, 1, 0.02, 2, False),       # the reference's harmonics alongside
    (1000, 1234, 2, 0.03, 0, False),     # steps not a power of two; a quadratic trend
    (1000, 5, 0, 0.03, 1, False),        # a constant per window
    (512, 3, 3, 0.05, 0, False),         # a cubic trend
    (1024, 0, 1, None, 2, True),         # a sweep's runs, one after another
])
def test_kernel_agrees_with_the_numpy_passes(compiled, steps, zero, degree, window,
                                             ref_orders, runs):
    rng = np.random.default_rng(5)
    n, ppr = 40_000, 512
    ref_counts, devices = _counts_run(rng, n, ppr, steps, -3_000_000)
    groups = np.repeat(np.arange(4), n // 4) if runs else None
    args = (ref_counts, devices, ppr, steps, zero, degree, window, ref_orders, groups)
    fused, numpy_ = _feed(True, *args), _feed(False, *args)
    grid = np.linspace(0.0, TWO_PI, 512, endpoint=False)
    for a, b in zip(fused, numpy_, strict=True):
        assert np.all(np.abs(b.fitted.coef[:2]) > 1.0)    # the error is there to find
        assert np.max(np.abs(a.error(grid) - b.error(grid))) < 1e-12
        assert np.max(np.abs(a.error.uncertainty(grid) - b.error.uncertainty(grid))) < 1e-12
        assert a.residual_rms == pytest.approx(b.residual_rms, rel=1e-10)
        assert (a.samples, a.windows, a.periods) == (b.samples, b.windows, b.periods)
        if ref_orders:
            assert a.reference is not None and b.reference is not None
            assert np.allclose(a.reference.coef, b.reference.coef, rtol=0, atol=1e-12)


def test_interleaved_runs_and_float_counts_take_the_numpy_passes(compiled):
    """Runs met out of order (a sweep's runs interleaved), counts with a null (float):
    the kernel declines and nothing is added."""
    fit = InterpolationFit(256, harmonics=2, window=None)
    bank = FitBank.of([fit])[0]
    info = HeadInfo("H", "II", 0.0, 256 * 1024, 256, 1024, 0.1, 0)
    c = np.arange(1000, dtype=np.int64) * 37
    r = c * (TWO_PI / (256 * 1024))
    assert not bank.add_counts([c], [info], r, None, 0, np.tile([0, 1], 500))
    assert not bank.add_counts([c.astype(float)], [info], r, None, 0, None)
    r_bad = r.copy()
    r_bad[3] = np.nan
    assert not bank.add_counts([c], [info], r_bad, None, 0, None)
    assert fit.lsq.n == 0


def test_environment_forces_the_numpy_passes(monkeypatch):
    monkeypatch.setenv(kernel.ENV, "numpy")
    kernel.library.cache_clear()
    try:
        assert kernel.library() is None
        assert kernel.name() == "numpy (ENCTOOLS_KERNEL=numpy)"
        bank = FitBank.of([InterpolationFit(512, harmonics=2, window=0.02)])[0]
        info = HeadInfo("H", "II", 0.0, 256 * 1024, 256, 1024, 0.1, 0)
        c = np.arange(1000, dtype=np.int64) * 37
        assert not bank.add_counts([c], [info], c * 1e-6, None, 0, None)
    finally:
        kernel.library.cache_clear()


def test_version_names_the_kernel_in_use(monkeypatch):
    monkeypatch.setenv(kernel.ENV, "numpy")
    kernel.library.cache_clear()
    try:
        r = run_in_process("enc --version")
    finally:
        kernel.library.cache_clear()
    assert r.returncode == 0
    assert r.stdout.decode().splitlines()[1] == "kernel: numpy (ENCTOOLS_KERNEL=numpy)"


def test_a_build_without_a_compiler_leaves_no_library(tmp_path, monkeypatch):
    """No compiler: the build says so and writes nothing (the install goes on)."""
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    out = tmp_path / "_enckernel.so"
    ok, seconds, message = kernel_build.build(kernel_build.SOURCE, out)
    assert not ok and message and seconds >= 0
    assert not out.exists() and not list(tmp_path.iterdir())


def test_the_build_makes_a_library_of_this_interface(tmp_path):
    """The source compiles with the flags of the install (where there is a compiler) into
    a library of the interface the loader expects, loadable by a fresh Python."""
    out = tmp_path / "_enckernel.so"
    ok, _, message = kernel_build.build(kernel_build.SOURCE, out)
    if not ok:
        pytest.skip(f"no C compiler here: {message}")
    code = ("import ctypes, sys; lib = ctypes.CDLL(sys.argv[1]); "
            "lib.enc_kernel_abi.restype = ctypes.c_int64; print(lib.enc_kernel_abi())")
    r = subprocess.run([sys.executable, "-c", code, str(out)], capture_output=True, text=True,
                       env=dict(os.environ), check=True)
    assert int(r.stdout) == kernel.ABI
