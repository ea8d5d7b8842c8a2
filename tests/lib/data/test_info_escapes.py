"""Metadata read from a file reaches the terminal escaped: it cannot clear the screen,
set the window title, move the cursor or fake a line (``enc info``, ``enc report``)."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from conftest import DATA, run_in_process

from enctools.data.text import printable

NASTY = "\x1b[2J\x1b]0;title\x07\rerror: fake\x9b31m\x7f"
SHOWN = "\\x1b[2J\\x1b]0;title\\x07\\rerror: fake\\x9b31m\\x7f"
FORBIDDEN = (b"\x1b", b"\x07", b"\r", b"\xc2\x9b", b"\x7f")


def with_nasty_meta(src: Path, out: Path) -> Path:
    """A copy of the stream ``src`` whose rig description and history lines carry control
    sequences (its name is an identifier, refused with them: test_text_deceptive.py)."""
    table = pq.read_table(src)
    raw = table.schema.metadata
    meta = json.loads(raw[b"enctools"])
    meta["rig"] = {**meta.get("rig", {}), "name": "rig",
                   "description": "desc" + NASTY + "\nsecond line"}
    meta["history"] = [*meta.get("history", []), "hist" + NASTY]
    table = table.replace_schema_metadata({**raw, b"enctools": json.dumps(meta).encode()})
    pq.write_table(table, out)
    return out


@pytest.fixture
def nasty(tmp_path: Path) -> Path:
    r = run_in_process(["enc", "points", str(DATA / "seed001_table1.csv"), "-o",
                        str(tmp_path / "p.parquet")])
    assert r.returncode == 0, r.stderr.decode()
    return with_nasty_meta(tmp_path / "p.parquet", tmp_path / "nasty.parquet")


def test_printable_escapes_every_control_character() -> None:
    assert printable("a\tb\nc\x00\x1b\x7f\x80\x9f\xa0é—") == \
        "a\\tb\\nc\\x00\\x1b\\x7f\\x80\\x9f\xa0é—"
    assert printable("plain: 1.5\" [arcsec] \\x") == "plain: 1.5\" [arcsec] \\x"


def test_info_shows_metadata_escaped(nasty: Path) -> None:
    r = run_in_process(["enc", "info", str(nasty)])
    assert r.returncode == 0, r.stderr.decode()
    for b in FORBIDDEN:
        assert b not in r.stdout, b
    text = r.stdout.decode()
    assert "rig: rig — desc" + SHOWN + "\\nsecond line\n" in text
    assert "    hist" + SHOWN + "\n" in text
    assert not any(line.startswith("error:") for line in text.splitlines())


def test_report_shows_metadata_escaped(nasty: Path) -> None:
    r = run_in_process(["enc", "report", str(nasty)])
    assert r.returncode == 0, r.stderr.decode()
    for b in FORBIDDEN:
        assert b not in r.stdout, b
    assert "rig rig\n" in r.stdout.decode()


def test_error_lines_escape_what_they_quote(tmp_path):
    """A file name carrying escape sequences is quoted in the error line, never obeyed."""
    name = str(tmp_path / "no\x1b[2J\x1b]0;title\x07such\x9b.parquet")
    r = run_in_process(["info", name])
    err = r.stderr.decode()
    assert r.returncode == 2 and err.startswith("enc info: error: "), err
    assert not any(c in err for c in "\x1b\x07\x9b\r") and "\\x1b[2J" in err, err
