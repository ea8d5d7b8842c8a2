"""enc report --certificate: the A4 certificate of both campaigns read back with pypdf
(and poppler when installed), the HTML and the PDF from one template, the budget
table, the number format, the certificate file's keys."""

from __future__ import annotations

import math
import re
import shutil
import subprocess

import pytest
from conftest import ROOT, one_error_line, run
from test_report import make_deviations, make_interp, make_points

from enctools.methods.budget import Contribution, combine

A4 = (595.28, 841.89)   # pt
EXAMPLES = ROOT / "examples"
CERTS = {"000": EXAMPLES / "sjtu-dual-certificate.toml",
         "001": EXAMPLES / "ciomp-23bit-certificate.toml"}
NUMBERS = {"000": "ENC-2026-0417", "001": "ENC-2026-0418"}


def _ok(cmd: str | list[str]) -> None:
    r = run(cmd)
    assert r.returncode == 0, r.stderr.decode()


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory, sjtu_raw, ciomp_steps) -> dict[str, list[str]]:
    """The inputs of each demo campaign's report: seed 000's self-calibration (with its
    spectrum), direct comparison, interpolation error and the axis' step run (ISO 230-2,
    read on encoder I); seed 001's polygon points and RBF model."""
    d = tmp_path_factory.mktemp("campaigns")
    _ok(f"enc acquire --rig sjtu-dual --mode steps --count 8 --runs 5 --bidirectional "
        f"--readings 2 -o {d}/steps.parquet")
    _ok(f"enc selfcal {sjtu_raw} --method esa --ref-head H1 --heads H5,H6,H7 "
        f"--spectrum {d}/spec.parquet -o {d}/grad.parquet")
    _ok(f"enc average-heads {sjtu_raw} | enc compare --device H --reference P -o {d}/h-p.parquet")
    interp = make_interp(d / "interp.parquet")
    _ok(f"enc points {ciomp_steps} -o {d}/points.parquet")
    _ok(f"enc fit-rbf {d}/points.parquet -o {d}/model.parquet")
    return {"000": [f"{d}/grad.parquet", f"{d}/spec.parquet", f"{d}/h-p.parquet", str(interp),
                    f"{d}/steps.parquet"],
            "001": [f"{d}/points.parquet", f"{d}/model.parquet"]}


def _fonts_embedded(page) -> list[str]:
    """The names of the page's fonts that carry no embedded TrueType program."""
    missing = []
    for font in page["/Resources"]["/Font"].values():
        font = font.get_object()
        descendants = font.get("/DescendantFonts")
        inner = descendants[0].get_object() if descendants else font
        descriptor = inner["/FontDescriptor"].get_object()
        if "/FontFile2" not in descriptor:
            missing.append(str(font["/BaseFont"]))
    return missing


@pytest.mark.slow
@pytest.mark.parametrize("seed", ["000", "001"])
def test_certificate_pdf_every_page_a4_fonts_embedded_text_extractable(
        seed, campaigns, tmp_path):
    from pypdf import PdfReader

    pdf, html = tmp_path / "cert.pdf", tmp_path / "cert.html"
    _ok(["enc", "report", *campaigns[seed], "--certificate", str(CERTS[seed]),
         "--max-pp", "100", "--html", str(html), "--pdf", str(pdf)])
    number = NUMBERS[seed]
    pages = PdfReader(pdf).pages
    assert len(pages) >= 3
    texts = []
    for i, page in enumerate(pages, 1):
        box = page.mediabox
        assert (float(box.width), float(box.height)) == pytest.approx(A4, abs=0.01)
        assert not _fonts_embedded(page), i
        text = page.extract_text()
        assert number in text and f"Page {i} of {len(pages)}" in text, i
        texts.append(text)
    whole = re.sub(r"\s+", " ", "\n".join(texts))   # a caption may wrap
    for part in ("Calibration certificate", "Customer", "Serial number", "Date of issue",
                 "Air temperature", "Reference standards and traceability", "Results",
                 "Statement of conformity", "simple acceptance", "Measurement uncertainty",
                 "References", "Approval", "Signature"):
        assert part in whole, part
    # every figure's axes with their units, in its caption
    for unit in ("angle [deg]", "[arcsec]", "[1/rev]") + (
            ("[nm]", "phase within the signal period [deg]") if seed == "000" else ()):
        assert unit in whole, unit
    assert not re.search(r"seeds? 00[01]", whole)          # no internal citations
    assert not re.search(r"e-1\d", whole)                   # no rounding noise
    page = html.read_text()
    assert number in page and not re.search(r"seeds? 00[01]", page)


