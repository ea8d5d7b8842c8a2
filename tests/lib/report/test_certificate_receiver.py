"""The demo certificates of both campaigns read as their receiver reads them (pdftotext):
one row per target with U, nothing internal (no path, command line, version, rig name,
model internals), one identity for each reference standard and no date but the
certificate file's; the laboratory's record holds what the certificate leaves out."""

from __future__ import annotations

import re
import shutil
import subprocess
import tomllib

import pytest
from conftest import ROOT, one_error_line, run
from test_certificate import CERTS, campaigns  # noqa: F401  (the campaigns' inputs)

pytestmark = [pytest.mark.slow, pytest.mark.skipif(
    not shutil.which("pdftotext"), reason="poppler-utils not installed (make poppler)")]

#: a results row as pdftotext -layout prints it: target, deviation(s), U, k (and after);
#: the deviations to the decade of U, U to two significant digits
ROW = re.compile(r"^\s*(\d+\.\d{3})\s+(?:-?\d+(?:\.\d+)?\s+){1,3}(\d+(?:\.\d+)?)\s+(\d\.\d\d)"
                 r"(?:\s+-?\d+(?:\.\d+)?)?\s*$")   # ... and after the correction shipped


def _certificate(seed: str, inputs: list[str], folder) -> tuple[str, str]:
    pdf, record = folder / "cert.pdf", folder / "record.txt"
    r = run(["enc", "report", *inputs, "--certificate", str(CERTS[seed]), "--pdf", str(pdf),
             "--record", str(record)])
    assert r.returncode == 0, r.stderr.decode()
    text = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True,
                          text=True, check=True).stdout
    cells = subprocess.run(["pdftotext", str(pdf), "-"], capture_output=True, text=True,
                           check=True).stdout       # a table's cells one after the other
    return text + "\n" + cells, record.read_text()


def _rows(text: str) -> list[tuple[float, float]]:
    """(target, U) of every results row of the document."""
    part = text.split("Results per calibrated position", 1)[1]  # the -layout text's
    part = part.split("Measurement uncertainty", 1)[0]
    return [(float(m.group(1)), float(m.group(2))) for line in part.splitlines()
            if (m := ROW.match(line))]


@pytest.mark.parametrize("seed", ["000", "001"])
def test_the_receiver_reads_every_target_with_U_and_nothing_internal(seed, campaigns,  # noqa: F811
                                                                     tmp_path):
    text, record = _certificate(seed, campaigns[seed], tmp_path)
    rows = _rows(text)
    if seed == "001":       # the 24 polygon positions, before and after the correction
        assert sorted(t for t, _ in rows) == [15.0 * i for i in range(24)]
        assert "after correction [arcsec]" in text
    else:                   # each curve over the turn every 10 deg; the step run's targets
        assert len(rows) >= 2 * 36
        assert {45.0 * i for i in range(8)} <= {t for t, _ in rows}
    assert all(u > 0 for _, u in rows)
    flat = re.sub(r"\s+", " ", text)
    solid = "".join(text.split())       # a table's cell may wrap anywhere
    # nothing internal: no path or file name, command line, option, version, rig
    for inp in campaigns[seed]:
        assert inp not in flat and inp.rsplit("/", 1)[-1] not in flat
    assert not re.search(r"\.(parquet|arrow|h5)\b|/tmp/", flat)
    assert not re.search(r"\benc [a-z-]+ |(^| )--[a-z]", flat)
    assert not re.search(r"enctools|numpy|pyarrow|\b\d+\.\d+\.\d+\b", flat)
    assert "sjtu-dual" not in flat and "ciomp-23bit" not in flat
    for internal in ("spread_factor", "bias_arcsec", "kernel=", "as entered", "Made "):
        assert internal not in flat, internal
    # nor the rig file's keys (the quantities a model leaves unused are the laboratory's)
    assert not re.search(r"\b(reference_encoder|probe_arm|head_mounting)", flat)
    # ... which the laboratory's record holds: each input by its base name (they lie
    # outside the record's folder), never the machine's path (SOURCE_DATE_EPOCH's rule)
    assert all(inp.rsplit("/", 1)[-1] in record and inp not in record
               for inp in campaigns[seed]) and "enctools" in record
    # the item as the file names it; its dates and no other
    cert = tomllib.loads(CERTS[seed].read_text())
    assert all("".join(cert["item"][k].split()) in solid for k in ("serial", "model"))
    dates = {d.isoformat() for d in (cert["item"]["received"], cert["calibration"]["date"],
                                     cert["certificate"]["issued"])}
    dates |= {r["due"].isoformat() for r in cert["reference"]}
    assert set(re.findall(r"\b\d{4}-\d\d-\d\d\b", flat)) <= dates
    # each reference standard's certificate named, and no other certificate number
    for ref in cert["reference"]:
        assert "".join(ref["certificate"].split()) in solid
    assert "P-24-0117" not in flat and "AC-2025-0342" not in flat
    if seed == "000":       # the comparison's budget: encoder I as a reference standard,
        # used as it reads (no calibrated curve applied): its row is its accuracy
        assert re.search(r"accuracy of the\b.{0,60}?\breference\b.{0,60}?\bused without\b",
                         flat), flat[-3000:]
        assert "calibrateddeviationofthereferenceencoder" not in solid
        assert "LAB-EI-2026-012" in solid
        # ... and the step run's, per target: its approaches, encoder I's resolution
        # (a wrapped cell's last line may come after its neighbour's first: the oldest
        # fpdf2 writes a row's cells line by line, so the words are read in order, not joined)
        assert re.search(r"repeatability of the\b.{0,40}?\bapproaches", flat), flat[-3000:]
        assert "resolutionofencoderI" in solid
        # ... and the self-calibration's: its revolutions and the method's own bound
        assert "repeatabilityoverthe" in solid and "themethod'sownbound" in solid


