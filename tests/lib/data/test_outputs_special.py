"""Only regular files are ever replaced: an output that is a FIFO or a device is refused,
``--force`` or not, with one line and exit 2, and is still what it was afterwards. A
temporary left by a killed run is removed by the next run writing the same file; a
fresh one, or one whose writer still runs, is kept. In-process, small inputs."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import DATA, one_error_line, run_in_process

from enctools.data import files

FIFO_LINE = ("is a FIFO (named pipe), not a regular file; only regular files are replaced "
             "(write to stdout and redirect instead)")
DEVICE_LINE = ("is a character device, not a regular file; only regular files are replaced "
               "(write to stdout and redirect instead)")


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """A short sjtu-dual run and an RBF model."""
    d = tmp_path_factory.mktemp("inputs")
    r = run_in_process(f"enc acquire --rig sjtu-dual --revolutions 0.01 -o {d}/raw.parquet")
    assert r.returncode == 0, r.stderr.decode()
    r = run_in_process(f"enc fit-rbf {DATA}/seed001_table1.csv -q -o {d}/m.parquet")
    assert r.returncode == 0, r.stderr.decode()
    return d


# (command, its arguments with {out} the output under test, the extension {out} needs)
WRITERS = [
    ("acquire", "--rig sjtu-dual --revolutions 0.01 -o {out}", ".parquet"),
    ("acquire", "--rig sjtu-dual --revolutions 0.01 --tee {out} -o {tmp}/a.parquet",
     ".parquet"),
    ("selfcal", "{raw} -o {out}", ".parquet"),
    ("selfcal", "{raw} -o {tmp}/d.parquet --spectrum {out}", ".parquet"),
    ("report", "{raw} --html {out}", ".html"),
    ("make-rom", "{model} --bits 16 --allow-no-gain --allow-coarse -o {out}", ".parquet"),
    ("make-rom", "{model} --bits 16 --allow-no-gain --allow-coarse --target mif -o {out}",
     ".mif"),
    ("average-heads", "{raw} -o {out}", ".parquet"),
    ("compare", "{raw} --device H1 --reference H2 -o {tmp}/c.parquet --spectrum {out}", ".parquet"),
    ("fit-rbf", "{csv} -o {out}", ".parquet"),
    ("points", "{csv} -o {out}", ".h5"),
    ("interp-check", "{raw} --signals -o {tmp}/i.parquet --corrected {out}", ".arrows"),
]


def _command(inputs: Path, tmp: Path, cmd: str, args: str, out: str) -> str:
    filled = args.format(out=out, tmp=tmp, raw=inputs / "raw.parquet",
                         model=inputs / "m.parquet", csv=DATA / "seed001_table1.csv")
    return f"enc {cmd} {filled} --force"


@pytest.mark.parametrize(("cmd", "args", "ext"), WRITERS)
def test_a_fifo_is_refused_and_kept(inputs, tmp_path, cmd, args, ext):
    fifo = tmp_path / f"pipe{ext}"
    os.mkfifo(fifo)
    r = run_in_process(_command(inputs, tmp_path, cmd, args, str(fifo)))
    line = one_error_line(r, 2, f"enc {cmd}")
    assert line == f"enc {cmd}: error: output {fifo}: {FIFO_LINE}"
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert sorted(p.name for p in tmp_path.iterdir()) == [fifo.name]  # nothing else written


@pytest.mark.parametrize(("cmd", "args", "ext"), WRITERS)
def test_a_link_to_dev_null_is_refused(inputs, tmp_path, cmd, args, ext):
    link = tmp_path / f"null{ext}"  # the extension tells the format; the target is /dev/null
    link.symlink_to("/dev/null")
    r = run_in_process(_command(inputs, tmp_path, cmd, args, str(link)))
    line = one_error_line(r, 2, f"enc {cmd}")
    assert line == (f"enc {cmd}: error: output {link}: is a symbolic link to "
                    f"{DEVICE_LINE.removeprefix('is ')}")
    assert link.is_symlink() and stat.S_ISCHR(os.stat(link).st_mode)
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)


def test_dev_null_itself_is_refused():
    before = os.stat("/dev/null")
    r = run_in_process("enc acquire --rig sjtu-dual --revolutions 0.01 --format parquet "
                       "-o /dev/null --force")
    line = one_error_line(r, 2)
    assert line == f"enc acquire: error: output /dev/null: {DEVICE_LINE}"
    after = os.stat("/dev/null")
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev
    assert after.st_ino == before.st_ino


def test_without_force_the_same_refusal(tmp_path):
    fifo = tmp_path / "p.parquet"
    os.mkfifo(fifo)
    r = run_in_process(f"enc acquire --rig sjtu-dual --revolutions 0.01 -o {fifo}")
    assert one_error_line(r, 2).endswith(FIFO_LINE)


def test_a_link_to_a_regular_file_is_replaced_as_a_link(tmp_path):
    """Kept as before: the rename replaces the link; the file it pointed to is untouched."""
    target = tmp_path / "target.parquet"
    target.write_bytes(b"old")
    link = tmp_path / "link.parquet"
    link.symlink_to(target)
    r = run_in_process(f"enc acquire --rig sjtu-dual --revolutions 0.01 -o {link}")
    assert one_error_line(r, 2).endswith(f"output {link} exists; use --force to replace it")
    r = run_in_process(f"enc acquire --rig sjtu-dual --revolutions 0.01 -o {link} --force")
    assert r.returncode == 0, r.stderr.decode()
    assert not link.is_symlink() and link.stat().st_size > 1000
    assert target.read_bytes() == b"old"


def test_a_fifo_appearing_before_the_rename_is_refused(tmp_path):
    """The check is made again just before the rename."""
    out = tmp_path / "late.html"
    fd, tmp = files.new_temporary(out)
    os.close(fd)
    os.mkfifo(out)
    with pytest.raises(files.OutputError, match="FIFO"):
        files.rename_into_place(tmp, out)
    assert stat.S_ISFIFO(os.lstat(out).st_mode)
    with pytest.raises(files.OutputError, match="FIFO"):
        files.write_atomic(out, b"x")
    assert sorted(p.name for p in tmp_path.iterdir()) == [Path(tmp).name, out.name]


# ------------------------------------------------------------------ stale temporaries

def _dead_pid() -> int:
    """The process id of a process that has ended."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def _temporary(folder: Path, name: str, pid: int, age_s: float, host: str | None = None) -> Path:
    t = folder / f".{name}.{pid}@{host or files._host()}.a{int(age_s)}_{pid % 1000}.tmp"
    t.write_bytes(b"partial")
    then = time.time() - age_s
    os.utime(t, (then, then))
    return t


