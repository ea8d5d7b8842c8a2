"""U = k u from repeats: Student's k at the degrees of freedom u rests on, stated and used.

- methods.budget: the degrees of freedom of a mean of R repeats, k at them, the Type B
  part by Welch-Satterthwaite on the column's mean variances; none for one repeat.
- enc selfcal and enc compare write dof, k and coverage into their u columns (R - 1
  per point, 2 (R - 1) per harmonic), their summaries state k, nu and U max, enc report
  uses the stated k; the field metadata is checked on reading (one line, exit 2).
- selfcal counts the heads' rounding as a bound only when the run samples the same
  angles every revolution; the U of such a run still covers its truth.

How often U covers the simulator's truth on 2, 3 and 5 revolutions over 20 seeds:
tests/lib/methods/test_accuracy.py. Units: arcsec, nm.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from conftest import ROOT, one_error_line, run, run_in_process
from test_budget import t_quantile

from enctools.data.streams import read_table
from enctools.data.truth import Truth
from enctools.methods.budget import repeats_dof, type_a_coverage
from enctools.methods.harmonics import synthesize
from enctools.methods.revolutions import Revolution
from enctools.methods.selfcal_uncertainty import SampleRepeats
from enctools.units import TWO_PI

SELFCAL = "selfcal raw.arrow --method esa --ref-head H1 --heads H5,H6,H7"


def enc_ok(args: str, cwd: Path) -> str:
    """``enc ARGS`` in this process; its stdout (it must succeed)."""
    r = run_in_process(args, cwd=cwd)
    assert r.returncode == 0, r.stderr.decode()
    return r.stdout.decode()


@pytest.fixture(scope="module")
def two_revolutions(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 2-revolution run of encoder II's heads, self-calibrated (deviations, spectrum)."""
    d = tmp_path_factory.mktemp("two")
    enc_ok("acquire --rig sjtu-dual --seed 4 --revolutions 2 --interval 0.012 "
           "--heads H1,H2,H3,H4,H5,H6,H7 -q -o raw.arrow", d)
    enc_ok(f"{SELFCAL} -q --spectrum spec.parquet -o grad.parquet", d)
    return d


def field(path: Path, column: str) -> dict[str, str]:
    f = pq.read_schema(path).field(column)
    return {k.decode(): v.decode() for k, v in (f.metadata or {}).items()}


# --------------------------------------------------------------- the shared function


@pytest.mark.parametrize("repeats, parts, dof", [(2, 1, 1), (3, 2, 4), (20, 2, 38), (1, 1, 0)])
def test_repeats_dof(repeats: int, parts: int, dof: int) -> None:
    assert repeats_dof(repeats, parts) == dof


def test_type_a_coverage_is_students_k() -> None:
    """Type A alone: k is the t quantile at its dof (12.71 at 1, 2.09 at 19)."""
    u = np.array([0.1, 0.3, 0.2])
    for dof in (1.0, 2.0, 19.0):
        cov = type_a_coverage(u, dof)
        assert cov is not None and cov.dof == dof
        assert cov.k == pytest.approx(t_quantile(0.975, dof), rel=1e-12)
    assert type_a_coverage(u, 1.0).k == pytest.approx(12.706, abs=1e-3)
    assert type_a_coverage(u, math.inf).k == pytest.approx(1.95996, abs=1e-5)


def test_type_a_coverage_with_a_bound_by_welch_satterthwaite() -> None:
    """u_a 0.3 on 4 dof, u_b 0.4 exact: nu = (0.09 + 0.16)^2 / (0.09^2 / 4) = 30.86, over
    the column's mean variances (the points' own u_a, 0.2 and sqrt(0.14), mean 0.09)."""
    u_a = np.array([0.2, math.sqrt(0.14)])
    cov = type_a_coverage(u_a, 4.0, 0.4)
    assert cov is not None
    assert cov.dof == pytest.approx(0.25 ** 2 / (0.09 ** 2 / 4), rel=1e-12)
    assert cov.k == pytest.approx(t_quantile(0.975, cov.dof), rel=1e-12)
    assert type_a_coverage(u_a, 4.0, 0.0).dof == 4.0


