"""Summaries: every command's --json parsed, its keys those of enc-streams(5) SUMMARIES,
a figure checked against an independent computation; the text on stderr in --unit;
-q silent; --json refused where the stream takes stdout; progress on a terminal;
library warnings as one line."""

from __future__ import annotations

import json
import os
import pty
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from conftest import DATA, ROOT, enc_exe, run, run_in_process

MAN = ROOT / "man"
#: containers whose keys are free (metadata, settings, what a kind tells, ISO figures)
FREE = {"info", "settings", "metadata", "axis", "positions", "thresholds_settings"}


def documented_keys() -> set[str]:
    text = (MAN / "enc-streams.5").read_text()
    section = text.split(".SH SUMMARIES", 1)[1].split("\n.SH ", 1)[0]
    return set(re.findall(r"[A-Za-z][a-z0-9]*(?:_[a-z0-9]+)*", section))  # U_arcsec too


def keys_of(x: object) -> set[str]:
    """Every key of a JSON document, but those inside free-form containers."""
    out: set[str] = set()
    if isinstance(x, dict):
        for k, v in x.items():
            out.add(k)
            if k not in FREE:
                out |= keys_of(v)
    elif isinstance(x, list):
        for v in x:
            out |= keys_of(v)
    return out


def check_keys(doc: dict) -> None:
    known = documented_keys()
    missing = sorted(k for k in keys_of(doc)
                     if k not in known and re.sub(r"_(nm|count)$", "_arcsec", k) not in known)
    assert not missing, f"keys not in enc-streams(5) SUMMARIES: {missing}"


def json_of(cmd: str, cwd: Path | None = None) -> dict:
    r = run(cmd, cwd=cwd)
    assert r.returncode == 0, r.stderr.decode()
    # warnings said on purpose: an unsynchronised run, a model without gain (seed 001
    # table 1, enc-fit-rbf(1), GAIN)
    assert (b"WARNING" not in r.stderr or b"synchronous" in r.stderr
            or b"WARNING: no gain" in r.stderr
            or b"WARNING: the model does not beat" in r.stderr), r.stderr.decode()
    doc = json.loads(r.stdout)  # one document, nothing else on stdout
    assert "NaN" not in r.stdout.decode() and "Infinity" not in r.stdout.decode()
    check_keys(doc)
    return doc


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("summaries")
    for args, name in (("--rig sjtu-dual --revolutions 3", "run"),
                       ("--rig ciomp-23bit --mode steps", "steps")):
        r = run(f"enc acquire {args} -q -o {d}/{name}.parquet")
        assert r.returncode == 0, r.stderr.decode()
    return d


def column(path: Path, name: str) -> np.ndarray:
    return pq.read_table(path).column(name).to_numpy()


def test_acquire_json(runs, tmp_path):
    out = tmp_path / "a.parquet"
    doc = json_of(f"enc acquire --rig ciomp-23bit --mode steps --json -o {out}")
    assert doc["mode"] == "steps" and doc["output"] == str(out)
    assert doc["n_rows"] == pq.read_metadata(out).num_rows > 0


def test_average_heads_json(runs, tmp_path):
    out = tmp_path / "avg.parquet"
    doc = json_of(f"enc average-heads {runs}/run.parquet --json -o {out}")
    assert doc["n_rows"] == pq.read_metadata(out).num_rows
    h = next(a for a in doc["averages"] if a["name"] == "H")
    assert h["heads"] == ["H1", "H2", "H3", "H4"] and h["alphas_deg"] == [0, 90, 180, 270]
    # four equally spaced heads keep the multiples of 4 only (seed 000 eq. 5)
    assert h["passed"] == list(range(4, 101, 4)) and h["radial_gain"] == 0


def test_selfcal_json(runs, tmp_path):
    out = tmp_path / "sc.parquet"
    doc = json_of(f"enc selfcal {runs}/run.parquet --json -o {out}")
    assert doc["method"] == "esa" and doc["n_revolutions"] == 3
    grad, x, _ = doc["curves"]
    g = column(out, "graduation")
    assert grad["pp_arcsec"] == pytest.approx(np.ptp(g), rel=1e-12)
    assert grad["s_bessel_arcsec"] == pytest.approx(np.std(g, ddof=1), rel=1e-12)
    assert grad["u_max_arcsec"] == pytest.approx(column(out, "u_graduation").max())
    assert x["role"] == "radial" and x["pp_nm"] == pytest.approx(np.ptp(column(out, "x")))


def test_compare_json(runs, tmp_path):
    out = tmp_path / "c.parquet"
    doc = json_of(f"enc compare {runs}/run.parquet --device H1,H2,H3,H4 --reference P1,P2 "
                  f"--name HP --json -o {out}")
    c = doc["curves"][0]
    assert c["name"] == "HP" and doc["n_revolutions"] == 3
    assert c["pm_arcsec"] == pytest.approx(np.ptp(column(out, "HP")) / 2, rel=1e-12)


