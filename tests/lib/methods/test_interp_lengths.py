"""A linear scale's interpolation error in nm (enc interp-check --signal-period, issue 33).

A 20 µm grating scale's 1 Vpp head (HEIDENHAIN's Ua1/Ua2 names) captured by a DAQ and
exported as its software writes it: a preamble, a tab-separated table with a time column
and the two channels in mV. The signals carry a known Heydemann ellipse distortion
(offsets, unequal amplitudes, a quadrature error). The interpolation error the check
reports, phase error [rad] / (2 pi) x 20,000 nm at each phase read, is computed here again
on its own: for each read phase psi of the output's grid, the true phase phi with
atan2(Ua2, Ua1) = psi is found by bisection, and error = (psi - phi) / (2 pi) x P. Read as
a rotary encoder (--periods-per-rev) the same table still gives arcsec, and the two agree
through arcsec -> phase -> nm.
"""

from __future__ import annotations

import json
import math
import re
import shutil
import subprocess

import numpy as np
import pytest
from conftest import one_error_line, run

from enctools.data.streams import read_table
from enctools.units import ARCSEC, TWO_PI

#: the scale's signal period [nm] and the head's faults: offsets and amplitudes [mV], the
#: sine's quadrature error [rad]
PERIOD_NM = 20_000.0
OFF_1, OFF_2, AMP_1, AMP_2, QUAD = 14.0, -9.0, 510.0, 486.0, math.radians(1.5)
PERIODS_PER_REV = 18_000


