"""Same inputs, same bytes wherever they are written: with SOURCE_DATE_EPOCH set, a
campaign written into two different folders gives byte-identical files, every one.

Each kind of output (a stream's metadata, a memory table's and a controller file's
comments, a polygon certificate, the report's text, HTML and PDF) names the files of its
command line relative to its own folder, or by their base name when they lie outside it,
never as the machine's absolute path; its time is SOURCE_DATE_EPOCH, but for an
acquisition from a device, which keeps the time it measured at.
"""

from __future__ import annotations

import json
import shlex
import shutil
import time
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from conftest import DATA, ROOT, run

EPOCH = "1764547200"  # 2025-12-01T00:00:00Z
STAMP = "2025-12-01T00:00:00Z"
ENV = {"SOURCE_DATE_EPOCH": EPOCH}
CERT = ROOT / "examples" / "ciomp-23bit-certificate.toml"


def _ok(cmd: str, cwd: Path) -> None:
    r = run(cmd, cwd=cwd, env=ENV)
    assert r.returncode == 0, f"{cmd}\n{r.stderr.decode()}"


def _meta(path: Path) -> dict:
    return json.loads(pq.read_schema(path).metadata[b"enctools"])


def _campaign(out: str, cwd: Path) -> None:
    """Steps 2-7 of examples/ciomp-23bit.mk into ``out`` (as given: relative to ``cwd`` or
    absolute), the certificate's fields named by their absolute path, the ROM a small one."""
    o = shlex.quote(out)
    _ok(f"mkdir -p {o} && "
        f"enc acquire -q --rig ciomp-23bit --mode steps -o {o}/polygon.parquet && "
        f"enc points -q {o}/polygon.parquet -o {o}/points.parquet && "
        f"enc fit-rbf -q {o}/points.parquet -o {o}/model.parquet && "
        f"enc make-rom -q {o}/model.parquet --address-bits 10 --width 16 --verify "
        f"-o {o}/correction.mif && "
        f"enc make-rom -q {o}/points.parquet --target linuxcnc --verify -o {o}/joint.comp && "
        f"enc make-rom -q {o}/model.parquet --address-bits 10 --width 16 -o {o}/rom.parquet && "
        f"enc report {o}/points.parquet {o}/model.parquet {o}/rom.parquet --certificate {CERT} "
        f"--html {o}/report.html --pdf {o}/report.pdf > {o}/report.txt", cwd)


@pytest.mark.slow
def test_a_campaign_written_into_two_folders_gives_the_same_bytes(tmp_path):
    # one folder given relative to the working folder, the other absolute and deeper
    _campaign("a", tmp_path)
    _campaign(str(tmp_path / "x" / "y" / "b"), tmp_path)
    a, b = tmp_path / "a", tmp_path / "x" / "y" / "b"
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    assert len(names) == 9, names
    differ = [n for n in names if (a / n).read_bytes() != (b / n).read_bytes()]
    assert not differ, differ
    for n in names:
        assert str(tmp_path).encode() not in (a / n).read_bytes(), n