@pytest.mark.slow
def test_interp_check_json(tmp_path):
    sweep, out = tmp_path / "sw.parquet", tmp_path / "ic.parquet"
    r = run(f"enc acquire --rig sjtu-dual --mode sweep --readings 4 -q -o {sweep}")
    assert r.returncode == 0, r.stderr.decode()
    doc = json_of(f"enc interp-check {sweep} --heads P1,H1 --json -o {out}")
    assert [c["name"] for c in doc["curves"]] == ["P1", "H1"]
    for c in doc["curves"]:
        assert c["pp_arcsec"] == pytest.approx(np.ptp(column(out, c["name"])), rel=1e-12)
        assert [h["n"] for h in c["harmonics"]] == [1, 2, 3, 4]


def test_points_json(runs, tmp_path):
    out = tmp_path / "p.parquet"
    doc = json_of(f"enc points {runs}/steps.parquet --json -o {out}")
    dev = column(out, "deviation")
    assert doc["n_rows"] == dev.size == 24
    assert doc["distinct_positions"]["s_bessel_arcsec"] == pytest.approx(np.std(dev, ddof=1))


def test_fit_rbf_json_and_null(tmp_path):
    doc = json_of(f"enc fit-rbf {DATA}/seed001_table1.csv --json -o {tmp_path}/m.parquet")
    # seed 001 table 1: 24 positions, p-p 5.46", Bessel s 1.2674" (eq. 8)
    assert doc["points"]["n_points"] == 24
    assert doc["points"]["pp_arcsec"] == pytest.approx(5.46, abs=1e-9)
    assert doc["points"]["s_bessel_arcsec"] == pytest.approx(1.2674, abs=1e-4)
    assert doc["model"]["kernel"] == "rbf" and doc["model"]["n_units"] == 24
    two = tmp_path / "two.csv"
    two.write_text("position_deg,deviation_arcsec\n0,1\n180,2\n")
    doc = json_of(f"enc fit-rbf {two} --json -o {tmp_path}/m2.parquet")
    assert doc["leave_one_out"]["rms_arcsec"] is None  # undetermined: null, never NaN


def test_make_rom_json(tmp_path):
    model, table = tmp_path / "m.parquet", tmp_path / "t.bin"
    assert run(f"enc fit-rbf {DATA}/seed001_table1.csv -q -o {model}").returncode == 0
    doc = json_of(f"enc make-rom {model} --bits 23 --address-bits 10 --verify --json "
                  f"--allow-no-gain -o {table}")
    assert doc["table"]["entries"] == 1024 and doc["file_bytes"] == table.stat().st_size
    assert doc["verified"] is True and doc["output"] == str(table)
    assert doc["table"]["lsb_arcsec"] == pytest.approx(1_296_000 / 2 ** 23)


def test_design_json():
    doc = json_of("enc design --angles 0,60,135,228 --json")
    # seed 000: min |W(n)| for 2 <= n <= 100 is about 1.18 at n = 42
    assert doc["min_transfer_n"] == 42 and doc["min_transfer"] == pytest.approx(1.18, abs=0.01)
    assert doc["blind"] == [] and doc["method"] == "esa"


def test_latency_json():
    doc = json_of("enc latency --bits 23 --delay 10e-6 --speeds 1 --json")
    assert doc["code_skip_speed_deg_s"] == pytest.approx(360 / (2 ** 23 * 10e-6))
    assert doc["resolution_arcsec"] == pytest.approx(1_296_000 / 2 ** 23)


def test_info_json(runs):
    doc = json_of(f"enc info --json {runs}/steps.parquet")
    schema = pq.read_schema(runs / "steps.parquet")
    assert doc["kind"] == "readings" and doc["mode"] == "steps" and doc["rig"] == "ciomp-23bit"
    assert doc["n_rows"] == pq.read_metadata(runs / "steps.parquet").num_rows
    assert [c["name"] for c in doc["columns"]] == schema.names
    assert doc["columns"][0]["unit"] == "s" and len(doc["history"]) == 1


def test_rig_check_json():
    doc = json_of("enc rig check --json sjtu-dual")
    enc_ii = next(e for e in doc["encoders"] if e["name"] == "II")
    assert enc_ii["counts_per_rev"] == 52000 * 4096
    assert enc_ii["lsb_arcsec"] == pytest.approx(1_296_000 / (52000 * 4096))
    assert [h["alpha_deg"] for h in enc_ii["heads"]] == pytest.approx(
        [0, 90, 180, 270, 60, 135, 228])