@pytest.mark.slow
@pytest.mark.skipif(not shutil.which("pdfinfo") or not shutil.which("pdftotext"),
                    reason="poppler-utils not installed (make poppler)")
def test_certificate_pdf_read_by_poppler(campaigns, tmp_path):
    pdf = tmp_path / "cert.pdf"
    _ok(["enc", "report", *campaigns["001"], "--certificate", str(CERTS["001"]),
         "--pdf", str(pdf)])
    info = subprocess.run(["pdfinfo", str(pdf)], capture_output=True, text=True, check=True)
    count = int(re.search(r"Pages:\s+(\d+)", info.stdout).group(1))
    sizes = subprocess.run(["pdfinfo", "-f", "1", "-l", str(count), str(pdf)],
                           capture_output=True, text=True, check=True).stdout
    assert sizes.count("595.28 x 841.89 pts (A4)") == count
    text = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True,
                          text=True, check=True).stdout
    assert text.count(NUMBERS["001"]) >= count
    assert "Measurement uncertainty" in text and "deviation [arcsec]" in text
    # the covariance statement of the polygon run's points (the model through GTC)
    flat = " ".join(text.split())
    assert re.search(r"two points correlate with r = 0\.5\d? \(propagated through GTC\)", flat)
    # each U to two significant digits (GUM 7.2.6): 0.15x arcsec is 0.15 or 0.16
    assert re.search(r"difference of two points .* its U is at most 0\.1[56] arcsec", flat)
    assert re.search(r"Peak-to-peak, as the difference of the extreme points \(\d+ deg and "
                     r"\d+ deg\): U = 0\.1[56] arcsec", flat)


# ------------------------------------------------------- one template, a budget


def _budget():
    rows = [Contribution("polygon face angle", "polygon certificate", "B", "normal", 0.10,
                         "arcsec", 2.0, 1.0),
            Contribution("autocollimator reading", "repeated readings", "A", "normal", 0.03,
                         "arcsec", 1.0, 1.0, 4.0),
            Contribution("temperature of the item", "thermometer", "B", "rectangular", 0.5,
                         "K", math.sqrt(3.0), 0.02)]
    return combine(rows)


@pytest.fixture(scope="module")
def documents(tmp_path_factory):
    """The HTML and the PDF text of one report with a budget, and the report."""
    from pypdf import PdfReader

    from enctools.report.certificate import load_certificate
    from enctools.report.display import in_unit
    from enctools.report.document import build, render
    from enctools.report.drawings import Drawings
    from enctools.report.pdf import document_pdf
    from enctools.report.summary import build_report

    d = tmp_path_factory.mktemp("budget")
    report = build_report([str(make_deviations(d / "dev.parquet")),
                           str(make_points(d / "t1.parquet", 1))])
    report.sections[1].budget = _budget()
    shown = in_unit(report, "arcsec")
    doc = build(shown, None, None, Drawings(shown), load_certificate(str(CERTS["001"])))
    pdf = d / "r.pdf"
    pdf.write_bytes(document_pdf(doc))
    text = "\n".join(p.extract_text() for p in PdfReader(pdf).pages)
    return render(doc, page=True), text, doc


