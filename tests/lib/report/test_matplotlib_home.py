"""A HOME that cannot be written (read-only, not a folder, or none) prints no warning
of matplotlib's: its configuration and cache go to a private temporary folder, made
only then and removed at exit (enctools.report.plots.matplotlib_ready)."""

from __future__ import annotations

import os
import stat
import subprocess

import pytest
from conftest import enc_exe
from test_report import make_points


def _read_only_home(tmp_path) -> str:
    home = tmp_path / "home"
    home.mkdir()
    home.chmod(stat.S_IRUSR | stat.S_IXUSR)
    return str(home)


@pytest.mark.parametrize("home", ["read-only", "/proc", "/dev/null", None])
def test_no_matplotlib_warning_and_nothing_left(tmp_path, home):
    points = make_points(tmp_path / "p.parquet", 1)
    temp = tmp_path / "tmp"
    temp.mkdir()
    env = {k: v for k, v in os.environ.items()
           if k not in ("HOME", "MPLCONFIGDIR", "XDG_CONFIG_HOME", "XDG_CACHE_HOME")}
    if home is not None:   # none: the password entry's, as Python finds it
        env["HOME"] = _read_only_home(tmp_path) if home == "read-only" else home
    env["TMPDIR"] = str(temp)
    r = subprocess.run([enc_exe(), "report", str(points), "--html", str(tmp_path / "r.html"),
                        "--pdf", str(tmp_path / "r.pdf")], env=env, capture_output=True,
                       timeout=300)
    err = r.stderr.decode()
    assert r.returncode == 0, err
    assert "matplotlib" not in err.lower() and "MPLCONFIGDIR" not in err, err
    assert (tmp_path / "r.html").exists() and (tmp_path / "r.pdf").exists()
    assert not list(temp.iterdir())            # the private folder removed at exit
