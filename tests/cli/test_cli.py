"""The enc driver: help without heavy imports, usage errors as one line, exit statuses."""

from __future__ import annotations

import subprocess
import sys

import pytest
from conftest import DATA, run_in_process

HEAVY = ("numpy", "scipy", "pyarrow.parquet", "h5py", "matplotlib")


def test_help_imports_nothing_heavy():
    code = ("import sys\nfrom enctools.cli.main import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            f"print([m for m in {HEAVY!r} if m in sys.modules])")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert r.stdout.decode().strip().splitlines()[-1] == "[]"


def test_every_command_help_imports_nothing_heavy():
    """`enc CMD --help` for every registered command: click and enctools' own light modules only."""
    from enctools.cli.main import COMMANDS

    code = ("import sys\nfrom enctools.cli.main import main\nheavy = {}\n"
            "for name in sys.argv[1:]:\n"
            "    try:\n        main([name, '--help'])\n    except SystemExit:\n        pass\n"
            f"    heavy[name] = [m for m in {HEAVY!r} if m in sys.modules]\n"
            "print(heavy)")
    r = subprocess.run([sys.executable, "-c", code, *COMMANDS], capture_output=True, timeout=120)
    assert r.returncode == 0, r.stderr.decode()
    heavy = eval(r.stdout.decode().strip().splitlines()[-1])
    assert set(heavy) == set(COMMANDS)
    assert heavy == {name: [] for name in COMMANDS}, heavy


#: what no tiny run of a stream command needs: each a tenth or more of importing numpy and
#: pyarrow (numpy.ma: pa.array's masked-array test; TOML, tempfile, hashlib: rig files, file
#: outputs, certificates)
UNUSED = ("scipy", "matplotlib", "h5py", "numpy.ma", "pyarrow.compute", "tomllib", "hashlib")


@pytest.mark.slow
def test_a_run_imports_only_what_it_uses(tmp_path):
    """A tiny run imports neither what it plots nor what it does not read: no matplotlib or
    h5py, no scipy where the command needs none, and none of :data:`UNUSED`; a run that
    writes to stdout, no tempfile."""
    run_in_process(f"enc acquire --rig sjtu-dual --revolutions 0.01 -q -o {tmp_path}/t.arrows")
    t = str(tmp_path / "t.arrows")
    cases = {"info": ([t], UNUSED + ("tempfile",)),
             "points": ([f"{DATA}/seed001_table1.csv"], UNUSED + ("tempfile",)),
             "average-heads": ([t], UNUSED + ("tempfile",)),
             "interp-check": ([t, "--reference", "P1"], UNUSED + ("tempfile",)),
             "report": ([str(tmp_path / "p.arrows")], UNUSED + ("tempfile",)),
             "make-rom": ([str(tmp_path / "m.arrows"), "--bits", "10", "-o",
                           str(tmp_path / "r.bin"), "--allow-no-gain", "--allow-coarse"],
                          UNUSED)}
    r = run_in_process(f"enc fit-rbf {DATA}/seed001_table1.csv -q -o {tmp_path}/m.arrows")
    assert r.returncode == 0, r.stderr.decode()
    run_in_process(f"enc points {DATA}/seed001_table1.csv -q -o {tmp_path}/p.arrows")
    code = ("import sys\nfrom enctools.cli.main import main\n"
            "try:\n    main(sys.argv[1:])\nexcept SystemExit as e:\n    assert not e.code, e.code\n"
            f"print(sorted(m for m in {UNUSED + ('tempfile',)!r} if m in sys.modules), "
            "file=sys.stderr)")
    # what numpy and pyarrow import themselves (numpy < 2 imports numpy.ma) is no command's
    base = subprocess.run([sys.executable, "-c", "import sys, numpy, pyarrow; print(sorted("
                           f"m for m in {UNUSED + ('tempfile',)!r} if m in sys.modules))"],
                          capture_output=True, timeout=120)
    already = set(eval(base.stdout.decode().strip().splitlines()[-1]))
    for name, (args, banned) in cases.items():
        r = subprocess.run([sys.executable, "-c", code, name, "-q", *args], capture_output=True,
                           timeout=120)
        assert r.returncode == 0, (name, r.stderr.decode())
        loaded = eval(r.stderr.decode().strip().splitlines()[-1])
        assert not set(loaded) & (set(banned) - already), (name, loaded)


def test_unknown_command_is_one_line():
    r = run_in_process("enc frobnicate")
    err = r.stderr.decode()
    assert r.returncode == 2
    assert err.count("\n") == 1 and "No such command 'frobnicate'" in err


def test_no_command_prints_help_and_exits_2():
    r = run_in_process("enc")
    assert r.returncode == 2
    assert b"Commands:" in r.stderr and r.stdout == b""


def test_version():
    r = run_in_process("enc --version")
    assert r.returncode == 0 and r.stdout.startswith(b"enctools, version")


def test_debug_shows_a_traceback_only_when_asked(tmp_path):
    r = run_in_process(f"enc info {tmp_path}/missing.parquet")
    assert r.returncode == 2 and b"Traceback" not in r.stderr
    assert r.stderr.decode() == f"enc info: error: {tmp_path}/missing.parquet: no such file\n"
    r = run_in_process(f"enc info --debug {tmp_path}/missing.parquet")
    assert r.returncode == 2 and b"Traceback" in r.stderr


@pytest.mark.slow
def test_sigterm_mid_run_keeps_a_valid_stream(tmp_path):
    """SIGTERM while writing: exit 143, the file holds every batch written before it."""
    import signal
    import time

    from conftest import enc_exe

    from enctools.data import streams

    out = tmp_path / "x.arrows"
    p = subprocess.Popen([enc_exe(), "acquire", "--rig", "sjtu-dual", "--revolutions", "2000",
                          "-o", str(out)], stderr=subprocess.PIPE)
    # signalled once a batch has reached the temporary (a batch of 65536 rows is over
    # 1 MB), not after a fixed wait: on a loaded machine a second may not see one written
    deadline = time.monotonic() + 120

    def written() -> int:
        return sum(f.stat().st_size for f in tmp_path.glob(".x.arrows.*"))

    while time.monotonic() < deadline and written() < 1 << 20:
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143, err
    assert err.decode().strip() == "enc acquire: error: terminated"
    _, table = streams.read_table(str(out), "readings")
    assert table.num_rows > 0 and table.num_rows % 65536 == 0
    assert not list(tmp_path.glob(".x.arrows.*"))


def test_shell_completion_script():
    r = run_in_process("enc", env={"_ENC_COMPLETE": "bash_source"})
    assert r.returncode == 0
    assert b"complete" in r.stdout and b"_ENC_COMPLETE" in r.stdout
    r = run_in_process("enc", env={"COMP_WORDS": "enc acq", "COMP_CWORD": "1",
                                   "_ENC_COMPLETE": "bash_complete"})
    assert b"acquire" in r.stdout


@pytest.mark.parametrize("stop, code, line", [
    ("Interrupted('terminated', exit_code=143)", 143, "terminated"),
    ("KeyboardInterrupt()", 130, "interrupted"),
])
def test_a_signal_wrapped_by_the_code_it_landed_in_is_still_the_signal(stop, code, line):
    """SIGTERM during an import (matplotlib's class bodies) reaches the runner as
    RuntimeError('Error calling __set_name__') caused by the interruption: it ends as the
    signal does (143 / 130), not as an internal error."""
    body = ("import sys; from enctools.cli import runner; from enctools.errors import Interrupted\n"
            "def invoke():\n"
            "    try:\n"
            f"        raise {stop}\n"
            "    except BaseException as exc:\n"
            "        raise RuntimeError('Error calling __set_name__') from exc\n"
            "runner.set_command('report'); sys.exit(runner.run(invoke, debug=False))\n")
    r = subprocess.run([sys.executable, "-c", body], capture_output=True, timeout=60)
    assert r.returncode == code
    assert r.stderr.decode() == f"enc report: error: {line}\n"