@pytest.mark.heavy
def test_html_and_pdf_from_one_template_say_the_same(documents):
    page, text, doc = documents
    assert NUMBERS["001"] in page and NUMBERS["001"] in text
    flat = re.sub(r"\s+", " ", text)
    # the results table and the budget's rows, value by value, in both
    cells = [v for row in doc["summary"]["rows"] for v in row[3:]]
    budget = doc["uncertainty"]["budgets"][0]
    cells += [v for row in budget["table"]["rows"] for v in row[4:]]
    cells += [row[1] for row in budget["totals"]["rows"]]
    assert len(cells) >= 30
    for v in cells:
        assert f">{v}<" in page, v
        assert str(v) in flat, v
    for header in ("quantity", "distribution", "divisor", "c_i", "u_i [arcsec]", "ν_i"):
        assert header in page and header in flat, header


@pytest.mark.heavy
def test_budget_table_holds_every_contribution_and_the_totals(documents):
    page, text, _ = documents
    b = _budget()
    flat = re.sub(r"\s+", " ", text)                 # a cell's text may wrap
    for c in b.contributions:
        assert c.name in page and c.name in flat
    # u_c and U to two significant digits (GUM 7.2.6; 0.0587 and 0.117 here)
    assert f"{b.u_c:.3f} arcsec" in flat and f"{b.U:.2f} arcsec" in flat
    assert f"{b.nu_eff:.0f}" in flat and f"{b.k:.2f}" in flat
    assert "Welch–Satterthwaite" in flat
    # the input without a budget states its Type A evaluation instead
    assert "Type A evaluation" in flat


@pytest.mark.heavy  # a whole certificate with its figures: 0.5 s, 1.5 s with matplotlib's import
def test_a_laboratory_text_holding_brackets_keeps_them_and_lists_nothing_more(tmp_path):
    """The references are numbered as the document is made, not by reading "[n]" back out
    of the rendered page: a statement citing the laboratory's own procedure "[3]" stays
    "[3]", and ISO 230-2 (third in the project's list) is not listed for it."""
    from enctools.report.certificate import load_certificate
    from enctools.report.display import in_unit
    from enctools.report.document import build, render
    from enctools.report.drawings import Drawings
    from enctools.report.summary import build_report

    text = CERTS["001"].read_text(encoding="utf-8")
    said = "Calibrated to procedure QP-7 [3] and annex [9]."
    cert = tmp_path / "cert.toml"
    cert.write_text(re.sub(r'(?m)^statement = .*$', f'statement = "{said}"', text)
                    if re.search(r"(?m)^statement = ", text)
                    else text.replace("[certificate]\n", f'[certificate]\nstatement = "{said}"\n',
                                      1), encoding="utf-8")
    shown = in_unit(build_report([str(make_points(tmp_path / "t1.parquet", 1))]), "arcsec")
    doc = build(shown, None, None, Drawings(shown), load_certificate(str(cert)))
    page = render(doc, page=True)
    assert said in page
    listing = page[page.index("<h2>References</h2>"):]
    assert "ISO 230-2" not in listing and "Jiao Y." not in listing
    cited = list(dict.fromkeys(re.findall(r"\[(\d)\]", page.replace(said, ""))))
    assert cited == [str(i + 1) for i in range(len(doc["papers"]))], cited


def test_report_without_certificate_invents_no_customer_fields(tmp_path):
    from enctools.report.html import to_html
    from enctools.report.summary import build_report

    page = to_html(build_report([str(make_points(tmp_path / "t1.parquet", 1))]))
    assert "Calibration report" in page and "Calibration certificate" not in page
    for absent in ("Customer", "Certificate number", "Approval", "Signature",
                   "Serial number", "Environment"):
        assert absent not in page, absent
    assert "Date of issue" in page
    assert "References" not in page and "[1]" not in page  # it cites nothing: none listed


# ------------------------------------------------------------------ numbers


