"""Streaming filters at speed without losing accuracy: the bin-expanded per-revolution
sums against the exact direct sum, pipe buffers, and interp-check streaming a long run.
Tolerances in the tests; no wall-clock assertions."""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest
from conftest import run

from enctools.methods.harmonics import (
    _binned_sums,
    _direct_sums,
    revolution_coefficients,
    trapezoid_weights,
)

TWO_PI = 2 * np.pi


def exact_sums(x: np.ndarray, v: np.ndarray, band: int) -> np.ndarray:
    """sum_j w_j v_cj exp(-i n x_j) with every exponential evaluated on its own."""
    w = trapezoid_weights(x)
    e = np.exp(-1j * np.outer(np.arange(band + 1), x)) * w
    return v @ e.T


@pytest.mark.heavy
@pytest.mark.parametrize("samples,band,direction,wobble", [
    (11881, 100, 1, 1e-4),     # the sjtu-dual default: 11 881 samples (5.05 ms), 100 harmonics
    (20000, 100, 1, 1e-4),     # the paper's 3 ms: 20 000 samples
    (20000, 100, -1, 1e-4),    # turning backwards
    (3001, 20, 1, 0.0),        # uniform
    pytest.param(200000, 100, 1, 1e-3, marks=pytest.mark.slow),  # fine, large speed variation
    (1000, 150, 1, 2e-3),      # coarse: more bins than samples
    (20000, 3, 1, 0.05),       # very uneven speed
    (20000, 1, 1, 1e-4),       # one harmonic: few wide bins
    (20000, 300, -1, 1e-4),    # many harmonics, backwards
])
def test_binned_sums_equal_the_exact_sum(samples: int, band: int, direction: int,
                                        wobble: float) -> None:
    """The bin expansion agrees with the exact sum to 1e-13 of the largest coefficient
    (rounding only: its truncation is below 2^-56)."""
    rng = np.random.default_rng(samples + band)
    k = np.arange(samples + 1)
    x = direction * (k * TWO_PI / samples + wobble * np.sin(TWO_PI * 3 * k / samples)
                     + 1e-7 * rng.standard_normal(samples + 1))
    x[0], x[-1] = 0.0, direction * TWO_PI
    v = rng.standard_normal((3, samples + 1)) + np.cos(7 * x)
    want = exact_sums(x, v, band)
    got = _binned_sums(x, v, trapezoid_weights(x), band)
    assert got is not None
    assert np.max(np.abs(got - want)) < 1e-13 * np.max(np.abs(want))
    direct = _direct_sums(x, v, trapezoid_weights(x), band)
    assert np.max(np.abs(direct - want)) < 1e-12 * np.max(np.abs(want))


def test_a_long_stop_falls_back_to_the_direct_sum() -> None:
    """Half the samples within one bin (a stop): no padded layout, the direct sum."""
    x = np.concatenate([np.linspace(0, 3.0, 5000), np.linspace(3.0, 3.0005, 5000)[1:],
                        np.linspace(3.0005, TWO_PI, 5000)[1:]])
    v = np.cos(5 * x)[None, :]
    assert _binned_sums(x, v, trapezoid_weights(x), 20) is None
    c = revolution_coefficients(x, v, 0.0, 20)[0]
    assert abs(c[5] - 1) < 1e-4 and np.max(np.abs(np.delete(c, 5))) < 1e-4


def test_few_samples_fall_back_to_the_direct_sum() -> None:
    x = np.linspace(0, TWO_PI, 101)
    v = np.sin(2 * x)[None, :]
    assert _binned_sums(x, v, trapezoid_weights(x), 10) is None
    c = revolution_coefficients(x, v, 0.0, 10)[0]
    assert abs(c[2] - (-1j)) < 1e-3  # sin 2u = Re(-i exp(2iu)), trapezoid on 100 steps


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="F_SETPIPE_SZ is Linux")
def test_enlarge_pipe() -> None:
    from enctools.data.pipes import PIPE_BUFFER, enlarge_pipe

    r, w = os.pipe()
    try:
        got = enlarge_pipe(r)
        assert got is None or got >= min(PIPE_BUFFER, 1 << 16)
    finally:
        os.close(r)
        os.close(w)
    with open(os.devnull, "rb") as f:
        assert enlarge_pipe(f) is None  # not a pipe: left alone


@pytest.mark.slow
def test_interp_check_streams_a_long_run(tmp_path) -> None:
    """A continuous run of 100 revolutions (1.19 M samples, past the old 1 000 000 limit)
    piped in is fitted, not refused, and gives H1's harmonics of 20 revolutions (the same
    seed) within 4 combined standard uncertainties."""
    from enctools.data.streams import read_table

    acquire = "enc acquire --rig sjtu-dual --interval 0.00505 --heads H1,P1"
    res = {}
    for revs in (20, 100):
        out = tmp_path / f"ic{revs}.arrows"
        r = run(f"{acquire} --revolutions {revs} | enc interp-check --reference P1 -q -o {out}")
        assert r.returncode == 0, r.stderr.decode()
        res[revs] = read_table(out)[0].meta["curves"]["H1"]
    assert res[100]["samples"] > 1_000_000
    for short, long in zip(res[20]["harmonics"], res[100]["harmonics"], strict=False):
        c = [h["amplitude"] * np.exp(1j * h["phase"]) for h in (short, long)]
        assert abs(c[0] - c[1]) < 4 * np.hypot(short["u"], long["u"]), (short, long)


WRITE_THEN_STALL = """
import sys, time
import pyarrow as pa, pyarrow.parquet as pq
t = pq.read_table(sys.argv[1])
bad = t.slice(0, 30000)
tcol = bad.column("t").to_numpy().copy()
tcol[20000] = float("nan")
bad = bad.set_column(bad.schema.get_field_index("t"), bad.schema.field("t"), pa.array(tcol))
with pa.ipc.new_stream(sys.stdout.buffer, t.schema) as w:
    w.write_table(t.slice(0, 20000))
    w.write_table(bad)
    sys.stdout.buffer.flush()
    time.sleep(60)  # the writer goes quiet, the pipe stays open
"""


@pytest.mark.parametrize("command", ["compare --device H1 --reference P1", "selfcal"])
@pytest.mark.slow
def test_an_error_mid_stream_ends_at_once_while_the_writer_is_quiet(
        tmp_path, sjtu_raw, command: str) -> None:
    """Bad data after the first batch, then a writer that neither writes nor closes: the
    filter reports it (one line, exit 2) within seconds, its read-ahead thread stopped
    (no abort at exit, no wait for the writer)."""
    import subprocess
    import time

    from conftest import enc_exe

    writer = tmp_path / "writer.py"
    writer.write_text(WRITE_THEN_STALL)
    w = subprocess.Popen([sys.executable, str(writer), str(sjtu_raw)], stdout=subprocess.PIPE)
    try:
        t0 = time.monotonic()
        r = subprocess.run([enc_exe(), *command.split(), "-o", str(tmp_path / "out.parquet")],
                           stdin=w.stdout, capture_output=True, timeout=50)
        took = time.monotonic() - t0
    finally:
        w.kill()
        w.wait()
    err = r.stderr.decode()
    assert r.returncode == 2, err
    assert "NaN" in err and "Traceback" not in err and "terminate" not in err, err
    assert not (tmp_path / "out.parquet").exists()
    assert took < 30  # not waiting for the writer's 60 s
