"""A certificate that cannot deceive: a name or number of the certificate file holding a
control, line-separator, bidi or zero-width character is refused with one line naming
the key and the character; free text holding one is shown escaped, in the HTML and in
the PDF as its receiver reads it (pdftotext), from every source (a file name too)."""

from __future__ import annotations

import shutil
import subprocess

import pytest
from conftest import one_error_line, run_in_process
from test_report import make_points

#: the free text keys, each given a character that would fake a line or reverse text
FREE = {("item", "description"): "Encoder\u2028Serial: FAKE-1",
        ("customer", "address"): "Lane 3\u202e9001-32EA",
        ("item", "condition"): "ok\x85NEL\u2029PS",
        ("environment", "remarks"): "zero\u200bwidth\ufeff\u2060\u200d",
        ("certificate", "statement"): "\u2066isolated\u2069 \u200e\u200f\u061c\u202a"}
DECEPTIVE = "\u2028\u2029\x85\u202a\u202e\u2066\u2069\u200e\u200f\u061c\u200b\u200d\ufeff\u2060"


def _toml(fields: dict[tuple[str, str], str]) -> str:
    tables: dict[str, list[str]] = {"certificate": ['number = "C-1"']}
    for (table, key), value in fields.items():
        tables.setdefault(table, []).append(f"{key} = {_quoted(value)}")
    return "".join(f"[{t}]\n" + "\n".join(lines) + "\n" for t, lines in tables.items())


def _quoted(value: str) -> str:
    return '"' + "".join(ch if ch.isprintable() and ch != '"' else f"\\u{ord(ch):04x}"
                         for ch in value) + '"'


@pytest.mark.parametrize("table, key, ch", [
    ("item", "serial", "\u202e"), ("certificate", "number", "\u2066"),
    ("customer", "name", "\u200b"), ("customer", "order", "\u2028"),
    ("item", "model", "\x85"), ("reference", "certificate", "\ufeff"),
    ("approval", "name", "\u200f"), ("item", "serial", "\n")])
def test_an_identifier_with_such_a_character_is_refused(tmp_path, table, key, ch):
    cert = tmp_path / "c.toml"
    body = _toml({(table, key): f"AE23{ch}1009"}) if (table, key) != ("certificate", "number") \
        else f'[certificate]\nnumber = {_quoted("C" + ch + "1")}\n'
    if table == "reference":
        body = body.replace("[reference]", "[[reference]]")
    cert.write_text(body, encoding="utf-8")
    r = run_in_process(["enc", "report", str(make_points(tmp_path / "p.parquet", 1)),
                        "--certificate", str(cert), "--html", str(tmp_path / "r.html")])
    line = one_error_line(r, 2, cmd="enc report")
    assert f"certificate file {cert}: [{table}] {key} holds the character U+{ord(ch):04X}" \
        in line, line
    assert not (tmp_path / "r.html").exists()


def test_the_number_given_apart_is_an_identifier_too(tmp_path):
    r = run_in_process(["enc", "report", str(make_points(tmp_path / "p.parquet", 1)),
                        "--certificate-number", "C\u202e1", "--html", str(tmp_path / "r.html")])
    line = one_error_line(r, 2, cmd="enc report")
    assert "--certificate-number" in line and "U+202E (RIGHT-TO-LEFT OVERRIDE)" in line


@pytest.mark.skipif(not shutil.which("pdftotext"), reason="poppler-utils not installed")
def test_free_text_is_shown_escaped_in_the_html_and_the_pdf(tmp_path):
    cert = tmp_path / "c.toml"
    cert.write_text(_toml(FREE), encoding="utf-8")
    points = make_points(tmp_path / "in\u202efdp.parquet", 1)    # a file name is text too
    html, pdf, record = tmp_path / "r.html", tmp_path / "r.pdf", tmp_path / "record.txt"
    r = run_in_process(["enc", "report", str(points), "--certificate", str(cert),
                        "--html", str(html), "--pdf", str(pdf), "--record", str(record)])
    assert r.returncode == 0, r.stderr.decode()
    page = html.read_text(encoding="utf-8")
    text = subprocess.run(["pdftotext", "-enc", "UTF-8", str(pdf), "-"], capture_output=True,
                          check=True).stdout.decode()
    # the PDF's lines break where its layout puts them: compared without white space
    for name, document in (("html", page), ("pdf", "".join(text.split()))):
        found = [f"U+{ord(ch):04X}" for ch in DECEPTIVE if ch in document]
        assert not found, (name, found)
        for shown in ("Encoder\\u2028Serial: FAKE-1", "Lane 3\\u202e9001-32EA",
                      "ok\\x85NEL\\u2029PS", "zero\\u200bwidth\\ufeff\\u2060\\u200d"):
            assert (shown if name == "html" else "".join(shown.split())) in document, (name, shown)
        assert "fdp.parquet" not in document    # a certificate names its results, not files
    # the file's name is in the laboratory's record, escaped there too
    kept = record.read_text(encoding="utf-8")
    assert "in\\u202efdp.parquet" in kept and "\u202e" not in kept
