"""Text that reads other than it is (controls, line separators, bidi controls, zero-width
characters): refused in a name or a number from a rig file or a stream's metadata, with
one line naming the field and the character; escaped wherever free text reaches the
terminal (enctools.data.text, the one rule)."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from conftest import DATA, one_error_line, run_in_process

from enctools.data.text import DECEPTIVE, check_identifier, escaped, printable
from enctools.errors import DataError

#: one of each family: C1, NEL, line and paragraph separators, bidi, zero-width
SAMPLES = ["\x9b", "\x85", "\u2028", "\u2029", "\u202a", "\u202e", "\u2066", "\u2069",
           "\u200e", "\u200f", "\u061c", "\u200b", "\u200c", "\u200d", "\ufeff", "\u2060"]


@pytest.mark.parametrize("ch", SAMPLES)
def test_each_character_is_escaped_on_the_terminal_and_in_documents(ch):
    code = ord(ch)
    shown = f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"
    assert code in DECEPTIVE
    assert printable(f"AE23{ch}1009") == f"AE23{shown}1009"
    assert escaped(f"AE23{ch}1009") == f"AE23{shown}1009"


def test_documents_keep_line_breaks_the_terminal_does_not():
    assert escaped("Street 1\n12345 Town\u2028x") == "Street 1\n12345 Town\\u2028x"
    assert printable("Street 1\n12345 Town") == "Street 1\\n12345 Town"
    assert printable("é — ± ↑ ″ 中文 עברית") == "é — ± ↑ ″ 中文 עברית"   # letters stay letters


def test_an_identifier_is_refused_naming_the_field_and_the_character():
    assert check_identifier("AE23-1009", "c.toml: [item] serial") == "AE23-1009"
    with pytest.raises(DataError) as e:
        check_identifier("AE23\u202e9001", "c.toml: [item] serial")
    assert str(e.value).startswith("c.toml: [item] serial holds the character U+202E "
                                   "(RIGHT-TO-LEFT OVERRIDE)")
    with pytest.raises(DataError, match=r"U\+001B \(a control character\)"):
        check_identifier("x\x1b[2J", "rig")


def _rig(tmp_path: Path, name: str = "r", description: str = "d", head: str = "H") -> Path:
    path = tmp_path / "r.toml"
    path.write_text(f'format = 1\nname = "{name}"\ndescription = "{description}"\n'
                    '[[encoder]]\nname = "E"\nperiods_per_rev = 100\ninterpolation = 4\n'
                    f'diameter_mm = 10.0\n[[encoder.head]]\nname = "{head}"\nangle_deg = 0.0\n',
                    encoding="utf-8")
    return path


@pytest.mark.parametrize("where, ch, field", [
    ("name", "\u202e", "name"), ("name", "\u2066", "name"), ("name", "\x85", "name"),
    ("head", "\u200b", "encoder[0].head[0].name"), ("head", "\u2028", "encoder[0].head[0].name")])
def test_a_rig_file_name_with_such_a_character_is_refused(tmp_path, where, ch, field):
    path = _rig(tmp_path, **{where: f"Tab{ch}le"})
    r = run_in_process(["enc", "rig", "check", str(path)])
    line = one_error_line(r, 2, cmd="enc rig")
    assert f"rig file {path}: {field} holds the character U+{ord(ch):04X}" in line
    assert ch not in r.stderr.decode() and ch not in r.stdout.decode()


def test_a_rig_description_is_free_text_shown_escaped(tmp_path):
    path = _rig(tmp_path, description="calibrated\u2028error: fake \u202eAE23")
    r = run_in_process(["enc", "rig", "check", str(path)])
    assert r.returncode == 0, r.stderr.decode()
    out = r.stdout.decode()
    assert "calibrated\\u2028error: fake \\u202eAE23" in out
    assert not any(ch in out for ch in SAMPLES)


def _points(tmp_path: Path) -> Path:
    r = run_in_process(["enc", "points", str(DATA / "seed001_table1.csv"), "-o",
                        str(tmp_path / "p.parquet")])
    assert r.returncode == 0, r.stderr.decode()
    return tmp_path / "p.parquet"


def _with_rig(src: Path, out: Path, **rig: str) -> Path:
    table = pq.read_table(src)
    raw = table.schema.metadata
    meta = json.loads(raw[b"enctools"])
    meta["rig"] = {**meta.get("rig", {}), **rig}
    pq.write_table(table.replace_schema_metadata({**raw, b"enctools": json.dumps(meta)
                                                  .encode()}), out)
    return out


@pytest.mark.parametrize("command", [["info"], ["report"], ["fit-rbf", "-o", "m.parquet"]])
def test_a_streams_rig_name_with_a_bidi_control_is_refused(tmp_path, command):
    nasty = _with_rig(_points(tmp_path), tmp_path / "n.parquet", name="sjtu\u2066-dual")
    r = run_in_process(["enc", command[0], str(nasty), *command[1:]], cwd=tmp_path)
    line = one_error_line(r, 2, cmd=f"enc {command[0]}")
    assert "metadata rig.name holds the character U+2066 (LEFT-TO-RIGHT ISOLATE)" in line
    assert not (tmp_path / "m.parquet").exists()


def test_a_streams_description_reaches_the_terminal_escaped(tmp_path):
    nasty = _with_rig(_points(tmp_path), tmp_path / "n.parquet", name="rig",
                      description="line\u2028error: fake\u202eAE23\u200b")
    for command in (["info"], ["report"]):
        r = run_in_process(["enc", *command, str(nasty)])
        assert r.returncode == 0, r.stderr.decode()
        text = (r.stdout + r.stderr).decode()
        assert not any(ch in text for ch in SAMPLES), command
    assert "line\\u2028error: fake\\u202eAE23\\u200b" in \
        run_in_process(["enc", "info", str(nasty)]).stdout.decode()


def test_every_summary_line_is_escaped():
    from enctools.cli.summary import text_lines

    lines = text_lines({"rig": "Tab\u202ele", "heads": [{"name": "H\u2066", "pp_arcsec": 1.0}],
                        "note": "a\u2028b\x85c"})
    assert not any(ch in line for line in lines for ch in SAMPLES), lines
    assert "Tab\\u202ele" in lines[0] and lines[1].startswith("H\\u2066:")


def test_every_log_line_is_escaped(capsys):
    from enctools.cli import runner

    runner.setup_logging()
    runner.log_warning("curve H1\u202e: fake\u2028line\x1b[2J")
    err = capsys.readouterr().err
    assert err.endswith(": WARNING: curve H1\\u202e: fake\\u2028line\\x1b[2J\n"), err


def test_a_polygon_certificate_number_is_an_identifier(tmp_path):
    from enctools.data.polygon import read_certificate

    faces = "".join(f"{i},{0.1 if i % 2 == 0 else -0.1},0.04\n" for i in range(24))
    path = tmp_path / "cert.csv"
    path.write_text(f"# certificate: PTB 0000 2025\n# k: 2\nface,error,U\n{faces}")
    assert read_certificate(str(path)).number == "PTB 0000 2025"
    path.write_text(f"# certificate: PTB\u2066 2025\n# k: 2\nface,error,U\n{faces}")
    with pytest.raises(DataError, match=r"cert.csv: line 1: certificate holds the character "
                                        r"U\+2066 \(LEFT-TO-RIGHT ISOLATE\)"):
        read_certificate(str(path))
