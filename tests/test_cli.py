"""The enc driver: help without heavy imports, usage errors as one line, exit statuses."""

from __future__ import annotations

import subprocess
import sys

from conftest import run

HEAVY = ("numpy", "scipy", "pyarrow.parquet", "h5py", "matplotlib")


def test_help_imports_nothing_heavy():
    code = ("import sys\nfrom enctools.cli.main import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            f"print([m for m in {HEAVY!r} if m in sys.modules])")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert r.stdout.decode().strip().splitlines()[-1] == "[]"


def test_subcommand_help_imports_nothing_heavy():
    code = ("import sys\nfrom enctools.cli.main import main\n"
            "try:\n    main(['acquire', '--help'])\nexcept SystemExit:\n    pass\n"
            f"print([m for m in {HEAVY!r} if m in sys.modules])")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert r.stdout.decode().strip().splitlines()[-1] == "[]"


def test_unknown_command_is_one_line():
    r = run("enc frobnicate")
    err = r.stderr.decode()
    assert r.returncode == 2
    assert err.count("\n") == 1 and "No such command 'frobnicate'" in err


def test_no_command_prints_help_and_exits_2():
    r = run("enc")
    assert r.returncode == 2
    assert b"Commands:" in r.stderr and r.stdout == b""


def test_version():
    r = run("enc --version")
    assert r.returncode == 0 and r.stdout.startswith(b"enctools, version")


def test_debug_shows_a_traceback_only_when_asked(tmp_path):
    r = run(f"enc info {tmp_path}/missing.parquet")
    assert r.returncode == 2 and b"Traceback" not in r.stderr
    assert r.stderr.decode() == f"enc info: error: {tmp_path}/missing.parquet: no such file\n"
    r = run(f"enc info --debug {tmp_path}/missing.parquet")
    assert r.returncode == 2 and b"Traceback" in r.stderr


def test_sigterm_mid_run_keeps_a_valid_stream(tmp_path):
    """SIGTERM while writing: exit 143, the file holds every batch written before it."""
    import signal
    import time

    from conftest import enc_exe
    from enctools import streams

    out = tmp_path / "x.arrows"
    p = subprocess.Popen([enc_exe(), "acquire", "--rig", "sjtu-dual", "--revolutions", "2000",
                          "-o", str(out)], stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list(tmp_path.glob(".x.arrows.*")):
        time.sleep(0.05)
    time.sleep(1.0)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143, err
    assert err.decode().strip() == "enc acquire: error: terminated"
    _, table = streams.read_table(str(out), "readings")
    assert table.num_rows > 0 and table.num_rows % 65536 == 0
    assert not list(tmp_path.glob(".x.arrows.*"))


def test_shell_completion_script():
    r = run("_ENC_COMPLETE=bash_source enc")
    assert r.returncode == 0
    assert b"complete" in r.stdout and b"_ENC_COMPLETE" in r.stdout
    r = run("COMP_WORDS='enc acq' COMP_CWORD=1 _ENC_COMPLETE=bash_complete enc")
    assert b"acquire" in r.stdout
