"""enc make-rom: tables and machine programs are data, never code.

Whatever text an argument carries (the input's name, the output's) lands only inside a
one-line comment of the format; names that land in program text (the SINUMERIK axis,
the ACS axis and array) are checked against what the control accepts. Each written file
is parsed as its control would: every line a comment of that format, a table line, or
a fixed keyword line of the writer.
"""

from __future__ import annotations

import os
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import DATA, one_error_line, run, run_in_process

from enctools.models import romformats as rf
from enctools.models.rom import Settings

#: a comment in each text format (the text after the prefix is checked separately)
COMMENT = {"mif": "-- ", "coe": "; ", "mem": "// ", "acs": "! ", "siemens": "; "}
#: what may not stand inside a comment of the format (it could close or confuse it)
CLOSERS = {"mif": ("%",), "mem": ("/*", "*/")}
NUM = r"-?[0-9][0-9.e+-]*"
#: every line that is not a comment: the fixed lines and table lines of each writer
GRAMMAR = {
    "mif": [r"WIDTH=\d+;", r"DEPTH=\d+;", r"", r"ADDRESS_RADIX=HEX;", r"DATA_RADIX=HEX;",
            r"CONTENT BEGIN", r"\t[0-9A-F]+ : [0-9A-F]+;", r"END;"],
    "coe": [r"memory_initialization_radix=16;", r"memory_initialization_vector=",
            r"[0-9A-F]+[,;]"],
    "mem": [r"@0", r"[0-9A-F]+"],
    "csv": [r"address,correction", r"\d+,-?\d+"],
    "ihex": [r":[0-9A-F]+"],
    "acs": [r"GLOBAL REAL ENC_COMP\(\d+\)", r"INT AXIS_NO", r"AXIS_NO = \d+",
            rf"ENC_COMP\(\d+\)={NUM}", r"ERRORUNMAP AXIS_NO, 0",
            rf"ERRORMAP1D AXIS_NO, 0, 0, {NUM}, ENC_COMP", r"ERRORMAPON AXIS_NO, 0", r"STOP"],
    "siemens": [r"%_N_AX_EEC_INI", r"CHANDATA\(1\)", rf"\$AA_ENC_COMP\[0,\d+,AX1\]={NUM}",
                rf"\$AA_ENC_COMP_(STEP|MIN|MAX|IS_MODULO)\[0,AX1\]={NUM}", r"M17"],
}
EXT = {"mif": "mif", "coe": "coe", "mem": "mem", "csv": "csv", "ihex": "hex", "acs": "prg",
       "siemens": "spf"}
#: a folder and a file name that carry every way out of a comment: line ends (LF, CR,
#: NEL, U+2028/2029), ESC sequences, TAB, DEL, a bidi override, MIF's %, C's /* and */
#: (across the path's /), an undecodable byte, and the keywords the readers look for
HOSTILE_DIR = "d\nM30\r%*"
HOSTILE_NAME = ("*m\nM30\r\nM30\x1b[2J\x1b]0;t\x07\t\x7f\x85\u2028\u2029\u202e%\xfc\udcff"
                "\n$AA_ENC_COMP_STEP[0,AX1]=1.0\nERRORMAP1D AXIS_NO, 0, 0, 1, ENC_COMP"
                "\nmemory_initialization_radix=2;\nCONTENT BEGIN\n.parquet")
BASE = ["--bits", "23", "--address-bits", "5", "--width", "16", "--allow-no-gain"]
#: what the controllers' tables need besides: the control's resolution, ACS's sign
RESOLUTION = {"acs": 1e-4, "siemens": 1e-4}
CONTROL = {"acs": ["--resolution", "0.0001", "--sign", "correction"],
           "siemens": ["--resolution", "0.0001"]}


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    d = tmp_path_factory.mktemp("rominj")
    r = run_in_process(["fit-rbf", f"{DATA}/seed001_table1.csv", "-q", "-o", str(d / "m.parquet")])
    assert r.returncode == 0, r.stderr.decode()
    return d / "m.parquet"