def test_report_json_keys_as_the_commands(runs, tmp_path):
    out = tmp_path / "sc.parquet"
    sc = json_of(f"enc selfcal {runs}/run.parquet --json -o {out}")
    rep = json_of(f"enc report --json {out}")
    curves = {c["name"]: c for c in rep["sections"][0]["curves"]}
    for c in sc["curves"]:  # the same figure under the same key
        for key in ("n_points", "pp_arcsec", "pm_arcsec", "s_bessel_arcsec", "rms_arcsec",
                    "pp_nm", "s_bessel_nm"):
            if key in c:
                assert curves[c["name"]][key] == pytest.approx(c[key], rel=1e-12), key


@pytest.mark.parametrize("cmd", [
    "acquire --rig ciomp-23bit --mode steps", "average-heads {run}", "selfcal {run}",
    "compare {run} --device H1 --reference P1", "interp-check {run} --reference P1",
    "points {steps}",
    f"fit-rbf {DATA}/seed001_table1.csv", "make-rom {steps}"])
def test_json_needs_o_file_when_the_stream_takes_stdout(cmd, runs):
    r = run("enc " + cmd.format(run=runs / "run.parquet", steps=runs / "steps.parquet")
            + " --json")
    err = r.stderr.decode()
    assert r.returncode == 2 and r.stdout == b"", err
    assert err.count("\n") == 1 and "--json prints the summary on stdout" in err, err


def test_quiet_is_silent_and_unit_converts(runs, tmp_path):
    """Each command speaks on stderr, one "enc ..." line at a time, and -q silences it
    (in this process: the summary's words, not the interpreter, are what is checked)."""
    for cmd in (f"enc average-heads {runs}/run.parquet -o {tmp_path}/a.parquet",
                f"enc selfcal {runs}/run.parquet -o {tmp_path}/s.parquet",
                f"enc compare {runs}/run.parquet --device H1,H2,H3,H4 --reference P1,P2 "
                f"-o {tmp_path}/c.parquet",
                f"enc points {runs}/steps.parquet -o {tmp_path}/p.parquet",
                f"enc fit-rbf {DATA}/seed001_table1.csv -o {tmp_path}/m.parquet",
                f"enc make-rom {tmp_path}/m.parquet --bits 23 --address-bits 16 "
                f"--allow-no-gain -o {tmp_path}/t.mif",
                f"enc acquire --rig ciomp-23bit --mode steps -o {tmp_path}/r.parquet"):
        loud = run_in_process(cmd)
        assert loud.returncode == 0 and loud.stderr.count(b"\n") >= 1, loud.stderr.decode()
        assert all(ln.startswith(b"enc ") for ln in loud.stderr.splitlines())
        quiet = run_in_process(cmd + " --force -q")
        assert quiet.returncode == 0 and quiet.stderr == b"", quiet.stderr.decode()
    points = f"enc points {runs}/steps.parquet -o {tmp_path}/p.parquet --force"
    text = run_in_process(f"{points} --unit urad -q -v").stderr.decode()
    arcsec = run_in_process(points).stderr
    pp = float(re.search(r'p-p ([0-9.]+)"', arcsec.decode()).group(1))
    urad = run_in_process(f"{points} --unit urad")
    got = float(re.search(r"p-p ([0-9.]+) µrad", urad.stderr.decode()).group(1))
    assert got == pytest.approx(pp * np.pi / 648000 * 1e6, rel=1e-4)
    assert "p-p" not in text  # -q wins over -v for the summary


def test_average_heads_speaks_by_default(runs, tmp_path):
    r = run(f"enc average-heads {runs}/run.parquet -o {tmp_path}/a.parquet")
    assert r.returncode == 0
    lines = r.stderr.decode().splitlines()
    assert lines[0].startswith("enc average-heads: rows ") and "H: heads H1,H2,H3,H4" in lines[2]


def _on_a_terminal(argv: list[str]) -> tuple[int, str]:
    """Run argv with its stderr on a pseudo-terminal: exit status and what it showed."""
    master, slave = pty.openpty()
    env = dict(os.environ, PATH=f"{Path(enc_exe()).parent}{os.pathsep}{os.environ['PATH']}")
    p = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=slave, env=env)
    os.close(slave)
    shown = b""
    while True:
        try:
            chunk = os.read(master, 4096)
        except OSError:  # the child closed the terminal
            break
        if not chunk:
            break
        shown += chunk
    os.close(master)
    return p.wait(timeout=120), shown.decode("utf-8", "replace")