def test_a_stream_records_its_paths_relative_to_its_folder(tmp_path):
    (tmp_path / "out" / "in").mkdir(parents=True)
    shutil.copy(DATA / "seed001_table1.csv", tmp_path / "out" / "in" / "t1.csv")
    out = tmp_path / "out"
    _ok(f"enc points -q {out}/in/t1.csv -o {out}/points.parquet", tmp_path)
    meta = _meta(out / "points.parquet")
    assert meta["history"][-1].startswith(STAMP)
    assert meta["history"][-1].endswith(": enc points -q in/t1.csv -o points.parquet")
    assert meta["source"] == "table in/t1.csv"
    # an input outside the output's folder: its base name
    (tmp_path / "elsewhere").mkdir()
    _ok(f"enc fit-rbf -q {out}/points.parquet -o {tmp_path}/elsewhere/model.parquet", tmp_path)
    line = _meta(tmp_path / "elsewhere" / "model.parquet")["history"][-1]
    assert line.endswith(": enc fit-rbf -q points.parquet -o model.parquet"), line


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A points stream and its model in a folder of their own."""
    folder = tmp_path_factory.mktemp("made")
    _ok("enc acquire -q --rig ciomp-23bit --mode steps -o polygon.parquet && "
        "enc points -q polygon.parquet -o points.parquet && "
        "enc fit-rbf -q points.parquet -o model.parquet", folder)
    return folder


@pytest.mark.parametrize(("args", "name"), [
    ("model.parquet --address-bits 10 --width 16", "correction.mif"),
    ("model.parquet --address-bits 10 --width 16 --target coe", "correction.coe"),
    ("points.parquet --target linuxcnc", "joint.comp"),
    ("model.parquet --address-bits 8 --axis C1 --resolution 0.0001", "ENC_COMP.SPF"),
])
def test_a_table_files_comments_name_its_paths_relative_to_its_folder(made, tmp_path, args,
                                                                     name):
    model, out = made / args.split()[0], tmp_path / "out" / name
    out.parent.mkdir()
    rest = " ".join(args.split()[1:])
    _ok(f"enc make-rom -q {model} {rest} -o {out}", tmp_path)
    text = out.read_text()
    assert str(tmp_path) not in text and str(made) not in text
    line = f"{STAMP} enctools"
    assert line in text
    joined = text.replace("\n; ", "")  # comment lines are cut at a control's length
    assert f"enc make-rom -q {args.split()[0]} {rest} -o {name}" in joined


def test_the_reports_name_their_inputs_relative_to_their_folder(made, tmp_path):
    from pypdf import PdfReader

    out = tmp_path / "out"
    out.mkdir()
    # a report, not a certificate: a certificate names its results, not the files
    # (test_certificate_receiver), which the laboratory's record keeps
    _ok(f"enc report {made}/points.parquet {made}/model.parquet "
        f"--html {out}/report.html --pdf {out}/report.pdf > {out}/report.txt", tmp_path)
    pdf = (out / "report.pdf").read_bytes()
    pdf_text = "\n".join(p.extract_text() for p in PdfReader(out / "report.pdf").pages)
    for text in ((out / "report.txt").read_text(), (out / "report.html").read_text(),
                 pdf_text):
        assert str(tmp_path) not in text and str(made) not in text
        assert "points.parquet" in text and "model.parquet" in text
    assert (out / "report.txt").read_text().startswith("points.parquet: points")
    assert "2025-12-01 00:00 UTC" in (out / "report.html").read_text()
    assert b"/CreationDate (D:20251201000000Z" in pdf
    assert b"/ModDate" not in pdf or b"/ModDate (D:20251201000000Z" in pdf


def test_a_polygon_certificate_names_its_run_relative_to_its_folder(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    _ok(f"enc acquire -q --rig ciomp-23bit --mode closure -o {tmp_path}/closure.parquet && "
        f"enc closure -q {tmp_path}/closure.parquet -o {out}/closure-points.parquet "
        f"--faces-out {out}/faces.csv", tmp_path)
    text = (out / "faces.csv").read_text()
    assert str(tmp_path) not in text
    assert "closure closure.parquet" in text and f"# {STAMP} enctools" in text
    meta = _meta(out / "closure-points.parquet")
    assert meta["source"] == "closure run closure.parquet"
    # the certificate applied: the points name it and its run without a folder either
    _ok(f"enc acquire -q --rig ciomp-23bit --mode steps -o {tmp_path}/polygon.parquet && "
        f"enc points -q {tmp_path}/polygon.parquet --polygon-certificate {out}/faces.csv "
        f"-o {tmp_path}/certified.parquet", tmp_path)
    assert str(tmp_path) not in json.dumps(_meta(tmp_path / "certified.parquet"))


def test_a_simulated_acquisition_is_dated_by_source_date_epoch(tmp_path):
    (tmp_path / "out").mkdir()
    _ok(f"enc acquire -q --rig sjtu-dual --revolutions 0.2 -o {tmp_path}/out/raw.parquet "
        f"--tee {tmp_path}/out/copy.arrow && "
        f"enc acquire -q --replay {tmp_path}/out/raw.parquet -o {tmp_path}/out/again.parquet",
        tmp_path)
    line = _meta(tmp_path / "out" / "raw.parquet")["history"][-1]
    assert line.startswith(STAMP) and line.endswith("-o raw.parquet --tee copy.arrow"), line
    meta = _meta(tmp_path / "out" / "again.parquet")
    assert meta["settings"]["replayed"] == "raw.parquet"
    assert meta["history"][-1].endswith("--replay raw.parquet -o again.parquet")


def test_a_bare_name_is_kept_as_given(tmp_path):
    """A value that a folder's name shares is a value, not that folder ("--mode .")."""
    (tmp_path / "steps").mkdir()
    _ok("enc acquire -q --rig ciomp-23bit --mode steps -o steps/polygon.parquet", tmp_path)
    line = _meta(tmp_path / "steps" / "polygon.parquet")["history"][-1]
    assert line.endswith(": enc acquire -q --rig ciomp-23bit --mode steps -o polygon.parquet")


