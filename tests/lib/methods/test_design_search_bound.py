"""enc design --search: its count is known before it starts, it is bounded, it ends on a
signal (enc-design(1), LIMITS of enc(1))."""

from __future__ import annotations

import subprocess
from itertools import combinations, pairwise

import numpy as np
import pytest
from conftest import enc_exe, run

from enctools.errors import SettingsError
from enctools.methods import design


def _brute(m: int, step: float, gap: float) -> int:
    """Every increasing m-tuple of grid slots in (0, 360), neighbours (and 0, 360) at least
    ``gap`` apart: counted one by one."""
    vals = [k * step for k in range(1, round(360.0 / step))]
    count = 0
    for row in combinations(vals, m):
        full = (0.0, *row, 360.0)
        count += all(b - a >= gap - 1e-9 for a, b in pairwise(full))
    return count


@pytest.mark.parametrize(("m", "step", "gap"), [
    (1, 10.0, 10.0), (2, 7.0, 20.0), (3, 13.5, 0.0), (2, 11.390625, 10.0), (3, 5.0, 35.0),
    (1, 0.7, 0.5), (3, 17.0859375, 10.0), (2, 45.0, 120.0), (2, 3.0, 179.0),
])
def test_the_grid_is_counted_as_enumerated(m: int, step: float, gap: float) -> None:
    expected = _brute(m, step, gap)
    assert design._grid_count(m, step, gap) == expected
    assert design._grid(m, step, gap).shape == (expected, m)


def test_a_search_scores_no_more_than_its_plan_and_says_so() -> None:
    plan = design.plan_search(3, 20, "fourier", 3.0)
    seen: list[tuple[int, int]] = []
    res = design.search(3, 20, "fourier", 3.0, max_candidates=plan.total,
                        progress=lambda done, most: seen.append((done, most)))
    assert plan.grid == design._grid_count(2, 3.0, 10.0)
    assert plan.grid < res.evaluated <= plan.total
    assert seen and all(d <= m for d, m in seen)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)
    assert seen[-1] == (res.evaluated, res.evaluated)


def test_the_bound_is_honoured_before_anything_is_scored() -> None:
    plan = design.plan_search(4, 100)
    called: list[int] = []
    with pytest.raises(SettingsError, match=f"up to {plan.total} arrangements.*more than "
                                            f"max_candidates {plan.total - 1}"):
        design.search(4, 100, max_candidates=plan.total - 1,
                      progress=lambda done, most: called.append(done))
    assert not called
    with pytest.raises(SettingsError, match="max_candidates 10:"):
        design.Settings(search_heads=4, max_candidates=10)


def test_eight_heads_are_refused_by_default_at_once() -> None:
    r = run("enc design --search 8 --band 2000", timeout=30)
    assert r.returncode == 2
    lines = r.stderr.decode().splitlines()
    assert len(lines) == 1 and "more than --max-candidates 2000000" in lines[0]


def test_the_count_is_said_on_stderr_but_not_with_q() -> None:
    r = run("enc design --search 3 --band 20 --method fourier --search-step 3")
    plan = design.plan_search(3, 20, "fourier", 3.0)
    assert r.returncode == 0
    assert f"enc design: scoring at most {plan.total} arrangements of 3 heads" in r.stderr.decode()
    r = run("enc design --search 3 --band 20 --method fourier --search-step 3 -q")
    assert r.returncode == 0 and r.stderr == b""


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGINT"])
def test_a_signal_ends_a_long_search_within_a_second(sig: str) -> None:
    import signal
    import time

    p = subprocess.Popen([enc_exe(), "design", "--search", "6", "--band", "2000",
                          "--max-candidates", "100000000"], stderr=subprocess.PIPE,
                         stdout=subprocess.PIPE)
    time.sleep(2.0)
    assert p.poll() is None
    sent = time.monotonic()
    p.send_signal(getattr(signal, sig))
    out, err = p.communicate(timeout=30)
    assert time.monotonic() - sent < 1.0
    assert p.returncode == 128 + getattr(signal, sig), err
    assert out == b"" and err.decode().splitlines()[-1].startswith("enc design: error:")


@pytest.mark.heavy
def test_search_results_are_the_same_as_before() -> None:
    """The grid built slot by slot scores the same candidates as the former filtered
    product: the seed's search finds the same arrangement."""
    res = design.search(4, 100)
    assert res.angles_deg == (0.0, 112.3, 231.44, 292.42) and res.evaluated == 485696
    assert np.isclose(res.score, 1.1947573273300363)


def test_a_signal_started_ignored_stays_ignored() -> None:
    """nohup and a shell's background jobs start a command with SIGHUP, or SIGINT and
    SIGQUIT, ignored: it keeps them ignored (errors.ending_signals), SIGTERM still ends it."""
    import signal
    import time

    def ignore() -> None:
        for sig in (signal.SIGINT, signal.SIGQUIT, signal.SIGHUP):
            signal.signal(sig, signal.SIG_IGN)

    p = subprocess.Popen([enc_exe(), "design", "--search", "6", "--band", "2000",
                          "--max-candidates", "100000000"], stderr=subprocess.PIPE,
                         stdout=subprocess.PIPE, preexec_fn=ignore)
    try:
        time.sleep(2.0)
        for sig in (signal.SIGINT, signal.SIGQUIT, signal.SIGHUP):
            p.send_signal(sig)
        time.sleep(1.0)
        assert p.poll() is None
        p.send_signal(signal.SIGTERM)
        p.communicate(timeout=30)
        assert p.returncode == 128 + signal.SIGTERM
    finally:
        p.kill()
        p.wait()