@pytest.mark.skipif(sys.platform != "linux", reason="pseudo-terminals as on Linux")
def test_progress_on_a_terminal_and_not_with_q(runs, tmp_path):
    for cmd, what in ((["average-heads", str(runs / "run.parquet")], "rows"),
                      (["selfcal", str(runs / "run.parquet")], "revolutions"),
                      (["compare", str(runs / "run.parquet"), "--device", "H1",
                        "--reference", "P1"], "revolutions"),
                      (["interp-check", str(runs / "run.parquet"), "--reference", "P1",
                        "--heads", "H1"], "rows read"),
                      (["fit-rbf", f"{DATA}/seed001_table1.csv"], "spread search"),
                      (["make-rom", str(tmp_path / "fit-rbf.parquet"), "--bits", "23",
                        "--address-bits", "16", "--allow-no-gain"],
                       "evaluating"),
                      (["acquire", "--rig", "ciomp-23bit", "--mode", "steps"], "steps")):
        out = str(tmp_path / f"{cmd[0]}.parquet")
        code, shown = _on_a_terminal([enc_exe(), *cmd, "-o", out])
        assert code == 0, shown
        assert f"\renc {cmd[0]}: {what} " in shown, shown
        # the summary starts a line of its own after the progress line
        assert re.search(rf"\n\s*enc {cmd[0]}: [^\r]*\n", shown.replace("\r\n", "\n")), shown
        code, shown = _on_a_terminal([enc_exe(), *cmd, "-o", out, "--force", "-q"])
        assert code == 0 and shown == "", shown
    # enc report: the inputs read and the HTML rendered
    code, shown = _on_a_terminal([enc_exe(), "report", str(tmp_path / "selfcal.parquet"),
                                  "--html", str(tmp_path / "r.html")])
    assert code == 0 and "\renc report: inputs and renderings " in shown, shown
    assert "100.0% (2/2" in shown, shown


def test_library_warnings_are_one_line():
    code = ("from enctools.cli import runner; runner.set_command('selfcal');"
            "runner.setup_logging(); import warnings, numpy as np;"
            "np.float64(1) / np.float64(0); warnings.warn('two\\nlines', UserWarning)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    lines = r.stderr.decode().splitlines()
    assert lines == ["enc selfcal: WARNING: divide by zero encountered in scalar divide",
                     "enc selfcal: WARNING: two lines"], lines
    quiet = code.replace("setup_logging()", "setup_logging(quiet=1)")
    r = subprocess.run([sys.executable, "-c", quiet], capture_output=True, timeout=60)
    assert r.stderr == b""


@pytest.mark.slow
def test_extreme_signals_give_one_line_not_a_warning(tmp_path):
    """Raw signals of 1e300 V, 1e-300 V or all equal: one line, never numpy's warnings."""
    import pyarrow as pa

    sweep = tmp_path / "sw.parquet"
    r = run(f"enc acquire --rig sjtu-dual --mode sweep --readings 1 --runs 1 --signals "
            f"--heads P1,P2 -q -o {sweep}")
    assert r.returncode == 0, r.stderr.decode()
    t = pq.read_table(sweep)
    for name, scale in (("huge", 1e300), ("tiny", 1e-300), ("flat", 0.0)):
        cols = [pa.array(c.to_numpy() * scale) if f.name.endswith((".cos", ".sin")) else c
                for f, c in zip(t.schema, t.columns, strict=True)]
        bad = tmp_path / f"{name}.parquet"
        pq.write_table(pa.Table.from_arrays(cols, schema=t.schema), bad)
        r = run(f"enc interp-check {bad} --signals -o {tmp_path}/{name}-ic.parquet")
        err = r.stderr.decode()
        assert "Warning" not in err and ".py:" not in err, err
        assert r.returncode in (0, 2) and all(ln.startswith("enc interp-check: ")
                                              for ln in err.splitlines()), err
        if name == "tiny":  # the fit does not depend on the scale of the signals
            assert r.returncode == 0, err


def test_enc_nightly_names_itself():
    for argv in ([str(ROOT / "bin" / "enc-nightly"), "--help"],
                 [sys.executable, "-m", "enctools.cli.nightly", "--help"]):
        r = subprocess.run(argv, capture_output=True, timeout=60)
        out = r.stdout.decode()
        assert r.returncode == 0 and out.startswith("Usage: enc-nightly [OPTIONS]"), out
        assert "python" not in out and "enctools." not in out
    r = subprocess.run([str(ROOT / "bin" / "enc-nightly"), "--bogus"], capture_output=True,
                       timeout=60)
    assert r.returncode == 2 and r.stderr.decode().startswith("enc-nightly: error:")


def test_history_lines_name_the_library_versions(runs):
    import numpy
    import pyarrow
    import scipy

    from enctools import __version__

    line = json.loads(run(f"enc info --json {runs}/run.parquet").stdout)["history"][0]
    for name, version in (("enctools", __version__), ("numpy", numpy.__version__),
                          ("scipy", scipy.__version__), ("pyarrow", pyarrow.__version__)):
        assert f"{name} {version}" in line, line
