"""enc report: the certificate's column after the correction shipped with the item
(ISO/IEC 17025:2017 7.8.4.1 d) is a held-out residual: at each target the error model
was fitted to, the deviation less the model refitted without that target (enc fit-rbf
keeps those predictions, ``residuals.held_out``), not the fit's own residual."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import run

from enctools.models import fitting


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """A polygon run's 24 points, a Fourier series of order 4 fitted to them, and the
    report of both as JSON."""
    d = tmp_path_factory.mktemp("after")
    raw, points, model = d / "raw.parquet", d / "points.parquet", d / "model.parquet"
    for cmd in (f"enc acquire --rig ciomp-23bit --mode steps --readings 1 -o {raw}",
                f"enc points {raw} -o {points}",
                f"enc fit-rbf {points} --kernel fourier --band 4 -o {model}"):
        r = run(cmd)
        assert r.returncode == 0, r.stderr.decode()
    r = run(f"enc report --json {points} {model}")
    assert r.returncode == 0, r.stderr.decode()
    text = run(f"enc report {points} {model}")
    assert text.returncode == 0, text.stderr.decode()
    return json.loads(r.stdout), text.stdout.decode()


def test_after_the_correction_is_the_leave_one_out_residual(report):
    """Each row's after-correction value is its deviation less the series refitted on the
    other 23 targets (by brute force here), to the rounding of the printed figures; the
    fit's own residuals are smaller by about 1 - (2K + 1)/24 and would fail this."""
    doc, text = report
    rows = doc["sections"][0]["results"][0]["rows"]
    assert len(rows) == 24
    x = np.array([r["target_deg"] for r in rows])
    y = np.array([r["deviation_arcsec"] for r in rows])
    after = np.array([r["deviation_after_correction_arcsec"] for r in rows])
    settings = fitting.Settings("fourier", harmonics=4)
    loo = np.empty_like(y)
    for i in range(x.size):
        keep = np.arange(x.size) != i
        refit = fitting.fit_points(x[keep], y[keep], settings).model
        loo[i] = y[i] - float(refit(np.array([x[i]]))[0])
    training = y - fitting.fit_points(x, y, settings).model(x)
    assert np.max(np.abs(loo - training)) > 0.01        # the two differ here
    np.testing.assert_allclose(after, loo, atol=3e-3)
    assert "held-out residual" in " ".join(text.split())


def test_the_correction_states_its_u_at_any_angle(report):
    """The note under the table and the JSON state the U of the correction at any angle:
    2 sqrt(held-out^2 + band^2) from the model's terms (enc fit-rbf's
    ``residuals.correction_u``), the table's quantisation named as not included (no table
    among the inputs); before, the certificate said "U –" of the correction."""
    doc, text = report
    c = doc["sections"][0]["results"][0]["correction_at_any_angle"]
    held, band, quant = (t["standard_u_arcsec"] for t in c["terms"])
    assert quant is None and held > 0 and band > 0
    assert c["coverage_k"] == 2
    assert c["expanded_u_arcsec"] == pytest.approx(2 * np.hypot(held, band), abs=2e-3)
    flat = " ".join(text.split())
    assert "U of the correction at any angle: " in flat
    assert "(not included: no table among the inputs)" in flat


def test_a_table_among_the_inputs_adds_half_an_lsb(tmp_path):
    """With the table written (a 256-entry ROM of 16-bit words, LSB one count of 2^23,
    0.1545") among the inputs, its quantisation LSB / sqrt(12) = 0.045" joins the U."""
    raw, points, model, rom = (tmp_path / f"{n}.parquet" for n in ("raw", "p", "m", "rom"))
    for cmd in (f"enc acquire --rig ciomp-23bit --mode steps --readings 1 -o {raw}",
                f"enc points {raw} -o {points}", f"enc fit-rbf {points} -o {model}",
                f"enc make-rom {model} --width 16 --address-bits 8 -o {rom}",
                f"enc report --json {points} {model} {rom}"):
        r = run(cmd)
        assert r.returncode == 0, r.stderr.decode()
    c = json.loads(r.stdout)["sections"][0]["results"][0]["correction_at_any_angle"]
    held, band, quant = (t["standard_u_arcsec"] for t in c["terms"])
    assert quant == pytest.approx(360 * 3600 / 2 ** 23 / np.sqrt(12), abs=1e-3)
    assert c["expanded_u_arcsec"] == pytest.approx(2 * np.sqrt(held ** 2 + band ** 2
                                                               + quant ** 2), abs=2e-3)
