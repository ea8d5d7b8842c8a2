"""Same inputs, same bytes: with SOURCE_DATE_EPOCH set, the time a command writes into
its outputs (history lines, the report's date, the PDF's CreationDate) is that time, so
the same commands give byte-identical files; a malformed value is refused (exit 2)."""

from __future__ import annotations

import json
import shutil

import pyarrow.parquet as pq
import pytest
from conftest import DATA, run

EPOCH = "1764547200"  # 2025-12-01T00:00:00Z


def _campaign(folder, env):
    folder.mkdir()
    shutil.copy(DATA / "seed001_table1.csv", folder / "t1.csv")
    r = run("enc points t1.csv -q -o points.parquet && "
            "enc fit-rbf points.parquet -q -o model.parquet && "
            "enc report points.parquet --html report.html --pdf report.pdf > report.txt",
            cwd=folder, env=env)
    assert r.returncode == 0, r.stderr.decode()


@pytest.mark.slow
def test_the_same_commands_give_the_same_bytes(tmp_path):
    env = {"SOURCE_DATE_EPOCH": EPOCH}
    _campaign(tmp_path / "a", env)
    _campaign(tmp_path / "b", env)
    for name in ("points.parquet", "model.parquet", "report.html", "report.pdf",
                 "report.txt"):
        a, b = (tmp_path / d / name for d in ("a", "b"))
        assert a.read_bytes() == b.read_bytes(), name
    meta = json.loads(pq.read_schema(tmp_path / "a" / "model.parquet").metadata[b"enctools"])
    assert all(line.startswith("2025-12-01T00:00:00Z ") for line in meta["history"])
    assert b"2025-12-01 00:00 UTC" in (tmp_path / "a" / "report.html").read_bytes()
    assert b"/CreationDate (D:20251201000000Z" in (tmp_path / "a" / "report.pdf").read_bytes()


@pytest.mark.parametrize("value", ["yesterday", "-5", "1.5", "１２３"])
def test_a_malformed_source_date_epoch_is_refused(tmp_path, value):
    r = run(f"enc points {DATA}/seed001_table1.csv -o {tmp_path}/p.parquet",
            env={"SOURCE_DATE_EPOCH": value})
    err = r.stderr.decode()
    assert r.returncode == 2 and err.count("\n") == 1 and "SOURCE_DATE_EPOCH" in err, err
    assert not (tmp_path / "p.parquet").exists()
