"""The polygon's certificate in enc points (enc-points(1), POLYGON CERTIFICATE): its face
angle errors applied to the reference angle, checked against the simulator's truth and
against the man page's worked example; bad certificates refused."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, one_error_line, run, run_in_process
from test_summaries import check_keys

from enctools.data import streams
from enctools.data.polygon import (
    face_standard_uncertainty,
    points_face_uncertainty,
    read_certificate,
)
from enctools.data.rig import load_rig
from enctools.data.truth import Truth, interpolation_error
from enctools.methods.points import from_table
from enctools.units import ARCSEC, DEG

CIOMP = ROOT / "enctools" / "rigs" / "ciomp-23bit.toml"


def fine_rig(folder: Path, face_error: float = 0.5) -> Path:
    """ciomp-23bit with a 2^28-count encoder (its quantisation 0.005", below the noise)
    and a polygon of ``face_error`` arcsec face errors."""
    text = CIOMP.read_text()
    for old, new in (("interpolation = 2048", "interpolation = 65536"),
                     ("counter_bits = 23 ", "counter_bits = 28 "),
                     ("face_error_arcsec = 0.05", f"face_error_arcsec = {face_error}")):
        assert old in text
        text = text.replace(old, new, 1)
    path = folder / "fine.toml"
    path.write_text(text)
    return path


def encoder_error(truth: Truth, rig_path: Path, indicated_deg: np.ndarray) -> np.ndarray:
    """The truth of the measuring heads' mean reading minus the true angle [arcsec] where
    they read ``indicated_deg``: graduation, radial motion and interpolation error of
    each head at the scale angle under it (the true angle found by iteration)."""
    enc = load_rig(str(rig_path)).encoders[0]
    heads = [h for h in enc.heads if h.name in enc.measure_heads]
    eps, rad = truth.graduation[enc.name], truth.radial[enc.name]

    def error(theta: np.ndarray) -> np.ndarray:
        out = np.zeros_like(theta)
        for h in heads:
            radial = (rad["x"](theta) * np.sin(h.angle)
                      - rad["y"](theta) * np.cos(h.angle)) * 1e-9 / enc.radius_m  # rad
            scale = theta + h.angle + eps(theta + h.angle) * ARCSEC + radial
            out += eps(theta + h.angle) + radial / ARCSEC + interpolation_error(
                truth.signals[h.name], scale, enc.periods_per_rev)
        return out / len(heads)

    indicated = indicated_deg * DEG
    theta = indicated.copy()
    for _ in range(4):
        theta = indicated - error(theta) * ARCSEC
    return error(theta)


def write_certificate(path: Path, errors: np.ndarray, expanded: float, first: int = 1,
                      k: float = 2.0, header: str = "") -> Path:
    lines = [f"# certificate: TEST-{len(errors)}", "# traceability: national angle standard",
             f"# k: {k:g}", header, "face, error [arcsec], U [arcsec]"]
    lines += [f"{j + first}, {e:+.4f}, {expanded:.4f}" for j, e in enumerate(errors)]
    path.write_text("\n".join(ln for ln in lines if ln) + "\n")
    return path


@pytest.mark.slow
def test_certified_faces_bring_the_points_to_the_truth(tmp_path):
    """With the certificate = the simulator's faces + noise at the stated u, the points'
    deviations match the encoder's truth within the certificate's u and the noise;
    without it they are off by the face errors."""
    rig = fine_rig(tmp_path)
    steps = tmp_path / "steps.parquet"
    r = run(f"enc acquire --rig {rig} --mode steps -q -o {steps}")
    assert r.returncode == 0, r.stderr.decode()
    header, _ = streams.read_table(str(steps), "readings")
    truth = Truth.from_dict(header.meta["truth"])
    faces = np.asarray(truth.polygon)
    u_cert = 0.02  # arcsec, standard
    noisy = faces + np.random.default_rng(7).normal(0.0, u_cert, faces.size)
    cert = write_certificate(tmp_path / "cert.csv", noisy - noisy.mean(), 2 * u_cert)
    got = {}
    for name, opts in (("with", f"--polygon-certificate {cert} --json"), ("without", "")):
        out = tmp_path / f"{name}.parquet"
        r = run(f"enc points {steps} {opts} -o {out}")
        assert r.returncode == 0, r.stderr.decode()
        if opts:
            doc = json.loads(r.stdout)
            check_keys(doc)
            assert doc["polygon_face_u_max_arcsec"] == pytest.approx(u_cert)
        h, table = streams.read_table(str(out), "points")
        got[name] = (h, from_table(table))
    h, pts = got["with"]
    meta = h.meta["polygon_certificate"]
    assert meta["certificate"] == "TEST-24" and meta["faces"] == 24 and meta["first_face"] == 1
    assert meta["u_arcsec"] == pytest.approx([u_cert] * 24)
    assert points_face_uncertainty(h.meta) == pytest.approx(np.full(24, u_cert))
    assert points_face_uncertainty(got["without"][0].meta) is None
    e = encoder_error(truth, rig, pts.position_deg)
    want = e - e[0]
    # noise of one point relative to the first: heads 0.05"/sqrt(2*5), autocollimator
    # 0.03"/sqrt(5), twice; the certificate's u at the point's face and the first face
    u_noise = np.sqrt(2 * ((0.05 / np.sqrt(10)) ** 2 + (0.03 / np.sqrt(5)) ** 2))
    u_point = np.sqrt(u_noise**2 + 2 * u_cert**2)
    miss = (pts.deviation - want)[1:] / u_point
    assert np.sqrt(np.mean(miss**2)) < 1.5 and np.abs(miss).max() < 4.0, miss
    off = got["without"][1].deviation - want
    assert np.abs(off - (faces - faces[0])).max() < 4 * u_noise  # off by the face errors
    assert np.sqrt(np.mean((off[1:] / u_point) ** 2)) > 10


def test_the_man_pages_worked_example(ciomp_steps, tmp_path):
    """enc-points(1)'s example: face 3 +0.50", face 0 -0.10", face 12 -0.40", the others
    0: face 3's true angle gains 0.60" on the first position's, so its deviation
    loses 0.60"; face 12's gains -0.30"; every other face's gains 0.10"."""
    man = (ROOT / "man" / "enc-points.1").read_text()
    example = man.split(".SH POLYGON CERTIFICATE", 1)[1].split(".SH ", 1)[0]
    for line in ("0, \\-0.10, 0.05", "3, +0.50, 0.05", "12, \\-0.40, 0.05"):
        assert line in example, line
    cert = tmp_path / "cert.csv"
    errors = np.zeros(24)
    errors[[0, 3, 12]] = [-0.10, 0.50, -0.40]
    write_certificate(cert, errors, 0.05, first=0, header="# unit: arcsec")
    devs = []
    for opts in (f"--polygon-certificate {cert}", ""):
        out = tmp_path / f"p{len(devs)}.parquet"
        r = run(f"enc points {ciomp_steps} {opts} -o {out}")
        assert r.returncode == 0, r.stderr.decode()
        devs.append(from_table(streams.read_table(str(out), "points")[1]).deviation)
    change = devs[0] - devs[1]
    want = np.full(24, -0.10)
    want[[0, 3, 12]] = [0.0, -0.60, 0.30]
    assert change == pytest.approx(want, abs=1e-9)


def test_first_face_and_units(ciomp_steps, tmp_path):
    """--first-face turns the certificate; a unit in the file, the title or the option."""
    errors = np.zeros(24)
    errors[[5, 8]] = [0.3, -0.3]
    cert = write_certificate(tmp_path / "c.csv", errors, 0.05, first=1)
    base = tmp_path / "base.parquet"
    assert run(f"enc points {ciomp_steps} -o {base}").returncode == 0
    out = tmp_path / "p.parquet"
    r = run(f"enc points {ciomp_steps} --polygon-certificate {cert} --first-face 6 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    change = (from_table(streams.read_table(str(out), "points")[1]).deviation
              - from_table(streams.read_table(str(base), "points")[1]).deviation)
    want = -(np.roll(errors, -5) - errors[5])  # face 6 (row 5) at the first position
    assert change == pytest.approx(want, abs=1e-9)
    urad = tmp_path / "urad.csv"
    urad.write_text("# k: 2\n# unit: urad\nface error U\n"
                    + "".join(f"{j} {e / 0.2062648:.9f} 0.25\n" for j, e in enumerate(errors)))
    cert_u = read_certificate(str(urad))
    assert cert_u.error_arcsec == pytest.approx(errors - errors.mean(), abs=1e-6)
    assert face_standard_uncertainty(cert_u) == pytest.approx(np.full(24, 0.125 * 0.2062648),
                                                              rel=1e-6)
    std = tmp_path / "std.csv"
    std.write_text("face,error,u\n" + "".join(f"{j},{e},0.01\n" for j, e in enumerate(errors)))
    assert read_certificate(str(std), unit="arcsec").u_arcsec == pytest.approx(np.full(24, 0.01))


GOOD = "# k: 2\nface,error,U\n" + "".join(f"{j},{(-1) ** j * 0.1:.2f},0.04\n" for j in range(24))


def _rows(edit):
    lines = GOOD.splitlines()
    return "\n".join(edit(lines)) + "\n"


@pytest.mark.parametrize("content, what", [
    (_rows(lambda ls: ls[:-1]), "lists 23 faces; the polygon of"),
    (_rows(lambda ls: ls[:5] + [ls[4]] + ls[6:]), "face 2 is listed twice"),
    (_rows(lambda ls: [*ls[:-1], "24,0.1,0.04"]), "face 23 is missing"),
    (_rows(lambda ls: [*ls[:5], "3,nan,0.04", *ls[6:]]), "NaN or infinite"),
    (_rows(lambda ls: [*ls[:5], "3,0.1,0", *ls[6:]]), "uncertainty must be > 0"),
    (_rows(lambda ls: [*ls[:5], "3.5,0.1,0.04", *ls[6:]]), "face 3.5 is not a whole number"),
    (_rows(lambda ls: [*ls[:3], "1,0.5,0.04", *ls[4:]]), "not about 0"),
    (_rows(lambda ls: ls[1:]), "needs the coverage factor"),
    (_rows(lambda ls: ["# k: 2", "face,error", *(r.rsplit(",", 1)[0] for r in ls[2:])]),
     "needs the columns face, error and U"),
    (_rows(lambda ls: ["# unit: degrees Celsius", *ls]), "not an angle unit"),
    (_rows(lambda ls: ["# reference: first", *ls]), "the first face's error is"),
    ("# only comments\n", "no faces"),
])
def test_bad_certificates_are_refused(ciomp_steps, tmp_path, content, what):
    cert = tmp_path / "c.csv"
    cert.write_text(content)
    out = tmp_path / "p.parquet"
    r = run_in_process(["enc", "points", str(ciomp_steps), "--polygon-certificate", str(cert),
                        "-o", str(out)])
    line = one_error_line(r, 2, "enc points")
    assert re.search(re.escape(what), line), line
    assert not out.exists()


def test_certificate_options_need_a_step_run(tmp_path):
    from conftest import DATA

    cert = tmp_path / "c.csv"
    cert.write_text(GOOD)
    out = tmp_path / "p.parquet"
    r = run_in_process(["enc", "points", str(DATA / "seed001_table1.csv"),
                        "--polygon-certificate", str(cert), "-o", str(out)])
    assert "--polygon-certificate" in one_error_line(r, 2, "enc points")
    r = run_in_process(["enc", "points", "x.parquet", "--first-face", "3", "-o", str(out)])
    assert "need --polygon-certificate" in one_error_line(r, 2, "enc points")
    assert not out.exists()
