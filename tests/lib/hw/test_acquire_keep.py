"""Every sample read is kept: a closed pipe downstream, a full disk under one output, a
device or transport failure, an interruption inside a counter block.

The outputs that can still be written are closed into valid files holding every batch
read (the batch in hand included); an output that failed leaves nothing, not even its
temporary file; the exit status says why the run ended.
"""

from __future__ import annotations

import errno
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest
from conftest import one_error_line, run, run_in_process, small_tmpfs

from enctools.data import streams

# ciomp-23bit at 1 kHz: 1.5 revolutions are 90 000 samples, two batches (65 536 + 24 464).
TWO_BATCHES = "--rig ciomp-23bit --mode continuous --revolutions 1.5"


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


@pytest.mark.parametrize("realtime", [False, True])
def test_closed_pipe_downstream_keeps_the_tee(tmp_path: Path, realtime: bool) -> None:
    tee = tmp_path / "tee.parquet"
    extra = " --realtime" if realtime else ""
    r = run(f"enc acquire --rig sjtu-dual{extra} --tee {tee} | head -c 100 > /dev/null;"
            " exit ${PIPESTATUS[0]}", cwd=tmp_path, timeout=60)
    assert r.returncode == 0, r.stderr.decode()
    assert r.stderr == b""  # quietly, as for any `| head`
    table = pq.read_table(tee)  # a valid file, under its final name
    assert table.num_rows > 0
    assert leftovers(tmp_path) == []


class _FullDisk:
    """A writer whose device is full after ``good`` batches (ENOSPC, as the OS says it)."""

    def __init__(self, writer: Any, good: int) -> None:
        self.writer = writer
        self.good = good

    def write_batch(self, batch: Any) -> None:
        if self.good <= 0:
            raise OSError(errno.ENOSPC, "No space left on device")
        self.good -= 1
        self.writer.write_batch(batch)

    def close(self) -> None:
        self.writer.close()


@pytest.mark.parametrize("full", ["tee", "output"])
def test_full_disk_under_one_output_keeps_the_other(tmp_path: Path, full: str,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "good").mkdir()
    (tmp_path / "full").mkdir()
    tee = tmp_path / ("full" if full == "tee" else "good") / "t.parquet"
    out = tmp_path / ("good" if full == "tee" else "full") / "raw.parquet"
    bad = tee if full == "tee" else out
    make = streams.OutputStream._make_writer

    def make_writer(self: streams.OutputStream) -> Any:
        writer = make(self)
        return _FullDisk(writer, 1) if self.path == str(bad) else writer

    monkeypatch.setattr(streams.OutputStream, "_make_writer", make_writer)
    r = run_in_process(f"enc acquire {TWO_BATCHES} --tee {tee} -o {out}")
    line = one_error_line(r, 2)
    kept = out if full == "tee" else tee
    assert f"output {bad}: No space left on device" in line
    assert f"the 90000 rows read are kept in {kept}" in line
    assert pq.read_table(kept).num_rows == 90000  # the batch that failed elsewhere too
    assert not bad.exists() and leftovers(bad.parent) == []


@pytest.mark.slow
def test_full_tmpfs_keeps_the_other_output(tmp_path: Path) -> None:
    """The same on a real 64 KiB file system that fills up during the run (root only)."""
    with small_tmpfs(tmp_path / "small", "64k") as small:
        good = tmp_path / "good.parquet"
        r = run(f"enc acquire {TWO_BATCHES} --tee {small}/t.parquet -o {good}")
        line = one_error_line(r, 2)
        assert f"output {small}/t.parquet: No space left on device" in line
        assert f"kept in {good}" in line
        assert pq.read_table(good).num_rows > 0
        assert list(small.iterdir()) == []


def _endings() -> list[Any]:
    from enctools.errors import DataError, DeviceError, Interrupted, OutputError, SettingsError

    return [(DeviceError("instrument x: read failed"), True),
            (KeyboardInterrupt(), True),
            (Interrupted("terminated", exit_code=143), True),
            (BrokenPipeError(32, "Broken pipe"), True),
            (OutputError("output other.parquet: No space left on device", "other.parquet"), True),
            (ConnectionResetError(104, "Connection reset by peer"), True),
            (RuntimeError("a bug"), True),
            (SettingsError("`heads`: no head 'X'"), False),
            (DataError("replay.arrows: truncated"), False),
            (OutputError("output SELF: No space left on device", "SELF"), False)]


@pytest.mark.parametrize("ending,kept", _endings(), ids=lambda x: type(x).__name__)
def test_keep_partial_keeps_for_every_ending_but_bad_usage_or_input(
        tmp_path: Path, ending: BaseException, kept: bool) -> None:
    import pyarrow as pa

    from enctools.data.header import Header

    path = tmp_path / "run.parquet"
    if getattr(ending, "path", None) == "SELF":
        ending.path = str(path)  # type: ignore[attr-defined]
    from enctools.data.readings import head_field
    from enctools.data.schemas import make_field

    schema = pa.schema([make_field("t", pa.float64(), "s"),
                        head_field("A", "enc", 0.0, 1 << 20, 1 << 12, 1 << 8, 0.1, 0)])
    batch = pa.record_batch([pa.array([0.0, 0.1]), pa.array([0, 5], pa.int64())], schema=schema)
    header = Header("readings", schema, {"rig": {"name": "x"}, "settings": {}})
    with pytest.raises(type(ending)), \
            streams.OutputStream(str(path), header, keep_partial=True) as out:
        out.write(batch)
        raise ending
    assert path.exists() == kept
    if kept:
        assert pq.read_table(path).num_rows == 2
    assert leftovers(tmp_path) == []


def test_a_run_recorded_by_the_library_keeps_what_was_read(tmp_path: Path) -> None:
    """hw.recording without the command line: a device fault after two positions leaves
    both outputs holding them, and the fault is raised again."""
    from conftest import simulate

    from enctools.errors import DeviceError
    from enctools.hw import recording

    header, batches = simulate("ciomp-23bit", 1, mode="steps", count=4)

    def faulty() -> Any:
        yield from batches[:2]
        raise DeviceError("the table stopped answering")

    paths = [str(tmp_path / "a.parquet"), str(tmp_path / "b.arrows")]
    outs = recording.open_outputs(header, [(p, None) for p in paths])
    with pytest.raises(DeviceError, match="stopped answering"):
        recording.record(faulty(), outs)
    for p in paths:
        assert streams.read_table(p, "readings")[1].column("step").to_pylist() == [0] * 5 + [1] * 5
    assert leftovers(tmp_path) == []