def test_a_device_acquisition_keeps_the_time_it_measured_at(tmp_path):
    pytest.importorskip("pyvisa_sim")
    rig = ROOT / "tests" / "rigs" / "visa-sim.toml"
    before = time.strftime("%Y-%m-%dT%H:%M", time.gmtime(time.time() - 60))
    _ok(f"enc acquire -q --rig {rig} --mode continuous --speed 60 --revolutions 0.25 "
        f"-o {tmp_path}/run.parquet", tmp_path)
    line = _meta(tmp_path / "run.parquet")["history"][-1]
    assert not line.startswith(STAMP) and line[:16] >= before, line
    assert line.endswith("enc acquire -q --rig visa-sim.toml --mode continuous --speed 60 "
                         "--revolutions 0.25 -o run.parquet"), line


def test_corrected_readings_name_their_table_relative_to_their_folder(made, tmp_path):
    _ok(f"enc make-rom -q {made}/model.parquet --address-bits 10 --width 16 "
        f"-o {tmp_path}/c.mif && "
        f"enc acquire -q --rig ciomp-23bit --mode continuous --revolutions 0.1 "
        f"-o {tmp_path}/dense.parquet && "
        f"enc correct -q {tmp_path}/dense.parquet --table {tmp_path}/c.mif --reference truth "
        f"-o {tmp_path}/residual.parquet", tmp_path)
    meta = _meta(tmp_path / "residual.parquet")
    assert meta["settings"]["table"]["file"] == "c.mif"
    assert meta["source"] == "dense.parquet"
    assert str(tmp_path) not in json.dumps(meta)


def test_recorded_paths_inside_outside_and_through_a_link(tmp_path, monkeypatch):
    from enctools.data.header import output_folder, recorded_path, recorded_word

    (tmp_path / "out" / "raw").mkdir(parents=True)
    (tmp_path / "link").symlink_to(tmp_path / "out")
    folder = output_folder(str(tmp_path / "link" / "grad.parquet"))
    assert folder == output_folder(str(tmp_path / "out" / "grad.parquet"))
    assert recorded_path(str(tmp_path / "out" / "raw" / "a.parquet"), folder) == "raw/a.parquet"
    assert recorded_path(str(tmp_path / "link" / "a.parquet"), folder) == "a.parquet"
    assert recorded_path(str(tmp_path / "b.parquet"), folder) == "b.parquet"
    assert recorded_path("/elsewhere/c.toml", folder) == "c.toml"
    assert recorded_word(f"--table={tmp_path}/out/t.mif", folder) == "--table=t.mif"
    assert recorded_word("H1,P1", folder) == "H1,P1"
    assert recorded_word("-", folder) == "-"
    # a working folder removed under the command: no folder known, base names
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    assert output_folder("x/p.parquet") is None
    assert recorded_path("x/p.parquet", None) == "p.parquet"


def test_a_nightly_calibration_names_no_folder_of_the_machine(tmp_path):
    """enc-nightly's default campaign runs in its process: the result it stores as the
    calibration (--init) records the night's paths as its own folder's, not the machine's
    (the history, the calibration and TMPDIR are all absolute here)."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    cal = tmp_path / "cal.parquet"
    r = run([str(ROOT / "bin" / "enc-nightly"), "--rig", "ciomp-23bit", "--history",
             str(tmp_path / "hist"), "--calibration", str(cal), "--init"],
            env={**ENV, "TMPDIR": str(tmp)})
    assert r.returncode == 0, r.stderr.decode()
    meta = _meta(cal)
    assert str(tmp_path) not in json.dumps(meta) and STAMP in meta["history"][-1]
