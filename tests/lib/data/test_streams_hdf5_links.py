"""An HDF5 input is read from its own bytes only.

HDF5 lets a dataset keep its data in other files (external storage), be assembled from
other files' datasets (a virtual dataset), or a name point into another file (an
external link). A stream or a user's table arriving as HDF5 could so copy any file the
user can read (a key, /etc/shadow, /proc/self/environ) into an output, or hang on a FIFO.
Each is refused with one line, exit 2, and nothing written.
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np
import pytest
from conftest import run

SECRET = b"secret-token-0123456789abcdef\n" * 64


@pytest.fixture(scope="module")
def stream_h5(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("h5links")
    r = run(f"enc acquire --rig ciomp-23bit --mode steps --count 4 -o {d}/run.h5")
    assert r.returncode == 0, r.stderr.decode()
    (d / "secret.bin").write_bytes(SECRET)
    return d


def _column(h5: h5py.File) -> tuple[h5py.Group, str]:
    g = h5["readings"]
    return g, next(n for n in g if g[n].dtype == np.int64)


def _external_storage(src: Path, dst: Path, target: Path) -> None:
    dst.write_bytes(src.read_bytes())
    with h5py.File(dst, "r+") as h5:
        g, name = _column(h5)
        n, dtype, attrs = g[name].shape[0], g[name].dtype, dict(g[name].attrs)
        del g[name]
        ds = g.create_dataset(name, shape=(n,), dtype=dtype,
                              external=[(str(target), 0, n * dtype.itemsize)])
        ds.attrs.update(attrs)


def _other_file(target: Path) -> None:
    """Another HDF5 file whose dataset ``data`` holds the secret's first 64 bytes."""
    with h5py.File(target, "w") as other:
        other["data"] = np.frombuffer(SECRET[:64], dtype=np.int64)


def _external_link(src: Path, dst: Path, target: Path) -> None:
    dst.write_bytes(src.read_bytes())
    _other_file(target)
    with h5py.File(dst, "r+") as h5:
        g, name = _column(h5)
        del g[name]
        g[name] = h5py.ExternalLink(str(target), "data")


def _virtual(src: Path, dst: Path, target: Path) -> None:
    dst.write_bytes(src.read_bytes())
    _other_file(target)
    with h5py.File(dst, "r+") as h5:
        g, name = _column(h5)
        attrs = dict(g[name].attrs)
        del g[name]
        layout = h5py.VirtualLayout(shape=(8,), dtype=np.int64)
        layout[:] = h5py.VirtualSource(str(target), "data", shape=(8,))
        g.create_virtual_dataset(name, layout).attrs.update(attrs)


@pytest.mark.parametrize("make, what", [(_external_storage, "stored in external files"),
                                         (_external_link, "external link"),
                                         (_virtual, "virtual dataset")])
@pytest.mark.parametrize("command", ["enc info {f}", "enc acquire --replay {f} -o {out}",
                                     "enc average-heads {f} -o {out}",
                                     "enc points {f} -o {out}"])
def test_hdf5_data_from_elsewhere_is_refused(stream_h5, tmp_path, make, what, command):
    f = tmp_path / "hostile.h5"
    make(stream_h5 / "run.h5", f, stream_h5 / "secret.bin" if make is _external_storage
         else tmp_path / "other.h5")
    out = tmp_path / "out.parquet"
    r = run(command.format(f=f, out=out), timeout=60)
    err = r.stderr.decode()
    assert r.returncode == 2, err
    assert err.count("\n") == 1 and what in err, err
    assert not out.exists() and b"secret-token" not in r.stdout


def test_a_fifo_named_as_external_storage_does_not_hang(stream_h5, tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    f = tmp_path / "hostile.h5"
    _external_storage(stream_h5 / "run.h5", f, fifo)
    r = run(f"enc info {f}", timeout=30)
    assert r.returncode == 2 and b"stored in external files" in r.stderr


def test_a_plain_hdf5_table_with_external_storage_is_refused(stream_h5, tmp_path):
    """A user's table (no enctools metadata) is read by the same rule."""
    f = tmp_path / "table.h5"
    with h5py.File(f, "w") as h5:
        h5["position_deg"] = np.arange(8) * 45.0
        h5.create_dataset("deviation_arcsec", shape=(8,), dtype=np.float64,
                          external=[(str(stream_h5 / "secret.bin"), 0, 64)])
    r = run(f"enc points {f} -o {tmp_path}/p.parquet", timeout=60)
    assert r.returncode == 2 and b"stored in external files" in r.stderr, r.stderr.decode()
    assert not (tmp_path / "p.parquet").exists()


def test_an_ordinary_hdf5_stream_still_reads(stream_h5, tmp_path):
    r = run(f"enc points {stream_h5}/run.h5 -o {tmp_path}/p.parquet")
    assert r.returncode == 0, r.stderr.decode()