def check_lines(text: str, fmt: str) -> list[str]:
    """The comment texts of a table file; fails unless every other line is the writer's."""
    assert "\r" not in text
    allowed = {"\n", "\t"} if fmt == "mif" else {"\n"}
    assert all(c.isprintable() or c in allowed for c in text), [
        c for c in text if not (c.isprintable() or c in allowed)]
    if fmt in rf.CONTROLLER:
        assert text.isascii()
    assert text.endswith("\n")
    comments = []
    for line in text[:-1].split("\n"):
        prefix = COMMENT.get(fmt)
        if prefix is not None and line.startswith(prefix):
            body = line[len(prefix):]
            assert "\t" not in body and not any(c in body for c in CLOSERS.get(fmt, ())), line
            comments.append(body)
        else:
            assert any(re.fullmatch(g, line) for g in GRAMMAR[fmt]), f"{fmt}: {line!r}"
    return comments


@pytest.mark.parametrize("fmt", sorted(GRAMMAR))
def test_hostile_names_stay_in_comments(model, tmp_path, monkeypatch, fmt):
    folder = tmp_path / HOSTILE_DIR
    folder.mkdir()
    src = os.path.join(str(folder), HOSTILE_NAME)
    shutil.copyfile(model, os.fsencode(src))
    out = str(tmp_path / f"o\nM30\x1b[31m.{EXT[fmt]}")
    args = ["make-rom", src, *BASE, *CONTROL.get(fmt, []), "-o", out, "--verify", "-q"]
    monkeypatch.setattr(sys, "argv", ["enc", *args])  # the history line is the command line
    r = run_in_process(args)
    assert r.returncode == 0, r.stderr.decode()
    data = Path(out).read_bytes()
    comments = check_lines(data.decode("utf-8"), fmt)
    if fmt == "csv":  # header first, no comments: the names are nowhere
        assert not comments and data.startswith(b"address,correction\n")
    elif fmt != "ihex":
        assert any("\\nM30\\r\\nM30\\x1b[2J" in c for c in comments), comments
    # both readers of the format read the table the control would (the comments say nothing)
    target = Settings(23, 5, 16, target=fmt, resolution_deg=RESOLUTION.get(fmt),
                      sign="correction" if fmt == "acs" else None).table
    fast, general = rf.READERS[fmt]
    values = general(data, target, out)
    if fast is not None:  # the fast reader still takes the files written here
        quick = fast(data, target, out)
        assert quick is not None and np.array_equal(quick, values)
    assert np.array_equal(rf.read_table(out, target), values)


