"""A log printed with ISO 230-2's sign, read right with --deviation-sign actual-target.

ISO 230-2:2014 (3.1, positional deviation) and VDI/DGQ 3441 give the deviation of an
approach as x_ij = P_ij - P_i: the actual position reached minus the target. enctools'
deviation is indicated - true: the axis stands where its own scale reads the target, so
x = -deviation. A motion controller's positioning-test export prints x itself; read as
given, its reversal and mean deviations came out with the opposite sign. The log below
is written as such an export gives it, one line per approach (target, run, direction,
x in µm); its figures are computed here again from the standard's formulas on x.
"""

from __future__ import annotations

import json

import numpy as np
from conftest import one_error_line, run

TARGETS_MM = np.array([0.0, 60.0, 120.0, 180.0, 240.0, 300.0])
RUNS = 5
OPTIONS = "--position 1 --run 2 --direction 3 --deviation 4"


def _x_um(target: float, run: int, up: bool) -> float:
    """x = actual - target [µm] of one approach: a pitch error, a backlash that leaves the
    axis 0.9 µm short approaching from below (x up < x down), a scatter; 0.01 µm."""
    value = (2.0 * np.sin(target / 90.0) + 0.003 * target + (-0.45 if up else 0.45)
             + 0.11 * np.cos(1.3 * run + target / 41.0))
    return round(float(value), 2)


def _log(tmp_path) -> dict[bool, np.ndarray]:
    """The export written to x-iso.csv; x [µm] by direction, [run, target]."""
    x = {up: np.array([[_x_um(t, r, up) for t in TARGETS_MM] for r in range(1, RUNS + 1)])
         for up in (True, False)}
    lines = ["# Axis X positioning test, ISO 230-2:2014, bidirectional, 5 cycles",
             "# Position deviation x = P_ij - P_i (actual - target), interferometer",
             "Target position [mm];Cycle;Approach;Position deviation [µm]"]
    for r in range(1, RUNS + 1):
        for up in (True, False):
            order = TARGETS_MM if up else TARGETS_MM[::-1]
            for t in order:
                k = int(np.flatnonzero(t == TARGETS_MM)[0])
                lines.append(f"{t:.3f};{r};{1 if up else -1};{x[up][r - 1, k]:.2f}")
    (tmp_path / "x-iso.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return x


def _report(tmp_path, extra: str) -> dict:
    r = run(f"enc points x-iso.csv {OPTIONS} {extra} -q --force -o p.parquet && "
            "enc report p.parquet --json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout)["sections"][0]["iso230_2"]


def test_an_iso_log_read_with_its_sign_gives_the_standards_reversal(tmp_path):
    x = _log(tmp_path)
    mean = {up: x[up].mean(axis=0) for up in x}
    b_i = mean[True] - mean[False]                      # ISO 230-2 3.3: B_i = x_i up - x_i down
    iso = _report(tmp_path, "--deviation-sign actual-target")
    assert np.isclose(iso["axis"]["B_mean"], b_i.mean(), rtol=0, atol=1e-9)
    assert np.isclose(iso["axis"]["B"], np.abs(b_i).max(), rtol=0, atol=1e-9)
    assert iso["axis"]["B_mean"] < 0                     # the axis stops short from below
    rows = iso["positions"]
    assert [row["position_mm"] for row in rows] == TARGETS_MM.tolist()
    for k, row in enumerate(rows):                       # the systematic deviations x_i
        assert np.isclose(row["mean_up"], mean[True][k], rtol=0, atol=1e-9)
        assert np.isclose(row["mean_down"], mean[False][k], rtol=0, atol=1e-9)
        assert np.isclose(row["B"], b_i[k], rtol=0, atol=1e-9)
    mid = (mean[True] + mean[False]) / 2
    assert np.isclose(iso["axis"]["M"], mid.max() - mid.min(), rtol=0, atol=1e-9)
    # read as given (indicated - true), every signed figure comes out the other way
    plain = _report(tmp_path, "")
    assert np.isclose(plain["axis"]["B_mean"], -b_i.mean(), rtol=0, atol=1e-9)
    assert np.isclose(plain["axis"]["B"], iso["axis"]["B"], rtol=0, atol=1e-12)


def test_a_wide_log_takes_the_sign_once(tmp_path):
    """A column per cycle and approach (--forward/--reverse): negated once, not twice."""
    x = _log(tmp_path)
    titles = ["Target [mm]"] + [f"C{r} {'up' if up else 'down'} [um]" for up in (True, False)
                                for r in range(1, RUNS + 1)]
    rows = ["\t".join(titles)] + ["\t".join([f"{t:.3f}"] + [f"{x[up][r, k]:.2f}"
                                                            for up in (True, False)
                                                            for r in range(RUNS)])
                                  for k, t in enumerate(TARGETS_MM)]
    (tmp_path / "wide.txt").write_text("\n".join(rows) + "\n")
    up = ",".join(str(2 + r) for r in range(RUNS))
    down = ",".join(str(2 + RUNS + r) for r in range(RUNS))
    r = run(f"enc report wide.txt --position 1 --forward {up} --reverse {down} "
            "--deviation-sign actual-target --json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    iso = json.loads(r.stdout)["sections"][0]["iso230_2"]
    b_i = x[True].mean(axis=0) - x[False].mean(axis=0)
    assert np.isclose(iso["axis"]["B_mean"], b_i.mean(), rtol=0, atol=1e-9)


def test_the_sign_of_a_table_without_a_deviation_column_is_refused(tmp_path):
    (tmp_path / "t.csv").write_text("reference [deg],measured [deg]\n0,0.001\n90,90.002\n")
    r = run("enc points t.csv --deviation-sign actual-target -o p.parquet", cwd=tmp_path)
    line = one_error_line(r, 2, "enc points")
    assert "--deviation-sign is the sign of a deviation column" in line
    assert not (tmp_path / "p.parquet").exists()