@pytest.mark.parametrize("value, unit, shown", [
    (-5.6e-17, "arcsec", "0.000"), (2.1e-17, "arcsec", "0.000"),
    (-0.0004, "arcsec", "-0.0004000"), (-0.0006, "arcsec", "-0.0006000"),
    (1.2345, "arcsec", "1.234"), (3e-9, "rad", "0.000000003000"),
    (-1e-12, "rad", "-0.000000000001000"), (-1e-17, "rad", "0.000000000"),
    (1.6e-7, "deg", "0.0000001600"), (None, "arcsec", "–"),
    (math.nan, "nm", "–"), (12.34567, "nm", "12.346"), (1234.5, "arcsec", "1234.500")])
def test_one_number_format_without_rounding_noise(value, unit, shown):
    """A figure alone: four significant digits, never coarser than the unit's resolution
    (0.001"), never finer than the floating-point noise (1e-9", 1e-15 rad)."""
    from enctools.report.display import fmt

    assert fmt(value, unit) == shown


@pytest.mark.parametrize("value, shown", [(0.05, "0.05000"), (1.0, "1.000"), (1234.4, "1234"),
                                           (0.0, "0.000"), (2.5e-5, "0.00002500")])
def test_declared_values_to_four_significant_digits(value, shown):
    from enctools.report.display import significant

    assert significant(value) == shown


def test_text_report_prints_a_mean_removed_as_zero(tmp_path):
    """A positioning deviation has its mean removed: the text says 0.000, not -5.6e-17."""
    r = run(["enc", "report", str(make_points(tmp_path / "t1.parquet", 1))])
    out = r.stdout.decode()
    assert r.returncode == 0 and "e-1" not in out and "seed 00" not in out


# ------------------------------------------------------------ the file and options


def test_every_certificate_key_is_in_the_man_page():
    from enctools.report.certificate import SCHEMA

    page = (ROOT / "man" / "enc-certificate.5").read_text().replace("\\-", "-")
    for table, keys in SCHEMA.items():
        assert f"[{table}]" in page, table
        for key in keys:
            assert f"B {key}" in page or f" {key}" in page, (table, key)


def test_number_option_replaces_the_files(tmp_path):
    html = tmp_path / "r.html"
    _ok(["enc", "report", str(make_points(tmp_path / "t1.parquet", 1)), "--certificate",
         str(CERTS["001"]), "--certificate-number", "LAB-7/2026", "--html", str(html)])
    page = html.read_text()
    assert "LAB-7/2026" in page and NUMBERS["001"] not in page


def test_certificate_needs_a_document(tmp_path):
    r = run(["enc", "report", str(make_points(tmp_path / "t1.parquet", 1)),
             "--certificate", str(CERTS["001"])])
    assert "--html or --pdf" in one_error_line(r, 2, cmd="enc report")


def test_certificate_example_files_load():
    from enctools.report.certificate import load_certificate

    for seed, path in CERTS.items():
        cert = load_certificate(str(path))
        assert cert is not None and cert.number == NUMBERS[seed]
        assert cert.references and cert.get("approval", "name")


def test_demo_makefiles_use_the_certificates():
    for name in ("sjtu-dual", "ciomp-23bit"):
        mk = (EXAMPLES / f"{name}.mk").read_text()
        assert "--certificate" in mk and f"{name}-certificate.toml" in mk, name


@pytest.mark.parametrize("settings, says, cites", [
    ({"mode": "signals"}, "sine and cosine signals (Heydemann's ellipse fit)", False),
    ({"mode": "reference"}, "capacitive probes or a second encoder) [1]", True)])
def test_an_interpolation_check_is_named_by_its_mode(settings, says, cites):
    """A signals run fits the encoder's own sin/cos (seed 000's probes are not its
    reference): it is named so, and cites no paper; a reference run cites seed 000."""
    from enctools.report import citations

    meta = {"history": ["2026-12-07T10:00:00Z: enc interp-check x.arrows"],
            "settings": settings}
    with citations.collecting() as cited:
        said = citations.method_of(meta)
    assert says in said
    assert cited == (["000"] if cites else [])