def _signals(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ua1 (cosine) and Ua2 (sine) [mV] at the true phase ``phi`` [rad]."""
    return OFF_1 + AMP_1 * np.cos(phi), OFF_2 + AMP_2 * np.sin(phi + QUAD)


def _daq_export(path) -> None:
    """The DAQ's export: 3.2 periods of travel at 1500 samples, mV to 3 decimals."""
    phi = TWO_PI * 3.2 * np.arange(1500) / 1500 + 0.3
    ua1, ua2 = _signals(phi)
    lines = ["# Acquired with a 16-bit USB DAQ, 100 kS/s, channels ai0 ai1",
             "# Scale: 20 um grating, 1 Vpp head, 1 mm/s", "Time [s]\tUa1 [mV]\tUa2 [mV]"]
    lines += [f"{k * 1e-5:.5f}\t{a:.3f}\t{b:.3f}" for k, (a, b) in enumerate(zip(ua1, ua2))]
    path.write_text("\n".join(lines) + "\n")


def _by_hand(psi: np.ndarray) -> np.ndarray:
    """The error [nm] at the read phases ``psi`` [rad]: the true phase solved by bisection
    on the raw signals' atan2 (monotonic for faults this small), mean removed."""
    def read(phi: np.ndarray) -> np.ndarray:
        ua1, ua2 = _signals(phi)
        # unwrapped against phi: atan2 is continuous for these small faults
        return phi + np.angle(np.exp(1j * (np.arctan2(ua2, ua1) - phi)))

    lo, hi = psi - 0.5, psi + 0.5
    for _ in range(60):
        mid = (lo + hi) / 2
        below = read(mid) < psi
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    err = (psi - (lo + hi) / 2) / TWO_PI * PERIOD_NM
    return err - err.mean()


def _run(tmp_path, commands: str) -> subprocess.CompletedProcess:
    """``commands`` run on the DAQ's export, scale.txt, in ``tmp_path``; they succeed."""
    _daq_export(tmp_path / "scale.txt")
    r = run(commands, cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    return r


def test_a_scales_error_in_nm_equals_the_phase_error_times_its_period(tmp_path):
    r = _run(tmp_path, "enc interp-check --signals scale.txt --signal-period 20um --json -o "
             "err.csv && enc interp-check --signals scale.txt --signal-period 0.02mm -o "
             "err.parquet 2> err.txt && enc info err.parquet > info.txt")
    _, rows = read_table(str(tmp_path / "err.parquet"), "deviations")
    psi = rows.column("theta").to_numpy()
    got = rows.column("H1").to_numpy()
    want = _by_hand(psi)
    assert np.ptp(want) > 250.0                        # about 300 nm p-p of distortion
    assert np.max(np.abs(got - want)) < 0.01           # nm: the fit of 3-decimal mV cells
    assert rows.schema.field("H1").metadata[b"unit"] == b"nm"
    assert rows.schema.field("u_H1").metadata[b"unit"] == b"nm"
    curve = json.loads(r.stdout)["curves"][0]
    assert curve["period_nm"] == PERIOD_NM
    assert curve["pp_nm"] == pytest.approx(np.ptp(got), abs=1e-9)
    assert abs(curve["pp_nm"] - np.ptp(want)) < 0.1
    assert abs(curve["harmonics"][0]["amplitude_nm"] - _amplitude(want, 1)) < 0.05
    csv_head = (tmp_path / "err.csv").read_text().splitlines()[0]
    assert csv_head == "theta_rad,H1_nm,u_H1_nm"
    # no angle's unit in what a person reads: the summary, enc info, the CSV, the JSON
    text = (tmp_path / "err.txt").read_text()
    assert "p-p" in text and " nm" in text
    for shown in (text, (tmp_path / "info.txt").read_text(), r.stdout.decode(), csv_head):
        assert "arcsec" not in shown and not re.search(r"\bdeg\b|°|″", shown), shown


def _amplitude(curve: np.ndarray, n: int) -> float:
    return float(abs(np.fft.rfft(curve)[n]) * 2 / curve.size)


def test_the_report_of_a_scale_is_in_nm_without_an_angle(tmp_path):
    _run(tmp_path, "enc interp-check --signals scale.txt --signal-period 20um -q -o "
         "err.parquet && enc report err.parquet > r.txt && enc report err.parquet --json > "
         "r.json && enc report err.parquet --html r.html --pdf r.pdf -q > /dev/null")
    report = (tmp_path / "r.txt").read_text()
    assert "signal period: 20000 nm" in report and "H1 [nm]" in report
    section = json.loads((tmp_path / "r.json").read_text())["sections"][0]
    assert section["curves"][0]["unit"] == "nm" and section["curves"][0]["signal_period_nm"]
    html = (tmp_path / "r.html").read_text()
    html = re.sub(r"<[^>]+>", " ", re.sub(r"data:image/png;base64,[^\"]+", "", html))
    html = html[:html.find("References")]
    assert "in nm;" in html and "interpolation error" in html
    shown = [report, (tmp_path / "r.json").read_text(), html]
    if shutil.which("pdftotext"):
        pdf = subprocess.run(["pdftotext", str(tmp_path / "r.pdf"), "-"], capture_output=True,
                             check=True).stdout.decode()
        shown.append(pdf[:pdf.find("References")])
    for text in shown:
        assert "arcsec" not in text and not re.search(r"\bdeg\b|°|″", text), text


def test_the_same_table_as_a_rotary_encoder_still_reports_arcsec(tmp_path):
    r = _run(tmp_path, f"enc interp-check --signals scale.txt --periods-per-rev "
             f"{PERIODS_PER_REV} --json -o rot.parquet && enc interp-check --signals "
             "scale.txt --signal-period 20um --json -o lin.parquet")
    rot, lin = (json.loads(doc)["curves"][0] for doc in
                r.stdout.decode().replace("}\n{", "}\n\x00{").split("\x00"))
    assert rot["period_arcsec"] == pytest.approx(72.0) and "pp_arcsec" in rot
    assert "pp_nm" not in rot and "period_nm" not in rot
    _, rows = read_table(str(tmp_path / "rot.parquet"), "deviations")
    assert rows.schema.field("H1").metadata[b"unit"] == b"arcsec"
    # arcsec -> phase (x N, in rad) -> nm (P / 2 pi): the same error
    k = ARCSEC * PERIODS_PER_REV / TWO_PI * PERIOD_NM
    assert lin["pp_nm"] == pytest.approx(rot["pp_arcsec"] * k, rel=1e-12)


def test_a_readings_stream_of_a_scale_states_its_period_in_its_sidecar(tmp_path):
    """A readings CSV whose CSVW sidecar gives the signal columns' signal_period_nm: the
    error in nm without the option, the same as the option gives."""
    import pyarrow as pa

    from enctools.data.schemas import make_field
    from enctools.data.streams import Header, write_table

    phi = TWO_PI * 3.2 * np.arange(1500) / 1500 + 0.3
    ua1, ua2 = _signals(phi)
    # the head's counter as enc acquire records it (its geometry a turn's: 1000 periods)
    fields = [make_field("t", pa.float64(), "s"),
              make_field("H1", pa.int64(), "count", "head", encoder="X", alpha_deg=0,
                         counts_per_rev=1_024_000, periods_per_rev=1000, radius_m=0.1,
                         zero_count=0)]
    fields += [make_field(f"H1_{comp}", pa.float64(), "V", "signal", head="H1", component=comp,
                          signal_period_nm="20000") for comp in ("cos", "sin")]
    table = pa.Table.from_arrays([pa.array(np.arange(1500) * 1e-5),
                                  pa.array(np.floor(phi / TWO_PI * 1024).astype(np.int64)),
                                  pa.array(np.round(ua1, 3) / 1e3),
                                  pa.array(np.round(ua2, 3) / 1e3)], schema=pa.schema(fields))
    write_table(str(tmp_path / "run.csv"), Header("readings", table.schema,
                                                  {"rig": {}, "settings": {}}), table)
    _daq_export(tmp_path / "scale.txt")
    r = run("enc interp-check --signals run.csv -q -o a.parquet && enc interp-check --signals "
            "scale.txt --signal-period 20um -q -o b.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    _, a = read_table(str(tmp_path / "a.parquet"), "deviations")
    _, b = read_table(str(tmp_path / "b.parquet"), "deviations")
    assert a.schema.field("H1").metadata[b"unit"] == b"nm"
    assert a.schema.field("H1").metadata[b"signal_period_nm"] == b"20000.0"
    assert np.max(np.abs(a.column("H1").to_numpy() - b.column("H1").to_numpy())) < 1e-6


@pytest.mark.parametrize(("args", "words"), [
    ("--signal-period 20um --periods-per-rev 100", "--periods-per-rev and --signal-period"),
    ("--signal-period 20", "is not a length"),
    ("--signal-period 2km", "is not a length"),
    ("--signal-period 0.1nm", "1 nm..1 m"),
    ("--signal-period 20um --spectrum s.parquet", "--spectrum: a spectrum stream is in arcsec"),
])
def test_a_signal_period_that_cannot_be_is_refused(tmp_path, args, words):
    _daq_export(tmp_path / "scale.txt")
    r = run(f"enc interp-check --signals scale.txt {args} -o err.parquet", cwd=tmp_path)
    assert words in one_error_line(r, 2, "enc interp-check")
    assert not (tmp_path / "err.parquet").exists()
