"""The outputs of one analysis command appear together or not at all: when any of them
cannot be written (a full disk), none replaces its target, the files of an earlier run
are left as they were, no temporary is left, and one error line names the file that
failed. In-process, small inputs, the failure injected where the bytes are written."""

from __future__ import annotations

import errno
from pathlib import Path

import pytest
from conftest import one_error_line, run_in_process

from enctools.data import files, streams

ENOSPC = OSError(errno.ENOSPC, "No space left on device")


@pytest.fixture(scope="module")
def raw(tmp_path_factory):
    """Short sjtu-dual runs: two revolutions, and a hundredth of one with its signals."""
    d = tmp_path_factory.mktemp("inputs")
    for args, name in (("--revolutions 2.1", "raw"), ("--revolutions 0.01 --signals", "sig")):
        r = run_in_process(f"enc acquire --rig sjtu-dual {args} -o {d}/{name}.parquet")
        assert r.returncode == 0, r.stderr.decode()
    return d


# (command, its arguments with {o} its folder of outputs, the outputs' names)
COMMANDS = [
    ("selfcal", "{raw} -o {o}/d.parquet --spectrum {o}/s.parquet", ["d.parquet", "s.parquet"]),
    ("compare", "{raw} --device H1 --reference H2 -o {o}/c.parquet --spectrum {o}/s.parquet",
     ["c.parquet", "s.parquet"]),
    ("interp-check", "{sig} --signals -o {o}/i.parquet --spectrum {o}/s.parquet "
     "--corrected {o}/c.arrows", ["i.parquet", "s.parquet", "c.arrows"]),
    ("report", "{raw} --html {o}/r.html --pdf {o}/r.pdf", ["r.html", "r.pdf"]),
]
CASES = [(cmd, args, names, failing) for cmd, args, names in COMMANDS for failing in names]


def _args(args: str, inputs: Path, out: Path) -> str:
    return args.format(raw=inputs / "raw.parquet", sig=inputs / "sig.parquet", o=out)


def _full_disk_at(monkeypatch: pytest.MonkeyPatch, failing: Path) -> None:
    """Writing ``failing`` runs out of space after a first part of it is written."""
    write_batch = streams.OutputStream.write
    write_temporary = files._write_temporary

    def stream_write(self, batch):
        if self.path == str(failing):
            raise self._write_error(ENOSPC)
        return write_batch(self, batch)

    def temporary(p, data, durable):
        if str(p) == str(failing):
            def part(f):
                f.write(b"part of it")
                raise ENOSPC
            return write_temporary(p, part, durable)
        return write_temporary(p, data, durable)

    monkeypatch.setattr(streams.OutputStream, "write", stream_write)
    monkeypatch.setattr(files, "_write_temporary", temporary)


@pytest.mark.parametrize("earlier", [False, True], ids=["fresh", "earlier run"])
@pytest.mark.parametrize(("cmd", "args", "names", "failing"), CASES)
def test_one_failing_output_leaves_none(raw, tmp_path, monkeypatch, cmd, args, names, failing,
                                        earlier):
    out = tmp_path / "out"
    out.mkdir()
    if earlier:
        for n in names:
            (out / n).write_bytes(b"an earlier run's " + n.encode())
    _full_disk_at(monkeypatch, out / failing)
    r = run_in_process(f"enc {cmd} {_args(args, raw, out)} --force")
    line = one_error_line(r, 2, f"enc {cmd}")
    assert line == f"enc {cmd}: error: output {out / failing}: No space left on device"
    if earlier:
        assert sorted(p.name for p in out.iterdir()) == sorted(names)   # no temporary
        for n in names:
            assert (out / n).read_bytes() == b"an earlier run's " + n.encode(), n
    else:
        assert list(out.iterdir()) == []


@pytest.mark.parametrize(("cmd", "args", "names"), COMMANDS)
def test_all_outputs_written_when_all_succeed(raw, tmp_path, cmd, args, names):
    r = run_in_process(f"enc {cmd} {_args(args, raw, tmp_path)}")
    assert r.returncode == 0, r.stderr.decode()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names)


