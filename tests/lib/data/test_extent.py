"""One file read, not two: data/extent.py against files written by the libraries
themselves in their other layouts (page indexes, dictionaries, newer superblocks), and
the same files concatenated or followed by other bytes."""

from __future__ import annotations

import io
from pathlib import Path

import h5py
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from enctools.data import extent
from enctools.errors import DataError


def _table(n: int = 5000) -> pa.Table:
    rng = np.random.default_rng(1)
    return pa.table({"t": np.arange(n) * 1e-3, "x": rng.normal(size=n),
                     "name": pa.array([f"h{i % 7}" for i in range(n)]).dictionary_encode()})


def _parquet(path: Path, **kw: object) -> Path:
    pq.write_table(_table(), path, **kw)
    return path


@pytest.mark.parametrize("kw", [{}, {"write_page_index": True}, {"row_group_size": 700},
                                {"compression": "zstd", "use_dictionary": False},
                                {"write_statistics": False}])
def test_parquet_files_as_written_are_one_file(tmp_path: Path, kw: dict) -> None:
    p = _parquet(tmp_path / "a.parquet", **kw)
    with open(p, "rb") as f:
        extent.check_parquet(f, pq.ParquetFile(p).metadata, "a.parquet")


@pytest.mark.parametrize("kw", [{}, {"write_page_index": True}, {"row_group_size": 700}])
def test_two_parquet_files_one_after_the_other_are_refused(tmp_path: Path, kw: dict) -> None:
    """``cat a a``: the footer read is the second file's, its offsets the first file's
    bytes, which decode: refused by the check alone. (``cat b a`` with another b puts
    the offsets in b's bytes: left to the decoder, which pyarrow 14 may crash on, so
    not tried in this process.)"""
    a = _parquet(tmp_path / "a.parquet", **kw).read_bytes()
    meta = pq.ParquetFile(pa.BufferReader(a + a)).metadata
    with pytest.raises(DataError, match="two Parquet files"):
        extent.check_parquet(io.BytesIO(a + a), meta, "aa.parquet")


def _arrow_file(path: Path) -> bytes:
    t = _table()
    with pa.ipc.new_file(path, t.schema) as w:
        for b in t.to_batches(max_chunksize=1000):
            w.write_batch(b)
    return path.read_bytes()


def test_arrow_file_with_dictionaries_is_one_file(tmp_path: Path) -> None:
    _arrow_file(tmp_path / "a.arrow")
    with open(tmp_path / "a.arrow", "rb") as f:
        extent.check_arrow_file(f, "a.arrow")
    extent.check_arrow_file(io.BytesIO((tmp_path / "a.arrow").read_bytes()), "stdin")


def test_two_arrow_files_one_after_the_other_are_refused(tmp_path: Path) -> None:
    data = _arrow_file(tmp_path / "a.arrow")
    (tmp_path / "ab.arrow").write_bytes(data + data)
    with open(tmp_path / "ab.arrow", "rb") as f, pytest.raises(DataError, match="two Arrow"):
        extent.check_arrow_file(f, "ab.arrow")
    with pytest.raises(DataError, match="two Arrow"):
        extent.check_arrow_file(io.BytesIO(data + data), "stdin")


@pytest.mark.parametrize("libver", ["earliest", "v110", "latest"])
def test_hdf5_end_is_read_from_every_superblock_version(tmp_path: Path, libver: str) -> None:
    p = tmp_path / "a.h5"
    with h5py.File(p, "w", libver=libver) as h:
        h.create_dataset("x", data=np.arange(10000.0), chunks=(1000,))
    data = p.read_bytes()
    assert extent.hdf5_end(data[:64]) == len(data)
    extent.check_hdf5(io.BytesIO(data), "a.h5")
    with pytest.raises(DataError, match="8 bytes after its end"):
        extent.check_hdf5(io.BytesIO(data + b"garbage\n"), "a.h5")
    with pytest.raises(DataError, match="two HDF5 files"):
        extent.check_hdf5(io.BytesIO(data + data), "a.h5")


def test_hdf5_end_of_what_is_not_a_superblock_is_unknown() -> None:
    assert extent.hdf5_end(b"PAR1" + bytes(60)) is None
    assert extent.hdf5_end(extent.HDF5_SIGNATURE + bytes([9]) + bytes(55)) is None