def test_sinumerik_repro_in_a_real_process(model, tmp_path):
    """The repro: a newline in the input's name put a bare M30 line into the SPF file."""
    shutil.copyfile(model, tmp_path / "m\nM30.parquet")
    r = run(["enc", "make-rom", b"m\nM30.parquet", *BASE, *CONTROL["siemens"], "-o", "t.spf",
             "--verify", "-q"],
            cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    text = (tmp_path / "t.spf").read_text(encoding="ascii")
    assert "M30" not in [ln.strip() for ln in text.splitlines()]
    check_lines(text, "siemens")


@pytest.mark.parametrize(("ext", "args", "option"), [
    ("spf", ["--axis", "AX1\nM30"], "--axis"),
    ("spf", ["--axis", "AX1;x"], "--axis"),
    ("spf", ["--axis", "$AA_X"], "--axis"),
    ("spf", ["--axis", "AXIS_TOO_LONG"], "--axis"),
    ("spf", ["--axis", "1AX"], "--axis"),
    ("spf", ["--axis", "C\u00fc"], "--axis"),
    ("prg", ["--array", "X;STOP"], "--array"),
    ("prg", ["--array", "ENC\nSTOP"], "--array"),
    ("prg", ["--array", "A" * 33], "--array"),
    ("prg", ["--array", "stop"], "--array"),
    ("prg", ["--array", "AXIS_NO"], "--array"),
    ("prg", ["--axis", "0\nSTOP"], "--axis"),
    ("prg", ["--axis", "X"], "--axis"),
    ("prg", ["--axis", "128"], "--axis"),
    ("prg", ["--axis", "\u0663"], "--axis"),  # an Arabic-Indic digit: not an ACS number
])
def test_names_in_program_text_are_checked(model, tmp_path, ext, args, option):
    out = tmp_path / f"t.{ext}"
    fmt = "acs" if ext == "prg" else "siemens"
    r = run_in_process(["make-rom", str(model), *BASE, *CONTROL[fmt], "-o", str(out), *args])
    line = one_error_line(r, 2, "enc make-rom")
    assert option in line and repr(args[1]) in line
    assert list(tmp_path.iterdir()) == []  # no table, no temporary file


@pytest.mark.parametrize(("ext", "args", "want"), [
    ("spf", ["--axis", "C1"], "$AA_ENC_COMP[0,0,C1]="),
    ("spf", ["--axis", "ax_12345"], "$AA_ENC_COMP[0,0,ax_12345]="),
    ("prg", ["--axis", "007", "--array", "Map_2"], "AXIS_NO = 7\n"),
    ("prg", ["--axis", "127"], "ERRORMAP1D AXIS_NO, 0, 0, 11.25, ENC_COMP\n"),
])
def test_valid_names_are_written(model, tmp_path, ext, args, want):
    out = tmp_path / f"t.{ext}"
    fmt = "acs" if ext == "prg" else "siemens"
    r = run_in_process(["make-rom", str(model), *BASE, *CONTROL[fmt], "-o", str(out), "--verify",
                        "-q", *args])
    assert r.returncode == 0, r.stderr.decode()
    assert want in out.read_text()


def test_library_writers_check_names_too(tmp_path):
    from enctools.errors import SettingsError
    with pytest.raises(SettingsError, match=r"^axis must be"):
        rf.write_table(str(tmp_path / "t.spf"), np.zeros(4, np.int16),
                       rf.Target("siemens", axis="AX1\nM30"))
    assert list(tmp_path.iterdir()) == []
    assert rf.Target("acs").axis == "0" and rf.Target("siemens").axis == "AX1"


@pytest.mark.parametrize(("text", "ascii_only", "reserved", "want"), [
    ("plain text 1.0", False, "", "plain text 1.0"),
    ("a\nb\rc\td", False, "", "a\\nb\\rc\\td"),
    ("\x1b[2J\x7f\x85\u2028\u2029\u202e\udcff", False, "", "\\x1b[2J\\x7f\\x85\\u2028\\u2029"
     "\\u202e\\udcff"),
    ("50% Pr\u00fcf", False, "%", "50\\x25 Pr\u00fcf"),
    ("Pr\u00fcf \u00e9", True, "", "Pr?f ?"),
])
def test_comment_text(text, ascii_only, reserved, want):
    from enctools.models.romformats.words import comment_text
    assert comment_text(text, ascii_only, reserved) == want


@pytest.mark.parametrize(("data", "want"), [
    (b"; memory_initialization_radix=2;\nmemory_initialization_radix=16; "
     b"memory_initialization_vector=1,2,\nFFFF\n;\n", [1, 2, -1]),
    (b"memory_initialization_radix=10;\n; memory_initialization_vector=9;\n"
     b"memory_initialization_vector=\n1,\n0,\n3;\n", [1, 0, 3]),
])
def test_coe_keywords_in_comments_are_not_read(data, want):
    from enctools.models.romformats import readers  # not imported by the package itself
    assert readers.read_coe(data, rf.Target("coe", 16), "x.coe").tolist() == want
