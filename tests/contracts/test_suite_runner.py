"""The suite's own runner of commands (tests/conftest.py): what it leaves behind."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import ROOT, run


def _running(pid: int) -> bool:
    """Whether ``pid`` is a process that has not ended (a zombie has ended)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


def test_a_command_past_its_timeout_leaves_no_process_running(tmp_path: Path) -> None:
    """At its timeout, ``run`` ends the pipeline's commands with the shell that started
    them (its process group), not the shell alone: nothing left holding its pipes."""
    pid_file = tmp_path / "pid"
    with pytest.raises(subprocess.TimeoutExpired):
        run(f"sleep 60 & echo $! > {pid_file}; wait", timeout=1)
    pid = int(pid_file.read_text())
    try:
        deadline = time.monotonic() + 5
        while _running(pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _running(pid), "the shell's command outlived its timeout"
    finally:
        if _running(pid):
            os.kill(pid, 9)


def test_the_commands_of_the_suite_keep_their_compiled_bytecode() -> None:
    """The commands the tests start keep the bytecode they compile (in the venv's
    pycache/ when the environment says not to write it beside the sources): else each of
    them compiles again every module of enctools it imports."""
    r = run([sys.executable, "-c", "import sys; print(sys.dont_write_bytecode, "
             "sys.pycache_prefix)"])
    written, prefix = r.stdout.decode().split()
    assert written == "False", "the suite's commands compile enctools at every start"
    assert prefix == "None" or not Path(prefix).is_relative_to(ROOT / "enctools")
