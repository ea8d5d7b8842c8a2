"""bin/enc-nightly and the history dataset: drift against the stored calibration, one
row per run, two runs at once, a run killed mid-write, enc report --history."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pyarrow.parquet as pq
import pytest
from conftest import DATA, ROOT, one_error_line, run

from enctools.data.streams import read_table
from enctools.report.history import SCHEMA, append_run, read_history

NIGHTLY = str(ROOT / "bin" / "enc-nightly")


def csv_campaign(table_no: int, sleep: float = 0.0) -> str:
    """A campaign that 'measures' seed 001 table N (fast, deterministic)."""
    pause = f"sleep {sleep} && " if sleep else ""
    return f'{pause}enc points {DATA}/seed001_table{table_no}.csv -o "$OUT/result.parquet"'


def nightly(hist: Path, cal: Path, *args: str, campaign: str | None = None):
    cmd = [NIGHTLY, "--rig", "ciomp-23bit", "--history", str(hist), "--calibration", str(cal),
           *args]
    if campaign is not None:
        cmd += ["--campaign", campaign]
    return run(cmd)


@pytest.mark.slow
def test_first_night_stores_calibration_then_rechecks(tmp_path):
    """Default campaign (re-acquire the polygon, enc points): night 1 stores the
    calibration, night 2 with another noise seed stays within 0.2" of it."""
    hist, cal = tmp_path / "hist", tmp_path / "cal.parquet"
    r = nightly(hist, cal, "--init")
    assert r.returncode == 0, r.stderr.decode()
    assert cal.exists() and "stored this run as the calibration" in r.stderr.decode()
    seed2 = ('enc acquire --rig "$RIG" --mode steps --seed 77 | '
             'enc points -o "$OUT/result.parquet"')
    r = nightly(hist, cal, "--max-drift", "0.2", "--html", str(tmp_path / "n.html"),
                campaign=seed2)
    assert r.returncode == 0, r.stderr.decode()
    assert ": ok: p-p" in r.stdout.decode()
    h = read_history(hist)
    assert h.runs == 2 and list(h.column("status")) == ["ok", "ok"]
    drift = h.column("drift_max")
    assert drift[0] == 0.0 and 0 < drift[1] < 0.2        # noise only: 0.05" per head
    # the polygon run's figures: about 1.5" Bessel s, p-p about 5" (ciomp-23bit rig)
    assert 1.0 < h.column("std")[1] < 2.0
    summary = json.loads(h.column("summary_json")[1])
    assert summary["drift"]["tolerance_arcsec"] == 0.2
    html = (tmp_path / "n.html").read_text()
    assert "Nightly history" in html and "<b>Conforms</b> to every limit given" in html


@pytest.mark.slow
def test_drift_beyond_tolerance_exits_1_and_is_recorded(tmp_path):
    hist, cal = tmp_path / "hist", tmp_path / "cal.parquet"
    assert nightly(hist, cal, "--init", campaign=csv_campaign(1)).returncode == 0
    r = nightly(hist, cal, "--max-drift", "0.5", campaign=csv_campaign(2))   # "compensated"
    assert r.returncode == 1
    err = r.stderr.decode().strip().splitlines()
    assert err[-1].startswith("enc-nightly: error: drift 2.645 arcsec > --max-drift 0.5")
    h = read_history(hist)
    assert list(h.column("status")) == ["ok", "drift"]
    assert list(h.column("exit_code")) == [0, 1]
    # drift = table 2 - table 1 at the same positions, mean removed over the 24 distinct
    # positions (0 and 360 deg are one target; both rows are 0 in these tables)
    import numpy as np
    t1 = np.loadtxt(DATA / "seed001_table1.csv", delimiter=",", comments="#", skiprows=3)
    t2 = np.loadtxt(DATA / "seed001_table2.csv", delimiter=",", comments="#", skiprows=3)
    assert t1[0, 0] == 0 and t1[-1, 0] == 360 and t1[0, 1] == t1[-1, 1] == 0
    d = t2[:-1, 1] - t1[:-1, 1]
    d -= d.mean()
    assert h.column("drift_max")[1] == pytest.approx(np.abs(d).max(), abs=1e-9)
    r = run(["enc", "report", "--history", str(hist)])
    assert r.returncode == 0
    out = r.stdout.decode()
    assert "2 run(s)" in out and "drift" in out and "2.645" in out


@pytest.mark.parametrize("case, campaign, code", [
    ("no calibration", None, 2),
    ("device fault", "echo 'enc acquire: error: timeout' >&2; exit 3", 3),
    ("no result", "true", 2),
])
@pytest.mark.slow
def test_failed_runs_are_recorded(tmp_path, case, campaign, code):
    hist, cal = tmp_path / "hist", tmp_path / "cal.parquet"
    if case != "no calibration":
        assert nightly(hist, cal, "--init", campaign=csv_campaign(1)).returncode == 0
    r = nightly(hist, cal, campaign=campaign or csv_campaign(1))
    assert r.returncode == code
    line = r.stderr.decode().strip().splitlines()[-1]
    assert line.startswith("enc-nightly: error:")
    h = read_history(hist)
    assert h.column("status")[-1] == "error" and h.column("exit_code")[-1] == code


