"""Shared fixtures: the enc executable, a runner for real subprocess pipelines, and
session-scoped simulator runs so each is made once per test session."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DATA = Path(__file__).resolve().parent / "data"


def enc_exe() -> str:
    """The enc executable of this environment (the venv's console script)."""
    exe = Path(sys.executable).parent / "enc"
    if not exe.exists():
        pytest.fail(f"enc is not installed beside {sys.executable}; run make test")
    return str(exe)


@pytest.fixture(scope="session")
def enc() -> str:
    return enc_exe()


def run(cmd: str | list[str], cwd: Path | None = None, input: bytes | None = None,
        env: dict[str, str] | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run a command (a shell pipeline when given a string) with enc on PATH."""
    e = dict(os.environ)
    e["PATH"] = f"{Path(enc_exe()).parent}{os.pathsep}{e.get('PATH', '')}"
    e.pop("ENC_DEBUG", None)
    if env:
        e.update(env)
    shell = isinstance(cmd, str)
    return subprocess.run(cmd, shell=shell, cwd=cwd, input=input, env=e, capture_output=True,
                          timeout=timeout, executable="/bin/bash" if shell else None)


def one_error_line(r: subprocess.CompletedProcess, code: int, cmd: str = "enc acquire") -> str:
    """The one error line of a failed command (warnings, e.g. logged retries, may precede it)."""
    err = r.stderr.decode()
    assert r.returncode == code, err
    lines = [ln for ln in err.splitlines() if "error:" in ln]
    assert len(lines) == 1 and lines[0].startswith(f"{cmd}: error: "), err
    assert "Traceback" not in err
    return lines[0]


@pytest.fixture(scope="session")
def sjtu_raw(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The default sjtu-dual run (20 revolutions, 9 heads) as Parquet."""
    d = tmp_path_factory.mktemp("sjtu")
    out = d / "raw.parquet"
    r = run(["enc", "acquire", "--rig", "sjtu-dual", "-o", str(out)])
    assert r.returncode == 0, r.stderr.decode()
    return out


@pytest.fixture(scope="session")
def ciomp_steps(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The default ciomp-23bit polygon run (24 positions) as Parquet."""
    d = tmp_path_factory.mktemp("ciomp")
    out = d / "steps.parquet"
    r = run(["enc", "acquire", "--rig", "ciomp-23bit", "--mode", "steps", "-o", str(out)])
    assert r.returncode == 0, r.stderr.decode()
    return out
