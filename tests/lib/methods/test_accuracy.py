"""The README's accuracy table ("What the methods recover") holds over 20 seeds.

``make accuracy`` (benchmarks/accuracy.py) measures every row at the README's sizes over
the simulator's noise seeds 1..20 and prints the table, each row's claim being its worst
seed. These tests run the same measurements (the same enc command lines, in this
process) over the same 20 seeds, on runs they can afford, and hold the worst seed to the
figure the README states for that size:

- the seed 000 campaign (selfcal esa, average-heads, compare H - P and P by H): 10
  revolutions at 12 ms instead of 20 at 5.05 ms (a fifth of the samples: about twice the
  error, which is noise);
- the sweep checks: the README's own runs (20 readings per step), the same figures;
- interp-check on a continuous run: 4 revolutions instead of 20;
- the RBF correction of a dense 23-bit run (test_rbf.py): one sample every 0.02 s
  instead of 0.002 s.

Units: arcsec, radial motion nm.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, run_in_process

sys.path.insert(0, str(ROOT / "benchmarks"))
import accuracy

SEEDS = range(1, 21)


@pytest.fixture(autouse=True)
def in_process(monkeypatch: pytest.MonkeyPatch) -> None:
    """The measurements' enc commands run in this process (no interpreter start-up each)."""
    monkeypatch.setattr(accuracy, "RUN", lambda args, cwd: run_in_process(args, cwd=cwd))


def over_seeds(measure: Callable[..., dict[str, float]], **size: float) -> dict[str, np.ndarray]:
    """{figure: its values over the 20 seeds} of one measurement at ``size``."""
    return accuracy.over_seeds(measure, SEEDS, **size)


@pytest.mark.slow
def test_seed000_campaign_over_20_seeds() -> None:
    """selfcal esa: RMS over harmonics 1..100 and x, y; the share of errors inside U;
    compare H - P; P by H and the self-calibrated curve, and its +/- against the truth's
    within 100 harmonics (+/-0.262"; +/-0.270" with the harmonics above 100 that no
    method sees)."""
    f = over_seeds(accuracy.continuous_campaign, revolutions=10, interval=0.012)
    truth = accuracy.truth_of_averages()
    assert f["esa_rms"].max() <= 0.0025
    assert max(f["x_rms_nm"].max(), f["y_rms_nm"].max()) <= 2.0
    assert 0.93 <= f["inside_U"].mean() <= 0.97
    assert f["h_p_max"].max() <= 0.004
    assert f["p_max"].max() <= 0.0055
    assert np.abs(f["p_pm"] - truth["p_pm_100"]).max() <= 0.003
    assert np.abs(f["h_pm"] - truth["h_pm_100"]).max() <= 0.003
    assert truth["p_pm_100"] == pytest.approx(0.262, abs=5e-4)
    assert truth["p_pm_all"] == pytest.approx(0.270, abs=5e-4)
    assert truth["h_pm_100"] == pytest.approx(0.167, abs=5e-4)


@pytest.mark.slow
@pytest.mark.parametrize("revolutions", [2, 3, 5])
def test_selfcal_u_covers_the_truth_on_few_revolutions(revolutions: int) -> None:
    """selfcal esa on 2, 3 and 5 revolutions (12 ms) over the 20 seeds: U = k u with the
    k the outputs state (Student's t, curve / harmonics: 12.7 / 4.30, 4.30 / 2.78,
    2.78 / 2.31) covers the truth within 100 harmonics at 93 to 97 % of the curve's
    points and of the harmonics' re, im, pooled over the seeds (measured 95.1 / 94.9,
    94.8 / 94.7, 95.1 / 95.3 %). With k = 2 the curve was covered at 71, 82, 88 %."""
    f = over_seeds(accuracy.selfcal_coverage, revolutions=revolutions, interval=0.012)
    assert 0.93 <= f["curve"].mean() <= 0.97
    assert 0.93 <= f["harmonics"].mean() <= 0.97
    assert f["curve_k2"].mean() < 0.93


@pytest.mark.slow
def test_compare_u_covers_the_truth_on_two_revolutions() -> None:
    """compare H - P on 2 revolutions (12 ms) over the 20 seeds: U = k u (k 12.7 per
    point, 4.30 per harmonic) covers the truth at 93 to 97 % of the points and of the
    harmonics' re, im (measured 94.5 / 95.2 %); k = 2 covered 70 / 82 %."""
    f = over_seeds(accuracy.compare_coverage, revolutions=2, interval=0.012)
    assert 0.93 <= f["curve"].mean() <= 0.97
    assert 0.93 <= f["harmonics"].mean() <= 0.97
    assert f["curve_k2"].mean() < 0.9


@pytest.mark.slow
def test_quiet_selfcal_has_no_random_input() -> None:
    """Without noise, interpolation error and quantisation the seed changes nothing."""
    f = over_seeds(accuracy.quiet_selfcal, revolutions=2)
    assert np.ptp(f["quiet_rms"]) == 0.0
    assert f["quiet_rms"].max() <= 1e-5


@pytest.mark.slow
def test_sweep_checks_over_20_seeds() -> None:
    """The README's runs: every head against the probes, and H1, H2 against P1."""
    f = over_seeds(accuracy.sweep_checks, readings=20)
    assert f["probes_max"].max() <= 0.009
    assert f["by_p1_max"].max() <= 0.007


@pytest.mark.slow
def test_continuous_interp_over_20_seeds() -> None:
    f = over_seeds(accuracy.continuous_interp, revolutions=4)
    assert f["run_max"].max() <= 0.0006


def test_readme_table_is_the_scripts(tmp_path: Path) -> None:
    """The README's table has the script's rows in its order, with their targets; the
    rows without a random input are measured here and read as the README says."""
    text = (ROOT / "README.md").read_text()
    head = "| method | result: worst of 20 seeds (median) | paper / target |"
    assert head in text
    lines = text[text.index(head):].split("\n\n")[0].splitlines()[2:]
    cells = [[c.strip() for c in line.strip("|").split(" | ")] for line in lines]
    rows = accuracy.rows()
    assert [(c[0], c[2]) for c in cells] == [(r.method, r.target) for r in rows]
    fixed = accuracy.fixed_rows(tmp_path)
    for c, r in zip(cells, rows, strict=True):
        if r.measure is None:
            assert c[1] == fixed[r.key], r.key