@pytest.mark.slow
def test_two_runs_at_once_both_land(tmp_path, enc):
    hist, cal = tmp_path / "hist", tmp_path / "cal.parquet"
    assert nightly(hist, cal, "--init", campaign=csv_campaign(1)).returncode == 0
    env = dict(os.environ, PATH=f"{Path(enc).parent}{os.pathsep}{os.environ['PATH']}")
    procs = [subprocess.Popen([NIGHTLY, "--rig", "ciomp-23bit", "--history", str(hist),
                               "--calibration", str(cal), "--campaign",
                               csv_campaign(t, sleep=0.5), "--max-drift", "9"],
                              env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
             for t in (1, 3)]
    results = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], results
    h = read_history(hist)
    assert h.runs == 3 and len(set(h.column("run_id"))) == 3
    assert sorted(h.column("pp")[1:]) == pytest.approx([2.29, 5.46])


_KILLED = textwrap.dedent("""
    import os, signal, sys
    import deltalake
    from enctools.report import history

    def half_then_die(table, data, **kw):   # the night's data file written, no commit
        import pyarrow.parquet as pq
        folder = os.path.join(sys.argv[1], "rig=killed")
        os.makedirs(folder, exist_ok=True)
        pq.write_table(data, os.path.join(folder, "part-00001-orphan.parquet"))
        os.kill(os.getpid(), signal.SIGKILL)   # ... then the power goes
    deltalake.write_deltalake = half_then_die
    history.append_run(sys.argv[1], {"rig": "killed", "status": "ok"})
""")


@pytest.mark.slow
def test_run_killed_mid_write_leaves_history_readable(tmp_path):
    hist = tmp_path / "hist"
    append_run(hist, {"rig": "before", "status": "ok", "pp": 1.0})
    p = subprocess.run([sys.executable, "-c", _KILLED, str(hist)], capture_output=True)
    assert p.returncode == -signal.SIGKILL, p.stderr.decode()
    assert (hist / "rig=killed" / "part-00001-orphan.parquet").exists()  # written, no commit
    h = read_history(hist)
    assert h.runs == 1 and h.column("rig").tolist() == ["before"] and not h.skipped
    append_run(hist, {"rig": "after", "status": "ok"})
    assert read_history(hist).runs == 2
    from deltalake import DeltaTable  # any Delta reader
    t = DeltaTable(str(hist)).to_pyarrow_dataset().to_table()
    assert sorted(t.column("rig").to_pylist()) == ["after", "before"]
    r = run(["enc", "report", "--history", str(hist)])
    assert r.returncode == 0 and "2 run(s)" in r.stdout.decode()


@pytest.mark.slow
def test_killed_nightly_process_leaves_history_readable(tmp_path, enc):
    hist, cal = tmp_path / "hist", tmp_path / "cal.parquet"
    assert nightly(hist, cal, "--init", campaign=csv_campaign(1)).returncode == 0
    env = dict(os.environ, PATH=f"{Path(enc).parent}{os.pathsep}{os.environ['PATH']}")
    p = subprocess.Popen([NIGHTLY, "--rig", "ciomp-23bit", "--history", str(hist),
                          "--calibration", str(cal), "--campaign", "sleep 30"], env=env,
                         start_new_session=True)
    import time
    time.sleep(1.0)
    os.killpg(p.pid, signal.SIGKILL)
    p.wait(timeout=30)
    h = read_history(hist)
    assert h.runs == 1 and not h.skipped


def test_a_damaged_file_of_the_layout_before_is_skipped_with_a_warning(tmp_path):
    from enctools.report.history_hive import FILE_SCHEMA
    hist = tmp_path / "hist"
    good = SCHEMA.empty_table().to_pylist() + [{"run_id": "g", "rig": "good", "status": "ok"}]
    hist.mkdir()
    pq.write_table(pa_table(good, SCHEMA), hist / "run-good.parquet")
    (hist / "run-damaged.parquet").write_bytes(b"PAR1 not really")  # the flat layout
    assert FILE_SCHEMA.names[0] == "run_id"
    r = run(["enc", "report", "--history", str(hist), "--json"])
    assert r.returncode == 0
    assert "skipping unreadable run-damaged.parquet" in r.stderr.decode()
    assert [row["rig"] for row in json.loads(r.stdout)["history"]] == ["good"]


def pa_table(rows, schema):
    import pyarrow as pa
    return pa.Table.from_pylist(rows, schema=schema)


@pytest.mark.heavy
def test_history_rows_have_the_schema(tmp_path):
    assert append_run(tmp_path, {"rig": "x", "status": "ok", "drift_max": 0.1}) == 1
    assert (tmp_path / "_delta_log").is_dir()
    assert read_history(tmp_path).table.schema == SCHEMA


@pytest.mark.slow
def test_history_errors(tmp_path):
    r = run(["enc", "report", "--history", str(tmp_path / "none")])
    assert r.returncode == 2 and "no such folder" in r.stderr.decode()
    r = run([NIGHTLY, "--rig", "x", "--history", str(tmp_path), "--calibration", "c.parquet",
             "--tolerance", "-1"])
    assert r.returncode == 2 and r.stderr.decode().startswith("enc-nightly: error:")
    r = run([NIGHTLY, "--history", str(tmp_path)])
    assert r.returncode == 2 and "--rig" in r.stderr.decode()