def test_no_coverage_without_an_estimate() -> None:
    """One repeat (0 dof) or an undetermined u: nothing is stated."""
    assert type_a_coverage(np.array([0.1]), 0.0) is None
    assert type_a_coverage(np.array([np.nan, 0.1]), 3.0) is None


def test_field_metadata_reads_back() -> None:
    cov = type_a_coverage(np.array([1.0]), 1.0)
    assert cov is not None
    assert cov.field_meta() == {"dof": "1", "k": "12.7062", "coverage": "0.95"}
    assert type_a_coverage(np.array([1.0]), math.inf).field_meta()["dof"] == "inf"


# -------------------------------------------------------------- what selfcal writes


def test_selfcal_states_k_and_dof_of_two_revolutions(two_revolutions: Path) -> None:
    """2 revolutions: 1 degree of freedom per point (k 12.71), 2 per harmonic (k 4.30)."""
    d = two_revolutions
    for column in ("u_graduation", "u_x", "u_y"):
        fm = field(d / "grad.parquet", column)
        assert (fm["dof"], fm["k"], fm["coverage"]) == ("1", "12.7062", "0.95"), column
    fm = field(d / "spec.parquet", "u_amplitude")
    assert (fm["dof"], fm["k"]) == ("2", "4.30265")
    header, _ = read_table(str(d / "grad.parquet"))
    assert header.meta["rounding_repeats"] is False


def test_selfcal_summary_states_k_nu_and_u(two_revolutions: Path) -> None:
    d = two_revolutions
    doc = json.loads(enc_ok(f"{SELFCAL} --json -o again.parquet", d))
    grad = next(c for c in doc["curves"] if c["name"] == "graduation")
    assert grad["coverage_k"] == pytest.approx(12.7062) and grad["dof"] == 1
    assert grad["expanded_u_max_arcsec"] == pytest.approx(12.7062 * grad["u_max_arcsec"])
    r = run_in_process(f"{SELFCAL} -o text.parquet", cwd=d)
    assert r.returncode == 0
    assert re.search(r"graduation: .*k 12\.706, nu 1, U max [0-9.]+\"", r.stderr.decode())


def test_report_uses_the_stated_k(two_revolutions: Path) -> None:
    """enc report: U of the curve and of every listed harmonic is the stated k times u."""
    d = two_revolutions
    doc = json.loads(enc_ok("report grad.parquet spec.parquet --json", d))
    curve = next(c for s in doc["sections"] for c in s.get("curves", [])
                 if c["name"] == "graduation")
    u = pq.read_table(d / "grad.parquet")["u_graduation"].to_numpy()
    assert curve["coverage_k"] == pytest.approx(12.7062)
    assert curve["expanded_u_max_arcsec"] == pytest.approx(12.7062 * u.max(), rel=1e-9)
    spec = pq.read_table(d / "spec.parquet")
    u_of = dict(zip(spec["n"].to_pylist(), spec["u_amplitude"].to_pylist(), strict=True))
    rows = next(s for s in doc["sections"] if s.get("spectra"))["spectra"][0]
    assert rows["coverage_k"] == pytest.approx(4.30265)
    for h in rows["harmonics"]:
        assert h["expanded_u_arcsec"] == pytest.approx(4.30265 * u_of[h["n"]], rel=1e-9)


@pytest.mark.parametrize("key, value", [("k", "nan"), ("k", "0.5"), ("dof", "0"),
                                        ("coverage", "1.5")])
