"""A file name that is not UTF-8 (Latin-1 ``\\xe9.parquet``: legal on Linux) is read and
written like any other, and shown with its byte escaped (``\\xe9``): on the terminal, in
error lines, in the HTML and PDF report and its plots (was "internal error:
UnicodeEncodeError" from pyarrow, and a TypeError from matplotlib)."""

from __future__ import annotations

import os
import shutil
import subprocess

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import DATA, one_error_line, run

E9 = os.fsdecode(b"\xe9")        # the byte 0xE9 as Python's arguments carry it (PEP 383)


def _ok(cmd: list[str], cwd) -> subprocess.CompletedProcess:
    r = run(cmd, cwd=cwd)
    assert r.returncode == 0, r.stderr.decode("utf-8", "replace")
    assert b"internal error" not in r.stderr
    return r


@pytest.mark.parametrize("ext", ["parquet", "arrow", "arrows", "h5", "csv"])
def test_an_output_and_an_input_named_in_latin1(tmp_path, ext):
    name = f"p{E9}.{ext}"
    _ok(["enc", "points", str(DATA / "seed001_table1.csv"), "-q", "-o", name], tmp_path)
    assert os.fsencode(name) in os.listdir(os.fsencode(tmp_path))
    info = _ok(["enc", "info", name], tmp_path).stdout
    assert info.startswith(b"p\\xe9." + ext.encode() + b": points stream")
    _ok(["enc", "fit-rbf", name, "-q", "-o", f"m{E9}.parquet"], tmp_path)
    assert (tmp_path / f"m{E9}.parquet").exists()


def test_a_users_table_named_in_latin1(tmp_path):
    table = pa.table({"position_deg": [0.0, 90.0, 180.0, 270.0],
                      "deviation_arcsec": [0.5, -0.2, 0.1, -0.4]})
    pq.write_table(table, tmp_path / "t.parquet")
    os.rename(tmp_path / "t.parquet", tmp_path / f"t{E9}.parquet")
    _ok(["enc", "points", f"t{E9}.parquet", "-q", "-o", "p.parquet"], tmp_path)
    assert pq.read_table(tmp_path / "p.parquet").num_rows == 4


def test_a_missing_input_named_in_latin1_is_one_line_with_its_byte_escaped(tmp_path):
    r = run(["enc", "info", f"no{E9}.parquet"], cwd=tmp_path)
    line = one_error_line(r, 2, cmd="enc info")
    assert line == "enc info: error: no\\xe9.parquet: no such file", line


@pytest.mark.slow
@pytest.mark.skipif(not shutil.which("pdftotext"), reason="poppler-utils not installed")
def test_a_report_of_an_input_named_in_latin1(tmp_path):
    _ok(["enc", "points", str(DATA / "seed001_table1.csv"), "-q", "-o", f"{E9}.parquet"],
        tmp_path)
    _ok(["enc", "report", f"{E9}.parquet", "-q", "--html", f"r{E9}.html", "--pdf",
         f"r{E9}.pdf"], tmp_path)
    page = (tmp_path / f"r{E9}.html").read_text(encoding="utf-8")
    text = subprocess.run(["pdftotext", os.fsencode(tmp_path / f"r{E9}.pdf"), "-"],
                          capture_output=True, check=True).stdout.decode()
    assert "\\xe9.parquet" in page and "\\xe9.parquet" in text



def test_a_text_option_in_latin1_is_one_line_naming_the_byte(tmp_path):
    """A title is text, not a file name: its byte is named, nothing is written (was
    written into the documents; a --name became a column's, an internal error)."""
    _ok(["enc", "points", str(DATA / "seed001_table1.csv"), "-q", "-o", "p.parquet"], tmp_path)
    r = run(["enc", "report", "p.parquet", "--title", f"T{E9}", "--html", "r.html"],
            cwd=tmp_path)
    line = one_error_line(r, 2, cmd="enc report")
    assert "'--title': 'T\\xe9' holds the byte \\xe9, which is not UTF-8 text" in line
    assert not (tmp_path / "r.html").exists()
