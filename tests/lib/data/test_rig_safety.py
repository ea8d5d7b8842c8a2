"""A rig file names no code to load and no file outside its folder; templates stay plain.

``[backend] visa_library`` may name only PyVISA's own backends (``""``, ``@ivi``,
``@py``, ``@sim``, ``FILE.yaml@sim`` inside the rig file's folder): a library path is
refused before pyvisa is imported, so no constructor of a shared library ever runs.
``[motion.backend]`` templates may use only their documented plain fields.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest
from conftest import ROOT, one_error_line, run, run_in_process

RIG = ROOT / "tests" / "rigs" / "visa-sim.toml"
SIM = '"rotary-table.yaml@sim"'


def variant(folder: Path, library: str | None = None, **subs: str) -> Path:
    """visa-sim.toml and its simulation file copied to ``folder``, with substitutions."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(RIG.parent / "rotary-table.yaml", folder)
    text = RIG.read_text()
    assert SIM in text
    if library is not None:
        text = text.replace(SIM, library)
    for old, new in subs.items():
        assert old in text, old
        text = text.replace(old, new)
    p = folder / "rig.toml"
    p.write_text(text)
    return p


def refused(rig: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    """The one error line of ``enc acquire`` on ``rig``, run with pyvisa unimportable.

    Were pyvisa imported before the check, the error would be "needs the Python package
    pyvisa" instead: the line names the rig key, so nothing was imported or loaded.
    """
    monkeypatch.setitem(sys.modules, "pyvisa", None)
    out = tmp_path / "x.parquet"
    r = run_in_process(["enc", "acquire", "--rig", str(rig), "-o", str(out)])
    line = one_error_line(r, 2)
    assert "pyvisa" not in line.replace("pyvisa-py", "").replace("pyvisa-sim", ""), line
    assert not out.exists()
    return line


@pytest.mark.parametrize("library", [
    '"/tmp/evil.so"', '"evil.dll"', '"lib.so@ivi"', '"/usr/lib/libvisa.so"', '"@evil"',
    '"evil.so@py"', "5",
])
def test_library_path_is_refused_before_pyvisa(library: str, tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    line = refused(variant(tmp_path / "rig", library), tmp_path, monkeypatch)
    assert "backend.visa_library" in line and "never a library path" in line, line


def test_shared_library_constructor_never_runs(tmp_path: Path) -> None:
    """A real process with a pyvisa stand-in that leaves a mark when imported."""
    mark = tmp_path / "loaded"
    shadow = tmp_path / "shadow" / "pyvisa"
    shadow.mkdir(parents=True)
    (shadow / "__init__.py").write_text(f"open({str(mark)!r}, 'w').close()\n")
    rig = variant(tmp_path / "rig", '"/tmp/evil.so"')
    r = run(f"enc acquire --rig {rig} -o {tmp_path / 'x.parquet'}",
            env={"PYTHONPATH": str(tmp_path / "shadow")})
    line = one_error_line(r, 2)
    assert "'/tmp/evil.so'" in line and "never a library path" in line, line
    assert not mark.exists()


@pytest.mark.parametrize("library", [
    '"../../../../etc/passwd@sim"', '"/etc/passwd@sim"',
    f'"{ROOT}/tests/rigs/rotary-table.yaml@sim"', '"sub/../../rotary-table.yaml@sim"',
])
def test_simulation_file_outside_the_rig_folder_is_refused(
        library: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    line = refused(variant(tmp_path / "rig", library), tmp_path, monkeypatch)
    assert "outside the rig file's folder" in line, line


def test_symlink_out_of_the_rig_folder_is_refused(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    rig = variant(tmp_path / "rig", '"link.yaml@sim"')
    (tmp_path / "rig" / "link.yaml").symlink_to(RIG.parent / "rotary-table.yaml")
    line = refused(rig, tmp_path, monkeypatch)
    assert "outside the rig file's folder" in line, line


def test_simulation_file_must_be_yaml(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    rig = variant(tmp_path / "rig", '"notes.txt@sim"')
    (tmp_path / "rig" / "notes.txt").write_text("x: 1\n")
    line = refused(rig, tmp_path, monkeypatch)
    assert "must end in .yaml or .yml" in line, line


def test_simulation_file_inside_the_folder_is_taken(tmp_path: Path) -> None:
    from enctools.data.rig import load_rig
    from enctools.hw.visa import library_spec

    folder = tmp_path / "rig"
    for lib in ('"rotary-table.yaml@sim"', f'"{folder}/rotary-table.yaml@sim"',
                '"./sub/../rotary-table.yaml@sim"'):
        spec = library_spec(load_rig(str(variant(folder, lib))))
        assert spec == f"{(folder / 'rotary-table.yaml').resolve()}@sim"
    for lib in ('""', '"@py"', '"@ivi"', '"@sim"'):
        assert library_spec(load_rig(str(variant(folder, lib)))) == lib.strip('"')


@pytest.mark.parametrize("old,new,field", [
    ('move = "MOVE {counts:d}"', 'move = "MOVE {counts.__class__}"', "{counts.__class__}"),
    ('move = "MOVE {counts:d}"', 'move = "MOVE {counts[0]}"', "{counts[0]}"),
    ('move = "MOVE {counts:d}"', 'move = "MOVE {deg!r}"', "{deg!r}"),
    ('move = "MOVE {counts:d}"', 'move = "MOVE {}"', "{}"),
    ('move = "MOVE {counts:d}"', 'move = "MOVE {0}"', "{0}"),
    ('move = "MOVE {counts:d}"', 'move = "MOVE {deg:{counts}}"', "{deg:{counts}}"),
    ('move = "MOVE {counts:d}"', 'move = "MOVE {rpm}"', "{rpm}"),
    ('rotate = "JOG {rpm:.4f}"', 'rotate = "JOG {rpm.__class__.__mro__}"',
     "{rpm.__class__.__mro__}"),
])
def test_template_fields_are_plain_names(old: str, new: str, field: str, tmp_path: Path,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    line = refused(variant(tmp_path / "rig", None, **{old: new}), tmp_path, monkeypatch)
    key = "move" if "move" in old else "rotate"
    assert f"motion.backend.{key}: template" in line and f"the field {field};" in line, line
    assert "allowed fields: {deg}" in line or "allowed fields: {rpm}" in line, line


def test_malformed_template_is_one_line(tmp_path: Path,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    rig = variant(tmp_path / "rig", None, **{'"MOVE {counts:d}"': '"MOVE {counts"'})
    line = refused(rig, tmp_path, monkeypatch)
    assert "template 'MOVE {counts'" in line and "allowed fields" in line, line


def test_documented_templates_pass() -> None:
    from enctools.data.rig import load_rig
    from enctools.hw.config import check_template
    from enctools.hw.dialogue import TEMPLATE_FIELDS

    rig = load_rig(str(RIG))
    for tpl in ("MOVE {counts:d}", "MOVE:ABS {deg:.6f}", "PA{arcsec:+.2f};BG", "{rad}",
                "MOVE {{literal}} {deg}", "STOP"):
        check_template(tpl, TEMPLATE_FIELDS["move"], rig, "motion.backend.move")
    check_template("JOG {rpm:.4f} {deg_s:g} {rad_s}", TEMPLATE_FIELDS["rotate"], rig,
                   "motion.backend.rotate")