def test_nightly_man_page_lists_every_option():
    from enctools.cli.nightly import command
    page = (ROOT / "man" / "enc-nightly.1").read_text()
    for p in command.params:
        for opt in p.opts:
            assert opt.replace("-", r"\-") in page, opt


@pytest.mark.slow
def test_first_night_makes_the_calibration_folder(tmp_path):
    """A lab's first cron night: neither the history nor the calibration folder exists."""
    hist, cal = tmp_path / "n" / "history", tmp_path / "n" / "cal" / "calibration.parquet"
    page = tmp_path / "n" / "www" / "latest.html"
    r = nightly(hist, cal, "--init", "--html", str(page), campaign=csv_campaign(1))
    assert r.returncode == 0, r.stderr.decode()
    assert cal.exists() and read_history(hist).runs == 1 and page.exists()


@pytest.mark.slow
def test_unwritable_calibration_is_one_line(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    r = nightly(tmp_path / "h", blocker / "cal.parquet", "--init", campaign=csv_campaign(1))
    err = r.stderr.decode()
    assert r.returncode == 2 and err.startswith("enc-nightly: error: ") and "Traceback" not in err
    assert read_history(tmp_path / "h").runs == 1  # the failed night is recorded


def test_existing_html_is_replaced_only_with_force(tmp_path):
    hist, cal, page = tmp_path / "h", tmp_path / "cal.parquet", tmp_path / "latest.html"
    page.write_text("yesterday")
    r = nightly(hist, cal, "--init", "--html", str(page), campaign=csv_campaign(1))
    err = r.stderr.decode()
    assert r.returncode == 2 and err.startswith("enc-nightly: error: output ") and \
        "exists; use --force" in err and len(err.splitlines()) == 1, err
    assert page.read_text() == "yesterday" and not cal.exists()
    assert not hist.exists() or read_history(hist).runs == 0  # refused before the night
    r = nightly(hist, cal, "--init", "--html", str(page), "--force", campaign=csv_campaign(1))
    assert r.returncode == 0, r.stderr.decode()
    assert "Nightly history" in page.read_text() and read_history(hist).runs == 1


def test_help_names_the_command():
    r = run([NIGHTLY, "--help"])
    assert r.returncode == 0 and r.stdout.decode().startswith("Usage: enc-nightly [OPTIONS]")


@pytest.mark.parametrize(("sig", "code", "why"), [(signal.SIGTERM, 143, "terminated"),
                                                  (signal.SIGINT, 130, "interrupted")])
def test_terminated_night_is_recorded(tmp_path, enc, sig, code, why):
    """SIGTERM as SIGINT: the campaign is stopped, the row lands, exit 143 (130)."""
    hist, cal, work = tmp_path / "hist", tmp_path / "cal.parquet", tmp_path / "work"
    env = dict(os.environ, PATH=f"{Path(enc).parent}{os.pathsep}{os.environ['PATH']}")
    p = subprocess.Popen([NIGHTLY, "--rig", "ciomp-23bit", "--history", str(hist),
                          "--calibration", str(cal), "--keep", str(work),
                          "--campaign", 'touch "$OUT/started" && sleep 30'], env=env,
                         stderr=subprocess.PIPE)
    import time
    deadline = time.monotonic() + 60
    while not list(work.glob("*/started")) and time.monotonic() < deadline:
        time.sleep(0.05)                    # the night's own subfolder of --keep
    p.send_signal(sig)
    _, err = p.communicate(timeout=30)
    assert p.returncode == code, err
    assert err.decode().strip().splitlines()[-1] == f"enc-nightly: error: {why}"
    h = read_history(hist)
    assert h.runs == 1 and h.column("status")[0] == "interrupted" \
        and h.column("exit_code")[0] == code


def test_settings_and_drift_in_process():
    import numpy as np

    from enctools.data.statistics import curve_figures
    from enctools.errors import SettingsError
    from enctools.report.nightly import Settings, drift
    from enctools.report.sections import Curve

    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(SettingsError, match="tolerance must be >= 0"):
            Settings("r", "h", "c", tolerance=bad)
    angle = np.radians(np.arange(0.0, 360.0, 15.0))
    stored = 2.0 * np.sin(angle)
    current = stored + 0.3 * np.cos(2 * angle) + 5.0       # a new zero and a drift
    curves = [Curve("c", "arcsec", "points", angle, v, curve_figures(v))
              for v in (current, stored)]
    d = drift(curves[0], curves[1])
    assert d.offset == pytest.approx(5.0)
    assert np.allclose(d.drift, 0.3 * np.cos(2 * angle))
    assert d.max_abs == pytest.approx(0.3) and d.pp == pytest.approx(0.6)


# ------------------------------------------------ signals, full disks, temporary folders

def _sigterm_caught(pid: int) -> bool:
    """True once process ``pid`` handles SIGTERM (its handler is installed), or is gone."""
    import re
    try:
        status = Path(f"/proc/{pid}/status").read_text()
        if b"enctools.cli.nightly" not in Path(f"/proc/{pid}/cmdline").read_bytes():
            return False  # still the shell script, before its exec
    except OSError:
        return True
    m = re.search(r"SigCgt:\s*([0-9a-f]+)", status)
    return m is None or bool(int(m.group(1), 16) & (1 << (signal.SIGTERM - 1)))


def _nightly_env(enc: str, tmp: Path) -> dict[str, str]:
    return dict(os.environ, PATH=f"{Path(enc).parent}{os.pathsep}{os.environ['PATH']}",
                TMPDIR=str(tmp))


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux /proc")
def test_sigterm_at_any_point_records_the_night_or_leaves_history_unchanged(tmp_path, enc):
    """SIGTERM at 12 points of a night (imports, campaign, analysis, the row, the
    clean-up): exit 143 with one line and no summary, the history valid with the
    night's row or unchanged, no temporary folder or file left."""
    import time
    hist, cal, tmp = tmp_path / "hist", tmp_path / "cal.parquet", tmp_path / "tmp"
    tmp.mkdir()
    assert nightly(hist, cal, "--init", campaign=csv_campaign(1)).returncode == 0
    env, runs, recorded = _nightly_env(enc, tmp), 1, 0
    for delay in (0.0, 0.05, 0.15, 0.3, 0.6, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.5):
        p = subprocess.Popen([NIGHTLY, "--rig", "ciomp-23bit", "--history", str(hist),
                              "--calibration", str(cal), "--html", str(tmp_path / "n.html"),
                              "--force", "--campaign", csv_campaign(1, sleep=0.3)],
                             env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        deadline = time.monotonic() + 30
        while not _sigterm_caught(p.pid) and time.monotonic() < deadline:
            time.sleep(0.002)
        time.sleep(delay)
        p.terminate()
        out, err = p.communicate(timeout=60)
        h = read_history(hist)
        assert not h.skipped and not [f.name for f in hist.rglob(".*")]
        assert list(tmp.iterdir()) == [], delay
        if p.returncode == 0:                      # done before the signal
            runs += 1
            assert h.runs == runs and b": ok: " in out
            continue
        assert p.returncode == 143, (delay, err)
        assert err.decode().splitlines()[-1] == "enc-nightly: error: terminated", err
        assert b": ok: " not in out and "Traceback" not in err.decode()
        assert h.runs in (runs, runs + 1), delay
        if h.runs == runs + 1:
            recorded += 1
            last = (h.column("status")[-1], h.column("exit_code")[-1])
            assert last in (("interrupted", 143), ("ok", 0)), last  # the row was being written
        runs = h.runs
    assert recorded >= 3   # most signals land in the night itself


@pytest.mark.slow
def test_sigterm_stops_every_process_of_the_campaign(tmp_path, enc):
    """The campaign's pipeline is stopped with the night: nothing of it runs on."""
    import time
    hist, cal, tmp = tmp_path / "hist", tmp_path / "cal.parquet", tmp_path / "tmp"
    tmp.mkdir()
    mark = tmp_path / "went-on"
    p = subprocess.Popen([NIGHTLY, "--rig", "r", "--history", str(hist), "--calibration",
                          str(cal), "--campaign",
                          f'touch "{tmp_path}/started"; (sleep 2; touch {mark}) | cat'],
                         env=_nightly_env(enc, tmp), stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while not (tmp_path / "started").exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    p.terminate()
    assert p.wait(timeout=30) == 143
    time.sleep(2.5)
    assert not mark.exists() and list(tmp.iterdir()) == []
    h = read_history(hist)
    assert h.runs == 1 and h.column("exit_code")[0] == 143


@pytest.mark.slow
def test_work_folder_of_a_killed_night_is_removed_by_the_next(tmp_path, enc):
    hist, cal, tmp = tmp_path / "hist", tmp_path / "cal.parquet", tmp_path / "tmp"
    tmp.mkdir()
    env = _nightly_env(enc, tmp)
    p = subprocess.Popen([NIGHTLY, "--rig", "r", "--history", str(hist), "--calibration",
                          str(cal), "--campaign", 'touch "$OUT/started"; sleep 30'],
                         env=env, start_new_session=True)
    import time
    deadline = time.monotonic() + 60
    while not list(tmp.glob("*/started")) and time.monotonic() < deadline:
        time.sleep(0.02)
    os.killpg(p.pid, signal.SIGKILL)
    p.wait(timeout=30)
    assert [f.name.startswith("enc-nightly-") for f in tmp.iterdir()] == [True]
    r = subprocess.run([NIGHTLY, "--rig", "r", "--history", str(hist), "--calibration",
                        str(cal), "--init", "--campaign", csv_campaign(1)], env=env,
                       capture_output=True)
    assert r.returncode == 0, r.stderr
    assert list(tmp.iterdir()) == []


def test_stale_work_folders_only_of_dead_processes(tmp_path):
    from enctools.data.files import writer_tag
    from enctools.report.nightly import remove_stale_work_folders
    dead = 2**22 + 7                     # above any Linux pid_max: no such process
    host = writer_tag().split("@", 1)[1]
    names = [f"enc-nightly-{dead}@{host}-abc", f"enc-nightly-{os.getpid()}@{host}-abc",
             f"enc-nightly-{dead}@another-host-abc", "enc-nightly-unrelated"]
    for n in names:
        (tmp_path / n).mkdir()
        (tmp_path / n / "result.parquet").write_bytes(b"x")
    assert remove_stale_work_folders(str(tmp_path)) == [str(tmp_path / names[0])]
    assert sorted(f.name for f in tmp_path.iterdir()) == sorted(names[1:])


@pytest.mark.heavy
def test_no_file_of_another_writer_is_removed_by_a_night(tmp_path):
    """A file another writer is writing (or left) in the history stays: an append
    removes nothing (compaction's VACUUM alone does, past its retention)."""
    from enctools.data.files import writer_tag
    host = writer_tag().split("@", 1)[1]
    append_run(tmp_path, {"rig": "r", "status": "ok"})
    others = [tmp_path / f".run-x.parquet.{2**22 + 7}@{host}.abc123.tmp",
              tmp_path / "rig=r" / "part-00000-in-flight.parquet"]
    for f in others:
        f.write_bytes(b"PAR1")
    append_run(tmp_path, {"rig": "r", "status": "ok"})
    assert all(f.exists() for f in others) and read_history(tmp_path).runs == 2


def _nightly_in_process(argv: list[str], env: dict[str, str]) -> subprocess.CompletedProcess:
    """enc-nightly's main in this process (what a monkeypatch can reach)."""
    import io
    import tempfile

    from conftest import _as_a_process, _Captured, _exit_status

    from enctools.cli.nightly import main
    out, err = _Captured(), _Captured()
    with tempfile.TemporaryFile() as raw_in:
        streams = [io.TextIOWrapper(f, encoding="utf-8", write_through=True)
                   for f in (raw_in, out, err)]
        with _as_a_process(*streams, env, None):
            code = _exit_status(main, argv)
        for s in streams:
            s.detach()
    return subprocess.CompletedProcess(argv, code, out.getvalue(), err.getvalue())


@pytest.mark.parametrize("where", ["history", "html", "calibration", "both"])
def test_full_disk_is_one_line_exit_2_and_no_ok(tmp_path, enc, monkeypatch, where):
    """ENOSPC while writing the history row, the report or the calibration: one line
    naming the file, exit 2 (not 1, which is drift), no "ok" summary on stdout."""
    import errno

    import pyarrow.parquet as pq

    from enctools.data import files
    from enctools.report import historytable
    hist, cal, page = tmp_path / "hist", tmp_path / "cal.parquet", tmp_path / "n.html"
    if where not in ("calibration", "both"):
        append_run(hist, {"rig": "before", "status": "ok"})
        assert nightly(tmp_path / "h0", cal, "--init", campaign=csv_campaign(1)).returncode == 0
    real = files.write_atomic

    def full(path, data, **kw):  # the calibration: written beside, then linked into place
        if Path(path).name.startswith(f".{cal.name}."):
            path = cal
        if (where in ("history", "both") and hist in Path(path).parents) \
                or {"calibration": str(cal), "html": str(page),
                    "both": str(cal)}.get(where) == str(path):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(path, data, **kw)
    monkeypatch.setattr(files, "write_atomic", full)
    real_append = historytable.append_rows

    def full_history(history, rows, run_ids=None):
        if where in ("history", "both") and Path(history) == hist:
            raise OSError(errno.ENOSPC, "No space left on device", str(hist))
        return real_append(history, rows, run_ids)
    monkeypatch.setattr(historytable, "append_rows", full_history)
    env = {"PATH": f"{Path(enc).parent}{os.pathsep}{os.environ['PATH']}",
           "TMPDIR": str(tmp_path)}
    r = _nightly_in_process(["--rig", "r", "--history", str(hist), "--calibration", str(cal),
                             "--init", "--html", str(page), "--campaign", csv_campaign(1)], env)
    err = r.stderr.decode()
    lines = [ln for ln in err.splitlines() if "error:" in ln]
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert "No space left on device" in lines[0]
    for name in {"history": [hist], "html": [page], "calibration": [cal],
                 "both": [cal, hist]}[where]:
        assert str(name) in lines[0], lines[0]
    assert b"ok" not in r.stdout
    if where == "both":
        assert not hist.exists() or not [f for f in hist.rglob("*") if f.is_file()]
        return
    h = read_history(hist)
    assert not h.skipped and h.runs == {"history": 1, "html": 2, "calibration": 1}[where]
    assert not [f for f in tmp_path.iterdir() if f.name.startswith("enc-nightly-")]
    del pq


@pytest.mark.slow
def test_full_history_disk_is_one_line_not_ok(tmp_path, full_tmpfs):
    cal = tmp_path / "cal.parquet"
    assert nightly(tmp_path / "h0", cal, "--init", campaign=csv_campaign(1)).returncode == 0
    for hist, page in ((full_tmpfs / "h", tmp_path / "n.html"),
                       (tmp_path / "h1", full_tmpfs / "n.html")):
        r = nightly(hist, cal, "--html", str(page), campaign=csv_campaign(1))
        line = one_error_line(r, 2, "enc-nightly")
        assert "No space left on device" in line and str(page if hist.name == "h1" else hist) \
            in line, line
        assert b"ok" not in r.stdout
        assert not [f.name for f in hist.rglob(".*")]
    assert read_history(full_tmpfs / "h").runs == 0


@pytest.mark.slow
def test_a_night_does_not_import_pandas(tmp_path):
    """pyarrow asks whether every array it builds is a pandas object, importing pandas to
    answer when it is installed (the test extra installs it): a night keeps it out as enc
    does. Imported, it cost start-up, and a SIGTERM landing inside its import left a
    half-made module that the clean-up then failed on (exit 2, not 143)."""
    hist, cal = tmp_path / "hist", tmp_path / "cal.parquet"
    assert nightly(hist, cal, "--init", campaign=csv_campaign(1)).returncode == 0
    code = textwrap.dedent(f"""
        import runpy, sys
        sys.argv = ["enc-nightly", "--rig", "ciomp-23bit", "--history", {str(hist)!r},
                    "--calibration", {str(cal)!r}, "--campaign", {csv_campaign(1)!r}]
        try:
            runpy.run_module("enctools.cli.nightly", run_name="__main__")
        except SystemExit as exc:
            print("exit", exc.code, "pandas" in sys.modules)
        """)
    env = dict(os.environ, PATH=f"{ROOT / 'bin'}{os.pathsep}{os.environ['PATH']}")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                       cwd=tmp_path)
    assert r.stdout.split()[-3:] == ["exit", "0", "False"], r.stderr


# ------------------------------------------------ the campaign: in-process or a script

@pytest.mark.heavy
def test_the_default_campaign_runs_in_process_without_a_shell(tmp_path, monkeypatch):
    """The default campaign (a step run of the polygon and its points) is run through the
    library: no process is started, and the history records it as the pipeline it stands
    for."""
    import subprocess

    from enctools.cli.campaign import DEFAULT_TEXT

    def no_process(*args, **kwargs):
        raise AssertionError(f"a process was started: {args}")
    monkeypatch.setattr(subprocess, "Popen", no_process)
    hist, cal, work = tmp_path / "hist", tmp_path / "cal.parquet", tmp_path / "work"
    r = _nightly_in_process(["--rig", "ciomp-23bit", "--history", str(hist), "--calibration",
                             str(cal), "--init", "--keep", str(work)],
                            {"PATH": str(tmp_path / "nothing"), "TMPDIR": str(tmp_path)})
    assert r.returncode == 0, r.stderr.decode()
    assert ": ok: p-p" in r.stdout.decode() and cal.exists()
    (night,) = work.iterdir()                # --keep: a new subfolder a night
    assert sorted(f.name for f in night.iterdir()) == ["result.parquet"]
    h = read_history(hist)
    assert h.runs == 1 and h.column("campaign")[0] == DEFAULT_TEXT
    assert night.name == h.column("run_id")[0]
    assert 1.0 < h.column("std")[0] < 2.0   # the polygon run's Bessel s (ciomp-23bit)
    lines = read_table(str(night / "result.parquet"), "points")[0].history
    assert [line.split(": ", 1)[1] for line in lines] == [
        "enc acquire --rig ciomp-23bit --mode steps", "enc points -o result.parquet"]


@pytest.mark.heavy
def test_a_library_campaign_is_a_callable(tmp_path):
    """report.nightly takes the campaign as a callable: its failure is the night's."""
    from enctools.errors import DeviceError
    from enctools.report.nightly import Campaign, Settings, run_nightly

    def broken(rig: str, folder: Path, run_id: str) -> None:
        raise DeviceError("`axis` did not answer")

    night = run_nightly(Settings("r", str(tmp_path / "h"), str(tmp_path / "c.parquet"),
                                 Campaign(broken, "broken")),
                        words=lambda field: f"--{field}")
    assert night.code == 3
    assert night.messages == [("error", "campaign failed with exit 3: --axis did not answer")]
    h = read_history(tmp_path / "h")
    assert h.column("campaign")[0] == "broken" and h.column("exit_code")[0] == 3


def test_two_init_nights_at_once_store_one_calibration(tmp_path):
    """--init while another --init night stores its calibration first: that one is kept
    (not replaced by this night's) and this night is compared with it."""
    import shutil

    from enctools.report.nightly import Campaign, Settings, run_nightly
    cal = tmp_path / "c.parquet"
    first = tmp_path / "first.parquet"
    assert run(["enc", "points", f"{DATA}/seed001_table3.csv", "-o", str(first)]).returncode == 0

    def other_night_first(rig: str, folder: Path, run_id: str) -> None:
        assert run(["enc", "points", f"{DATA}/seed001_table1.csv", "-o",
                    str(folder / "result.parquet")]).returncode == 0
        shutil.copyfile(first, cal)            # the other night stored its own meanwhile

    night = run_nightly(Settings("r", str(tmp_path / "h"), str(cal),
                                 Campaign(other_night_first, "table 1"), tolerance=99.0,
                                 init=True))
    assert night.code == 0, night.messages
    assert cal.read_bytes() == first.read_bytes()             # kept, not replaced
    h = read_history(tmp_path / "h")
    assert h.column("drift_max")[0] > 0.1                     # table 1 against table 3
    # the narrower race: both found no calibration, the other's landed first
    from enctools.report.nightly import store_first
    mine = tmp_path / "mine.parquet"
    mine.write_bytes(b"this night's result")
    assert not store_first(str(cal), mine, "run-2")
    assert cal.read_bytes() == first.read_bytes()
    other = tmp_path / "new" / "c.parquet"
    assert store_first(str(other), first, "run-3") and other.read_bytes() == first.read_bytes()
    assert not [f.name for f in tmp_path.rglob("*.init")]


def test_the_history_records_a_rig_file_by_its_name(tmp_path):
    from enctools.report.nightly import history_rig
    rig = tmp_path / "lab" / "rig.toml"
    rig.parent.mkdir()
    text = run(["enc", "rig", "show", "ciomp-23bit"]).stdout.decode()
    rig.write_text(text.replace('name = "ciomp-23bit"', 'name = "0042"', 1))
    assert history_rig(str(rig)) == "0042" and history_rig("ciomp-23bit") == "ciomp-23bit"


def test_a_campaign_script_past_its_time_limit_is_stopped(tmp_path, enc):
    """A --campaign script runs as a process group of its own, stopped whole once past
    --campaign-timeout: exit 3, recorded."""
    import time
    hist, cal = tmp_path / "hist", tmp_path / "cal.parquet"
    mark = tmp_path / "went-on"
    start = time.monotonic()
    r = nightly(hist, cal, "--campaign-timeout", "0.5",
                campaign=f"(sleep 3; touch {mark}) | cat")
    assert time.monotonic() - start < 10
    assert one_error_line(r, 3, "enc-nightly").endswith("campaign stopped after 0.5 s "
                                                         "(its time limit)")
    time.sleep(3)
    assert not mark.exists()
    h = read_history(hist)
    assert h.runs == 1 and h.column("exit_code")[0] == 3 and h.column("status")[0] == "timeout"
    r = nightly(hist, cal, "--campaign-timeout", "1")
    assert r.returncode == 2 and "--campaign-timeout limits a --campaign script" in \
        r.stderr.decode()


def _group_gone(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return True
    return False


@pytest.mark.slow
def test_a_night_killed_before_it_tells_the_lock_its_campaign_runs_none(tmp_path):
    """kill -9 of the night after its campaign's shell started and before the group was
    written into the lock: the shell, still waiting for the night's word, ends without
    running the campaign (which nobody could have stopped). Before, a loaded machine let the
    campaign start first (stop 51's CI)."""
    import time

    lock, started = tmp_path / "lock", tmp_path / "started"
    lock.write_text("")
    code = textwrap.dedent(f"""
        import os, signal
        from enctools.cli import campaign
        def killed(lock, pid):
            os.kill(os.getpid(), signal.SIGKILL)
        campaign.record_campaign = killed
        campaign.run_script("touch {started}; sleep 30", dict(os.environ), None,
                            campaign.Path({str(lock)!r}))
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert r.returncode == -signal.SIGKILL, r.stderr.decode()
    time.sleep(1.0)
    assert not started.exists()
    assert lock.read_text() == ""


@pytest.mark.slow
@pytest.mark.parametrize("ending", ["success", "SIGTERM", "SIGHUP", "deadline"])
def test_no_process_of_the_campaign_outlives_the_night(tmp_path, enc, ending):
    """A campaign that ignores SIGTERM and leaves a process of its own running, itself
    ignoring SIGTERM and holding the campaign's stderr: whether the night succeeds, is
    signalled or reaches --campaign-timeout, it returns within the grace (5 s) and a few
    seconds, with its status, the night recorded, and no process of the group left."""
    import time
    hist, cal, tmp = tmp_path / "hist", tmp_path / "cal.parquet", tmp_path / "tmp"
    tmp.mkdir()
    assert nightly(hist, cal, "--init", campaign=csv_campaign(1)).returncode == 0
    script = (f'trap "" TERM; echo $$ > {tmp_path}/pgid; (sleep 60) & echo $! > {tmp_path}/bg; '
              + ('enc points "$DATA/seed001_table1.csv" -o "$OUT/result.parquet"'
                 if ending == "success" else "sleep 60"))
    env = dict(_nightly_env(enc, tmp), DATA=str(DATA))
    args = ["--campaign-timeout", "1"] if ending == "deadline" else []
    p = subprocess.Popen([NIGHTLY, "--rig", "ciomp-23bit", "--history", str(hist),
                          "--calibration", str(cal), *args, "--campaign", script],
                         env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while not (tmp_path / "bg").exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    time.sleep(0.3)
    start = time.monotonic()
    if ending.startswith("SIG"):
        p.send_signal(getattr(signal, ending))
    _, err = p.communicate(timeout=60)
    took = time.monotonic() - start
    pgid, bg = (int((tmp_path / n).read_text()) for n in ("pgid", "bg"))
    assert _group_gone(pgid), ending
    with pytest.raises(ProcessLookupError):
        os.kill(bg, 0)
    code, status = {"success": (0, "ok"), "SIGTERM": (143, "interrupted"),
                    "SIGHUP": (129, "interrupted"), "deadline": (3, "timeout")}[ending]
    assert p.returncode == code, err
    assert took < 10, took   # the grace of 5 s, and the night's own work
    h = read_history(hist)
    assert h.runs == 2 and (h.column("status")[-1], h.column("exit_code")[-1]) == (status, code)
    assert list(tmp.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("campaign", ["default", "script"])
def test_a_full_tmpdir_is_a_failed_night_with_its_reason(tmp_path, full_tmpfs, enc, campaign):
    """TMPDIR on a full disk: the campaign's outputs cannot be written there, and the night
    is recorded as failed with the reason, exit 2 (before: Python's tempfile took /tmp in
    its place and the night was recorded ok)."""
    import json
    hist, cal = tmp_path / "hist", tmp_path / "cal.parquet"
    rig = "ciomp-23bit"
    assert nightly(hist, cal, "--init", campaign=csv_campaign(1)).returncode == 0
    args = [] if campaign == "default" else ["--campaign", csv_campaign(1)]
    r = subprocess.run([NIGHTLY, "--rig", rig, "--history", str(hist), "--calibration",
                        str(cal), *args], env=_nightly_env(enc, full_tmpfs),
                       capture_output=True)
    line = one_error_line(r, 2, "enc-nightly")
    assert "No space left on device" in line and str(full_tmpfs) in line, line
    assert b"ok" not in r.stdout
    h = read_history(hist)
    assert h.runs == 2 and h.column("status")[-1] == "error"
    assert "No space left on device" in json.loads(h.column("summary_json")[-1])["error"]
    assert sorted(f.name for f in full_tmpfs.iterdir()) == ["fill", "h"]


def test_a_folder_is_stale_once_its_lock_is_free(tmp_path):
    """The lock decides, whatever process has the id in the folder's name: free (a reused
    id, pid 1 here) -> removed; held (a night of another pid namespace, no such id here)
    -> kept. Without a lock file, the id decides (an older version's folder)."""
    import fcntl

    from enctools.data.files import writer_tag
    from enctools.report.nightly import WORK_LOCK, remove_stale_work_folders
    host = writer_tag().split("@", 1)[1]
    dead = 2**22 + 7
    names = {"reused": f"enc-nightly-1@{host}-abc", "held": f"enc-nightly-{dead}@{host}-abc",
             "old-dead": f"enc-nightly-{dead}@{host}-def", "old-live": f"enc-nightly-1@{host}-def"}
    for key, n in names.items():
        (tmp_path / n).mkdir()
        if not key.startswith("old"):
            (tmp_path / n / WORK_LOCK).write_text("x")
    fd = os.open(tmp_path / names["held"] / WORK_LOCK, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX)
    try:
        removed = remove_stale_work_folders(str(tmp_path))
    finally:
        os.close(fd)
    assert sorted(removed) == sorted(str(tmp_path / names[k]) for k in ("reused", "old-dead"))
    assert sorted(f.name for f in tmp_path.iterdir()) == sorted([names["held"],
                                                                 names["old-live"]])


@pytest.mark.slow
def test_kill_9_of_the_night_alone_and_a_night_that_runs(tmp_path, enc):
    """kill -9 of enc-nightly alone: the next night stops the campaign it left running
    and removes its folder; a night started meanwhile in the same TMPDIR is left alone
    and ends ok."""
    import time
    hist, cal, tmp = tmp_path / "hist", tmp_path / "cal.parquet", tmp_path / "tmp"
    tmp.mkdir()
    env = _nightly_env(enc, tmp)
    assert nightly(hist, cal, "--init", campaign=csv_campaign(1)).returncode == 0

    def night(campaign: str) -> subprocess.Popen:
        return subprocess.Popen([NIGHTLY, "--rig", "r", "--history", str(hist),
                                 "--calibration", str(cal), "--campaign", campaign], env=env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    killed = night(f'echo $$ > {tmp_path}/pgid; touch "$OUT/started"; exec sleep 60')
    deadline = time.monotonic() + 60
    while not list(tmp.glob("*/started")) and time.monotonic() < deadline:
        time.sleep(0.02)
    killed.kill()
    killed.wait(timeout=30)
    left = [f.name for f in tmp.iterdir()]
    # outlasts the next night: it waits for the test's word (at most 60 s), not a guess of
    # how long the next night takes on a loaded machine
    go = tmp_path / "go"
    slow = night(f'touch "$OUT/slow"; for i in $(seq 1200); do [ -e {go} ] && break; '
                 f'sleep 0.05; done; {csv_campaign(1)}')
    while len(list(tmp.glob("*/slow"))) < 1 and time.monotonic() < deadline:
        time.sleep(0.02)
    r = subprocess.run([NIGHTLY, "--rig", "r", "--history", str(hist), "--calibration",
                        str(cal), "--campaign", csv_campaign(1)], env=env, capture_output=True)
    assert r.returncode == 0, r.stderr
    assert not set(left) & {f.name for f in tmp.iterdir()}   # the killed night's: removed
    pgid = int((tmp_path / "pgid").read_text())
    while Path(f"/proc/{pgid}").exists() and time.monotonic() < deadline:
        time.sleep(0.02)                                      # reaped by process 1
    assert _group_gone(pgid)                                  # and its campaign stopped
    assert list(tmp.glob("*/slow"))                           # the running night's: kept
    go.touch()
    assert slow.wait(timeout=60) == 0
    assert list(tmp.iterdir()) == []