@pytest.mark.parametrize("seed", ["000", "001"])
def test_the_references_listed_are_those_cited_in_the_order_cited(seed, campaigns,  # noqa: F811
                                                                   tmp_path):
    """ISO/IEC 17025 7.8 asks for a document that stands on its own: every reference it
    lists is cited in its text, numbered by its first citation, and every citation is
    listed (seed 001's certificate cites neither seed 000's paper nor ISO 230-2)."""
    _certificate(seed, campaigns[seed], tmp_path)
    text = subprocess.run(["pdftotext", "-layout", str(tmp_path / "cert.pdf"), "-"],
                          capture_output=True, text=True, check=True).stdout
    before, _, rest = text.partition("\nReferences\n")
    listing, _, after = rest.partition("The results relate only")
    listed = [int(n) for n in re.findall(r"^\s*(\d)\. ", listing, re.M)]
    cited = [int(n) for n in re.findall(r"\[(\d)\]", before + after)]
    first = list(dict.fromkeys(cited))
    assert listed == first == list(range(1, len(listed) + 1)), (listed, cited)
    papers = " ".join(listing.split())
    assert ("Jiao Y." in papers) == (seed == "000") and ("Yu H." in papers) == (seed == "001")
    assert ("ISO 230-2" in papers) == (seed == "000")


def test_inputs_of_two_rigs_are_refused_for_one_certificate(campaigns, tmp_path):  # noqa: F811
    r = run(["enc", "report", campaigns["001"][0], campaigns["000"][0], "--certificate",
             str(CERTS["001"]), "--pdf", str(tmp_path / "c.pdf")])
    line = one_error_line(r, 2, cmd="enc report")
    assert "2 rigs" in line and "ciomp-23bit" in line and "sjtu-dual" in line
    assert not (tmp_path / "c.pdf").exists()


@pytest.mark.parametrize("edit, words", [
    (("2026-12-02", "2026-11-20"), "[certificate] issued 2026-11-20 is before"),
    (('quantity = "autocollimator"\n', ""), 'quantity = "autocollimator"'),
])
def test_a_contradicting_certificate_file_is_refused(campaigns, tmp_path, edit,  # noqa: F811
                                                     words):
    cert = tmp_path / "cert.toml"
    cert.write_text(CERTS["001"].read_text().replace(*edit))
    r = run(["enc", "report", *campaigns["001"], "--certificate", str(cert), "--pdf",
             str(tmp_path / "c.pdf")])
    assert words in one_error_line(r, 2, cmd="enc report")
    assert not (tmp_path / "c.pdf").exists()


def test_the_record_goes_with_a_certificate_only(tmp_path):
    r = run(["enc", "report", str(ROOT / "tests" / "data" / "seed001_table1.csv"), "--html",
             str(tmp_path / "r.html"), "--record", str(tmp_path / "r.txt")])
    assert "--certificate" in one_error_line(r, 2, cmd="enc report")
