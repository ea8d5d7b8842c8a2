"""A linear axis's ISO 230-2 test in um, from an interferometer's log to the report.

The log is written here line by line as a laser interferometer's ISO 230-2 export gives
it: a column of targets in mm and one column of deviations in µm per run and direction
(11 targets x 5 runs x 2 directions, ISO 230-2:2014's test cycle). Its figures are
computed here again from the standard's formulas (sec. 3.3), with the standard's
x = actual - target, which is -deviation (enctools' deviation is indicated - true).
"""

from __future__ import annotations

import json

import numpy as np
from conftest import run

TARGETS_MM = np.arange(11) * 50.0           # 0 .. 500 mm
RUNS = 5


def _deviation_um(target: float, run: int, up: bool) -> float:
    """The indicated - true deviation [um] of one approach: a pitch error, a reversal
    of 1.2 um and a run-to-run scatter, rounded as the log prints it (0.01 um)."""
    scatter = 0.13 * np.sin(1.7 * run + target / 37.0) + 0.05 * ((run * 7 + int(target)) % 3 - 1)
    value = 3.0 * np.sin(target / 160.0) - 0.004 * target + (0.6 if up else -0.6) + scatter
    return round(float(value), 2)


def _log() -> tuple[str, dict[tuple[bool, int], np.ndarray]]:
    """The log's text and its deviations [um] by (up, run), one per target."""
    dev = {(up, r): np.array([_deviation_um(t, r, up) for t in TARGETS_MM])
           for up in (True, False) for r in range(1, RUNS + 1)}
    titles = ["Target [mm]"] + [f"Run {r} {'↑' if up else '↓'} [µm]"
                                for up in (True, False) for r in range(1, RUNS + 1)]
    lines = ["# Linear positioning test to ISO 230-2:2014, axis X",
             "# Deviation = indicated - interferometer reading, in µm", "\t".join(titles)]
    for i, t in enumerate(TARGETS_MM):
        cells = [f"{t:.3f}"] + [f"{dev[up, r][i]:.2f}" for up in (True, False)
                                for r in range(1, RUNS + 1)]
        lines.append("\t".join(cells))
    return "\n".join(lines) + "\n", dev


def _by_hand(dev: dict[tuple[bool, int], np.ndarray]) -> dict[str, float]:
    """ISO 230-2:2014 sec. 3.3 from the deviations: x = -deviation [um]."""
    x = {up: np.array([-dev[up, r] for r in range(1, RUNS + 1)]) for up in (True, False)}
    mean = {up: x[up].mean(axis=0) for up in x}
    s = {up: x[up].std(axis=0, ddof=1) for up in x}
    B_i = mean[True] - mean[False]
    R_i = np.maximum.reduce([2 * s[True] + 2 * s[False] + np.abs(B_i), 4 * s[True], 4 * s[False]])
    both = np.concatenate([mean[True], mean[False]])
    hi = np.concatenate([mean[True] + 2 * s[True], mean[False] + 2 * s[False]])
    lo = np.concatenate([mean[True] - 2 * s[True], mean[False] - 2 * s[False]])
    mid = (mean[True] + mean[False]) / 2
    return {"A": hi.max() - lo.min(), "B": np.abs(B_i).max(), "B_mean": B_i.mean(),
            "E": both.max() - both.min(), "M": mid.max() - mid.min(), "R": R_i.max(),
            "R_up": 4 * s[True].max(), "R_down": 4 * s[False].max()}


def _wide(tmp_path) -> tuple[str, dict[tuple[bool, int], np.ndarray]]:
    """The log written to x-axis.txt, and the options that map its columns."""
    text, dev = _log()
    (tmp_path / "x-axis.txt").write_text(text, encoding="utf-8")
    up = ",".join(f"Run {r} ↑ [µm]" for r in range(1, RUNS + 1))
    down = ",".join(f"Run {r} ↓ [µm]" for r in range(1, RUNS + 1))
    return f"--position 1 --forward '{up}' --reverse '{down}'", dev


def test_a_linear_axis_iso230_run_in_um_equals_the_standards_formulas(tmp_path):
    wide, dev = _wide(tmp_path)
    r = run(f"enc points x-axis.txt {wide} -q "
            "-o p.parquet && enc report p.parquet --json > r.json && enc report p.parquet "
            "> r.txt && enc report p.parquet --standard vdi3441 > v.txt && "
            "enc report p.parquet --html r.html -q > /dev/null && enc info p.parquet > i.txt",
            cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    section = json.loads((tmp_path / "r.json").read_text())["sections"][0]
    iso = section["iso230_2"]
    assert iso["unit"] == "um" and section["info"]["axis"] == "linear"
    want = _by_hand(dev)
    for key, value in want.items():
        assert np.isclose(iso["axis"][key], value, rtol=0, atol=1e-9), key
    assert want["B_mean"] < 0       # the standard's sign: x up - x down, x = -deviation
    assert [row["position_mm"] for row in iso["positions"]] == TARGETS_MM.tolist()
    assert iso["warnings"] == []
    # units carried, no angle's unit anywhere: text, VDI, HTML, enc info
    report = (tmp_path / "r.txt").read_text()
    assert "ISO 230-2 (R = 4s, A with +/-2s) [um]" in report and "pos [mm]" in report
    assert "no harmonics, no closure of 0 and 360" in report
    vdi = (tmp_path / "v.txt").read_text()
    assert "VDI/DGQ 3441 (Ps = 6s, P with (U + Ps)/2) [um]" in vdi
    info = (tmp_path / "i.txt").read_text()
    assert "position     double   [mm]" in info and "deviation    double   [um]" in info
    html = (tmp_path / "r.html").read_text()
    html = html[:html.find("References")] if "References" in html else html
    for shown in (report, vdi, info, html, (tmp_path / "r.json").read_text()):
        assert "arcsec" not in shown and " deg" not in shown and "[deg]" not in shown


def test_a_rotary_points_reversal_has_the_standards_sign(tmp_path):
    """A points stream's deviation is indicated - true: approached from below it reads
    1 arcsec high, so the axis stands 1 arcsec short (x = -1) and B_i = x up - x down
    = -2 arcsec, as ISO 230-2 defines it."""
    rows = ["position [deg],deviation [arcsec],direction,run"]
    for run_ in range(1, 6):
        for d, sign in ((1, 1.0), (-1, -1.0)):
            rows += [f"{t},{sign * 1.0 + 0.01 * run_},{d},{run_}" for t in range(0, 360, 45)]
    (tmp_path / "rot.csv").write_text("\n".join(rows) + "\n")
    r = run("enc report rot.csv --json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    iso = json.loads(r.stdout)["sections"][0]["iso230_2"]
    assert np.isclose(iso["axis"]["B_mean"], -2.0) and np.isclose(iso["axis"]["B"], 2.0)
    assert all(np.isclose(row["B"], -2.0) for row in iso["positions"])


def test_an_arcsec_limit_is_not_checked_against_a_linear_axis_um(tmp_path):
    wide, _ = _wide(tmp_path)
    r = run(f"enc report x-axis.txt {wide} --max-iso A:1000", cwd=tmp_path)
    assert r.returncode == 1
    assert "a linear axis's figures are in um; --max-iso/--max-vdi" in r.stderr.decode()
