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
    subprocess.run(["umount", "-l", str(d)], check=False)  # -l: a file still open in it


@pytest.fixture
def read_only(tmp_path):
    d = tmp_path / "ro"
    if not _mount(d, "size=1m,ro"):
        pytest.skip("cannot mount a tmpfs here (needs root)")
    yield d
    subprocess.run(["umount", "-l", str(d)], check=False)  # -l: a file still open in it


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


@pytest.mark.parametrize("mask", [0o077, 0o022, 0o027])
def test_every_output_has_the_mode_the_umask_gives(tmp_path, mask):
    """Streams of each format, a CSV's sidecar, a file written whole, a group's files and
    the nightly history's: 0o666 less the umask, as ``open`` gives (before: the history's
    files were 0o644 under umask 077; each writer set a mode of its own)."""
    import os
    import stat

    from enctools.data import files, streams
    from enctools.data.csvio import sidecar_path
    from enctools.report.history import append_run

    header, table = _a_points_stream(tmp_path)
    before = os.umask(mask)
    try:
        names = [tmp_path / f"p{ext}" for ext in (".parquet", ".h5", ".arrow", ".csv")]
        for name in names:
            streams.write_table(str(name), header, table)
        names.append(Path(sidecar_path(names[-1])))
        files.write_atomic(tmp_path / "whole.txt", b"x", durable=True)
        with files.OutputGroup() as group:
            group.write(tmp_path / "a.txt", b"a")
            streams.write_table(str(tmp_path / "g.parquet"), header, table, group=group)
        names += [tmp_path / "whole.txt", tmp_path / "a.txt", tmp_path / "g.parquet"]
        assert append_run(tmp_path / "hist", {"rig": "r", "status": "ok"}) == 1
        names += [p for p in (tmp_path / "hist").rglob("*") if p.is_file()]  # data and log
    finally:
        os.umask(before)
    modes = {p.name: oct(stat.S_IMODE(p.stat().st_mode)) for p in names}
    assert modes == dict.fromkeys(modes, oct(0o666 & ~mask))
    assert not list(tmp_path.rglob(".*.tmp"))


def _a_points_stream(folder: Path):
    """A small points stream (header, table): seed 001's table 1 through enc points."""
    import pyarrow as pa

    from enctools.data import streams

    src = folder / "src.parquet"
    data = Path(__file__).parents[2] / "data" / "seed001_table1.csv"
    assert run_in_process(f"enc points {data} -o {src}").returncode == 0
    with streams.open_input(str(src)) as s:
        return s.header, pa.Table.from_batches(list(s.batches()), s.header.arrow_schema())