def test_stated_coverage_out_of_range_is_refused(two_revolutions: Path, tmp_path: Path,
                                                 key: str, value: str) -> None:
    """A u column's dof, k, coverage out of range: one line naming them, exit 2."""
    from test_limits_streams import rewrite

    bad = rewrite(two_revolutions / "grad.parquet", tmp_path / "bad.parquet",
                  {"u_graduation": {key: value}})
    line = one_error_line(run(f"enc report {bad}"), 2, "enc report")
    assert "u_graduation" in line and key in line


# ----------------------------------------------------------- compare, the same rule


def test_compare_states_k_and_dof(tmp_path: Path) -> None:
    """enc compare H - P on 3 revolutions: 2 dof per point (k 4.30), 4 per harmonic
    (2.78); 1 revolution gives no spread, and no k is stated."""
    enc_ok("acquire --rig sjtu-dual --seed 2 --revolutions 3 --interval 0.012 "
           "--heads H1,H2,H3,H4,P1,P2 -q -o raw.arrow", tmp_path)
    enc_ok("average-heads raw.arrow -q -o avg.arrow", tmp_path)
    doc = json.loads(enc_ok("compare avg.arrow --device H --reference P --spectrum s.parquet "
                            "--json -o hp.parquet", tmp_path))
    assert (field(tmp_path / "hp.parquet", "u_H-P")["dof"],
            field(tmp_path / "hp.parquet", "u_H-P")["k"]) == ("2", "4.30265")
    assert field(tmp_path / "s.parquet", "u_amplitude")["k"] == "2.77645"
    assert doc["curves"][0]["coverage_k"] == pytest.approx(4.30265)
    enc_ok("acquire --rig sjtu-dual --seed 2 --revolutions 1.2 --interval 0.012 "
           "--heads H1,P1 -q -o one.arrow", tmp_path)
    enc_ok("compare one.arrow --device H1 --reference P1 -q -o one.parquet", tmp_path)
    assert "k" not in field(tmp_path / "one.parquet", "u_H1-P1")


# ------------------------------------------------ the rounding that repeats, or not


def revolution(index: int, positions: np.ndarray) -> Revolution:
    """A revolution whose coordinate samples ``positions`` [rad] from its start."""
    start = index * TWO_PI
    u = np.concatenate([start + positions, [start + TWO_PI]])
    return Revolution(index, start, u, np.zeros((1, u.size)))


def test_sample_repeats_tells_repeated_sampling_from_moving() -> None:
    """Samples at the same counts every revolution repeat; a drive whose angles move by
    fractions of the sample step (far more than a count) does not."""
    quantum = TWO_PI / 2 ** 28
    rng = np.random.default_rng(1)
    base = np.sort(rng.integers(0, 2 ** 28, 5000)) * quantum
    same, moving = SampleRepeats(quantum), SampleRepeats(quantum)
    for r in range(4):
        same.add(revolution(r, base))
        moving.add(revolution(r, np.sort((base + rng.uniform(0, 1e-3)) % TWO_PI)))
    assert same.repeated and not moving.repeated
    assert not SampleRepeats(quantum).repeated  # one revolution: nothing to tell


def steady_quiet_rig(tmp: Path) -> Path:
    """sjtu-dual with a steady drive, no noise, interpolation error or asynchronous motion:
    at 5 ms the heads read the same counts every revolution (their rounding repeats)."""
    text = (ROOT / "enctools" / "rigs" / "sjtu-dual.toml").read_text()
    for pattern, value in ((r"speed_error_ppm = [0-9.]+", "speed_error_ppm = 0.0"),
                           (r"jitter_arcsec = \[[0-9., ]+\]", "jitter_arcsec = [0.0, 0.0]"),
                           (r"position_noise_arcsec = [0-9.]+", "position_noise_arcsec = 0.0"),
                           (r"noise_arcsec = [0-9.]+", "noise_arcsec = 0.0"),
                           (r"asynchronous_rms_nm = [0-9.]+", "asynchronous_rms_nm = 0.0"),
                           (r"(?m)^signal = \{.*\}\n", "")):
        text = re.sub(pattern, value, text)
    path = tmp / "steady.toml"
    path.write_text(text)
    return path


