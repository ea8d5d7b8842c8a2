"""Outputs that cannot be written: full disk, read-only folder, a directory, a missing
folder. Each is one line on stderr, exit 2, and no file (not even a temporary one).
The commands run in-process (the message and the status are the point here)."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from conftest import run_in_process


def _mount(path: Path, options: str) -> bool:
    path.mkdir(parents=True, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                       capture_output=True)
    return r.returncode == 0


@pytest.fixture
def small_disk(tmp_path):
    d = tmp_path / "small"
    if not _mount(d, "size=8m"):
        pytest.skip("cannot mount a tmpfs here (needs root)")
    yield d
    subprocess.run(["umount", str(d)])


@pytest.fixture
def read_only(tmp_path):
    d = tmp_path / "ro"
    if not _mount(d, "size=1m,ro"):
        pytest.skip("cannot mount a tmpfs here (needs root)")
    yield d
    subprocess.run(["umount", str(d)])


def acquire(revolutions: float, out: Path | str):
    """``enc acquire --rig sjtu-dual --revolutions R -o OUT``, in-process."""
    return run_in_process(f"enc acquire --rig sjtu-dual --revolutions {revolutions} -o {out}")


def _fails_cleanly(r, words):
    err = r.stderr.decode()
    assert r.returncode == 2, err
    assert err.startswith("enc acquire: error: ") and err.count("\n") == 1, err
    assert words in err, err


@pytest.mark.parametrize("ext", [".parquet", ".h5", ".arrow", ".arrows"])
def test_full_disk(small_disk, ext):
    out = small_disk / f"x{ext}"
    r = acquire(40, out)
    _fails_cleanly(r, f"output {out}: No space left on device")
    assert list(small_disk.iterdir()) == []
    small = small_disk / f"small{ext}"  # the same disk still takes what fits
    assert acquire(0.05, small).returncode == 0


def test_read_only_folder(read_only):
    out = read_only / "x.parquet"
    _fails_cleanly(acquire(0.01, out), "is not writable")
    assert list(read_only.iterdir()) == []


def test_output_is_a_directory(tmp_path):
    _fails_cleanly(acquire(0.01, tmp_path), "is a directory")


def test_output_folder_missing(tmp_path):
    _fails_cleanly(acquire(0.01, f"{tmp_path}/a/b.h5"), "does not exist")


def test_cannot_create_in_folder():
    _fails_cleanly(acquire(0.01, "/proc/x.parquet"), "cannot create a file in /proc")