def test_stale_temporaries_are_removed_by_the_next_run(tmp_path):
    out = tmp_path / "raw.parquet"
    dead = _dead_pid()
    stale = _temporary(tmp_path, out.name, dead, 2 * files.STALE_AGE_S)
    fresh = _temporary(tmp_path, out.name, dead, 60)
    alive = _temporary(tmp_path, out.name, os.getppid(), 2 * files.STALE_AGE_S)
    elsewhere = _temporary(tmp_path, out.name, dead, 2 * files.STALE_AGE_S, "other-host")
    legacy = tmp_path / f".{out.name}.k2j4h5g6.tmp"
    legacy.write_bytes(b"old version")
    then = time.time() - 2 * files.LEGACY_AGE_S
    os.utime(legacy, (then, then))
    other = _temporary(tmp_path, "other.parquet", dead, 2 * files.STALE_AGE_S)
    r = run_in_process(f"enc acquire --rig sjtu-dual --revolutions 0.01 -v -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    err = r.stderr.decode()
    assert f"INFO: removed {stale}, a temporary file of {out}" in err
    assert f"INFO: removed {legacy}" in err
    assert not stale.exists() and not legacy.exists()
    for kept in (fresh, alive, elsewhere, other):
        assert kept.exists(), kept
        assert str(kept) not in err
    assert out.stat().st_size > 1000


def test_stale_temporaries_of_a_report_are_removed(inputs, tmp_path):
    out = tmp_path / "r.html"
    stale = _temporary(tmp_path, out.name, _dead_pid(), 2 * files.STALE_AGE_S)
    r = run_in_process(f"enc report {inputs}/raw.parquet --html {out}")
    assert r.returncode == 0, r.stderr.decode()
    assert not stale.exists() and out.exists()
    assert [p.name for p in tmp_path.iterdir()] == [out.name]


def test_only_own_regular_files_are_removed(tmp_path):
    out = tmp_path / "x.parquet"
    dead = _dead_pid()
    folder = tmp_path / f".{out.name}.{dead}@{files._host()}.dir_5678.tmp"
    folder.mkdir()
    link = tmp_path / f".{out.name}.{dead}@{files._host()}.lnk_5678.tmp"
    link.symlink_to(tmp_path / "elsewhere")
    then = time.time() - 2 * files.STALE_AGE_S
    os.utime(folder, (then, then))
    os.utime(link, (then, then), follow_symlinks=False)
    assert files.remove_stale_temporaries(out) == []
    assert folder.is_dir() and link.is_symlink()


def test_a_writer_names_itself_in_its_temporary(tmp_path):
    fd, tmp = files.new_temporary(tmp_path / "y.parquet")
    os.close(fd)
    assert Path(tmp).name.startswith(f".y.parquet.{os.getpid()}@{files._host()}.")
    assert files._pattern("y.parquet").fullmatch(Path(tmp).name)
    assert not files._pattern("y").fullmatch(Path(tmp).name)


def test_the_temporary_of_a_killed_run_is_removed_by_the_next(tmp_path, enc):
    """kill -9 leaves ``.NAME.PID@HOST.*.tmp``; once old, the next run removes it."""
    out = tmp_path / "raw.parquet"
    p = subprocess.Popen([enc, "acquire", "--rig", "sjtu-dual", "--realtime", "-o", str(out)],
                         stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    left: list[Path] = []
    while not left and time.monotonic() < deadline:
        time.sleep(0.1)
        left = list(tmp_path.glob(f".{out.name}.{p.pid}@*.tmp"))
    p.kill()
    p.wait()
    assert len(left) == 1 and not out.exists()
    then = time.time() - 2 * files.STALE_AGE_S
    os.utime(left[0], (then, then))
    r = run_in_process(f"enc acquire --rig sjtu-dual --revolutions 0.01 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    assert [q.name for q in tmp_path.iterdir()] == [out.name]


class _Stopped(Exception):
    pass


def test_a_signal_the_moment_a_temporary_appears_leaves_none(tmp_path, monkeypatch):
    """A signal that ends a command arrives as soon as its output's temporary appears (a
    watcher of the folder sends it then, as the catalogue's signal rows do): delivered
    before the writer has the name to clean up, the temporary was left behind. It is now
    made and recorded with the signals held, and removed when the process ends."""
    import signal

    previous = signal.signal(signal.SIGUSR1, lambda *_: (_ for _ in ()).throw(_Stopped()))
    real_open = os.open

    def open_and_signal(*args, **kwargs):
        fd = real_open(*args, **kwargs)
        os.kill(os.getpid(), signal.SIGUSR1)   # the watcher, the moment the file exists
        return fd

    monkeypatch.setattr(os, "open", open_and_signal)
    try:
        with pytest.raises(_Stopped):
            files.write_atomic(tmp_path / "out.bin", b"data")
    finally:
        monkeypatch.setattr(os, "open", real_open)
        signal.signal(signal.SIGUSR1, previous)
    (left,) = [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    assert str(left) in files._LIVE
    files._remove_live()                 # what the command's ending runs (atexit)
    assert list(tmp_path.iterdir()) == []