def test_repeated_rounding_stays_in_u_and_is_covered(tmp_path: Path) -> None:
    """A run that reads the same counts every revolution: its rounding is the same in
    each, the spread between them does not hold it, and u keeps it as a bound; U then
    covers the truth within 100 harmonics at 90 % of the points or more (95.1 %), where
    the spread alone (2e-11") covers none of the 3.3e-4" RMS rounding error."""
    rig = steady_quiet_rig(tmp_path)
    enc_ok(f"acquire --rig {rig} --revolutions 3 --interval 0.005 "
           "--heads H1,H2,H3,H4,H5,H6,H7 -q -o raw.arrow", tmp_path)
    enc_ok(f"{SELFCAL} -q -o grad.parquet", tmp_path)
    header, table = read_table(str(tmp_path / "grad.parquet"))
    assert header.meta["rounding_repeats"] is True
    truth = Truth.from_dict(header.meta["truth"])
    g = table["graduation"].to_numpy()
    err = g - synthesize(truth.graduation["II"].harmonics(100), g.size)
    k = float(field(tmp_path / "grad.parquet", "u_graduation")["k"])
    assert np.mean(np.abs(err) <= k * table["u_graduation"].to_numpy()) >= 0.9


# ------------------------------------------------ repeated step runs in enc report


@pytest.mark.heavy
@pytest.mark.parametrize("runs, directions", [(3, 1), (5, 1), (5, 2), (10, 2)])
def test_repeated_step_run_points_u_covers_at_students_k(runs, directions):
    """The U of a point of a repeated step run (enc report's per-target mean, u from the
    approaches' scatter) covers its truth 93-97 % of the time at Student's k on the
    approaches' degrees of freedom (n - 1, Welch-Satterthwaite over both directions);
    k = 2 covers clearly less on 3 and 5 runs."""
    from enctools.report.sections import _means_and_u

    rng = np.random.default_rng(runs * 10 + directions)
    m, trials = 8, 1500
    truth = np.sin(np.arange(m) * TWO_PI / m)           # [arcsec]
    inside = inside_k2 = 0
    for _ in range(trials):
        index = np.tile(np.arange(m), runs * directions)
        direction = np.repeat([1, -1][:directions], m * runs)
        x = truth[index] + 0.05 * direction + rng.normal(0.0, 0.3, index.size)
        means, u, n_min, dof = _means_and_u(index, direction, x, m)
        assert n_min == runs and u is not None
        assert dof == pytest.approx((runs - 1) * directions, rel=0.5)
        k = type_a_coverage(u, dof).k
        err = np.abs(means - truth)
        inside += int(np.sum(err <= k * u))
        inside_k2 += int(np.sum(err <= 2.0 * u))
    fraction, fraction_k2 = inside / (m * trials), inside_k2 / (m * trials)
    assert 0.93 <= fraction <= 0.97, fraction
    if runs * directions <= 5:
        assert fraction_k2 < 0.92, fraction_k2


def test_enc_report_states_students_k_for_a_repeated_step_run(tmp_path):
    rng = np.random.default_rng(3)
    rows = ["position_deg,deviation_arcsec,direction,run"]
    for r in range(5):
        for d in (1, -1):
            rows += [f"{t * 45},{math.sin(math.radians(t * 45)) + rng.normal(0, 0.3):.5f},{d},{r}"
                     for t in range(8)]
    (tmp_path / "steps.csv").write_text("\n".join(rows) + "\n")
    out = json.loads(enc_ok("report steps.csv --json", tmp_path))
    curve = out["sections"][0]["curves"][0]
    assert 2.2 < curve["coverage_k"] < 2.4     # t(0.975) at about 8 degrees of freedom