def test_group_commit_and_discard(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.write_text("old a")
    with pytest.raises(RuntimeError), files.OutputGroup() as g:
        g.write(a, b"new a")
        g.write(b, b"new b")
        raise RuntimeError
    assert a.read_text() == "old a" and sorted(p.name for p in tmp_path.iterdir()) == ["a"]
    with files.OutputGroup() as g:
        g.write(a, b"new a")
        g.write(b, lambda f: f.write(b"new b"))
        assert not b.exists()              # nothing is in place before the commit
    assert a.read_bytes() == b"new a" and b.read_bytes() == b"new b"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b"]


@pytest.mark.parametrize(("cmd", "args", "name"), [
    ("selfcal", "{raw} -o {o}/d.parquet --spectrum {full}/s.parquet", "s.parquet"),
    ("report", "{raw} --html {o}/r.html --pdf {full}/r.pdf", "r.pdf"),
])
def test_a_real_full_disk_for_one_output(raw, tmp_path, full_tmpfs, cmd, args, name):
    """The second output on a file system that is full (a small tmpfs)."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "d.parquet").write_bytes(b"an earlier run's")
    (out / "r.html").write_bytes(b"an earlier run's")
    filled = args.format(raw=raw / "raw.parquet", o=out, full=full_tmpfs)
    r = run_in_process(f"enc {cmd} {filled} --force")
    line = one_error_line(r, 2, f"enc {cmd}")
    assert line == f"enc {cmd}: error: output {full_tmpfs / name}: No space left on device"
    assert sorted(p.name for p in out.iterdir()) == ["d.parquet", "r.html"]
    assert {p.read_bytes() for p in out.iterdir()} == {b"an earlier run's"}
    assert sorted(p.name for p in full_tmpfs.iterdir()) == ["fill", "h"]


class _Ended(Exception):
    pass


def _renames_signalled(monkeypatch: pytest.MonkeyPatch, sig: int) -> list[str]:
    """os.replace sends ``sig`` to this process at the group's first rename; the names
    it renamed are listed in the returned list."""
    import os
    import signal

    done: list[str] = []
    replace = os.replace

    def signalled(src, dst):
        if not done:
            signal.raise_signal(sig)       # lands between the first and the second rename
        replace(src, dst)
        done.append(Path(dst).name)
    monkeypatch.setattr(files.os, "replace", signalled)
    return done


@pytest.mark.parametrize("name", ["SIGTERM", "SIGINT", "SIGHUP"])
def test_a_signal_during_the_renames_comes_after_all_of_them(tmp_path, monkeypatch, name):
    """A signal that lands between two renames of a group is delivered once every output
    is in place, through the handler the command had: never one output new, one old."""
    import signal

    sig = getattr(signal, name)

    def ended(signum, frame):
        raise _Ended(signum)

    previous = signal.signal(sig, ended)
    try:
        done = _renames_signalled(monkeypatch, sig)
        a, b = tmp_path / "a", tmp_path / "b"
        a.write_text("old a")
        b.write_text("old b")
        with pytest.raises(_Ended) as caught, files.OutputGroup() as g:
            g.write(a, b"new a")
            g.write(b, b"new b")
        assert caught.value.args == (sig,)
        assert done == ["a", "b"]
        assert a.read_bytes() == b"new a" and b.read_bytes() == b"new b"
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b"]
        assert signal.getsignal(sig) is ended    # the handler given back
    finally:
        signal.signal(sig, previous)


def test_a_signal_with_its_default_action_ends_the_process_after_the_renames(tmp_path):
    """Where nothing catches the signal (a library user), it still ends the process, only
    once both outputs are in place."""
    import subprocess
    import sys
    import textwrap

    code = textwrap.dedent(f"""
        import os, signal, sys
        from pathlib import Path
        from enctools.data import files
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        replace = os.replace
        def signalled(src, dst):
            if not Path(dst).name.endswith("b"):
                os.kill(os.getpid(), signal.SIGTERM)
            replace(src, dst)
        files.os.replace = signalled
        with files.OutputGroup() as g:
            g.write({str(tmp_path / "a")!r}, b"new a")
            g.write({str(tmp_path / "b")!r}, b"new b")
        print("not reached", flush=True)
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert r.returncode == -15, r.stderr.decode()
    assert r.stdout == b""
    assert (tmp_path / "a").read_bytes() == b"new a"
    assert (tmp_path / "b").read_bytes() == b"new b"
