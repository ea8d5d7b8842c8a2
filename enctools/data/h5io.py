"""HDF5 tables: one group per table (named after its kind), columns as datasets.

Group attributes: ``kind``, ``enctools`` (the stream metadata as JSON) and
``columns`` (column order). Dataset attributes: the field metadata (``unit``,
``role``, ...) and ``arrow_type``, so a table reads back to the same Arrow schema.
Datasets are chunked and resizable: a table is written batch by batch and read
batch by batch without holding it whole.
"""

from __future__ import annotations

import contextlib
import errno
import io
import json
import os
import resource
import stat
from collections.abc import Callable, Iterator
from typing import IO, Any

import numpy as np
import pyarrow as pa

from enctools.data import limits
from enctools.data.header import load_metadata
from enctools.errors import DataError

_CHUNK = 65536  # rows per batch read
_CHUNK_ROWS = 8192  # rows per HDF5 chunk: 64 KiB per float64 column
_MARGIN = 4 << 20  # bytes kept free for HDF5's metadata when the file is closed


def _ensure_space(path: str, nbytes: int) -> None:
    """Raise ENOSPC (EFBIG) before HDF5 meets a full disk (the process's file-size limit,
    ``ulimit -f``): its failed writes can crash the process."""
    st = os.statvfs(os.path.dirname(os.path.abspath(path)))
    if st.f_bavail * st.f_frsize < nbytes + _MARGIN:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), path)
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    if limit != resource.RLIM_INFINITY:
        size = os.path.getsize(path) if os.path.exists(path) else 0
        if size + nbytes + _MARGIN > limit:
            raise OSError(errno.EFBIG, os.strerror(errno.EFBIG), path)


def _arrow_type_name(t: pa.DataType) -> str:
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        return "string"
    return str(t)


def _arrow_type(name: str) -> pa.DataType:
    if name == "string":
        return pa.string()
    return pa.type_for_alias(name)


def _set_text(obj: Any, name: str, value: bytes) -> None:
    """Store UTF-8 text as a fixed-length string attribute.

    Fixed length, not HDF5's variable-length strings: reading those follows pointers
    into a global heap, and libhdf5 can crash on a damaged one.
    """
    obj.attrs.create(name, np.bytes_(value), dtype=f"S{max(len(value), 1)}")


class TableWriter:
    """Writes record batches into a new HDF5 file at ``path`` (pyarrow writer protocol)."""

    def __init__(self, path: str, schema: pa.Schema) -> None:
        import h5py

        self._h5 = h5py
        md = schema.metadata or {}
        kind = md.get(b"kind", b"table").decode()
        self._path = path
        _ensure_space(path, 0)
        self._file = h5py.File(path, "w")
        self._group = self._file.create_group(kind)
        _set_text(self._group, "kind", kind.encode())
        _set_text(self._group, "enctools", md.get(b"enctools", b"{}"))
        _set_text(self._group, "columns", json.dumps(schema.names).encode())
        self._names = schema.names
        for f in schema:
            if pa.types.is_string(f.type) or pa.types.is_large_string(f.type):
                dtype: Any = h5py.string_dtype()
            elif (pa.types.is_integer(f.type) or pa.types.is_floating(f.type)
                  or pa.types.is_boolean(f.type)):
                # (not DataType.to_pandas_dtype: before pyarrow 26 it needs pandas)
                dtype = pa.array([], type=f.type).to_numpy(zero_copy_only=False).dtype
            else:
                msg = f"HDF5 output cannot hold column {f.name!r} of type {f.type}"
                raise DataError(msg)
            ds = self._group.create_dataset(f.name, shape=(0,), maxshape=(None,), dtype=dtype,
                                            chunks=(_CHUNK_ROWS,))
            _set_text(ds, "arrow_type", _arrow_type_name(f.type).encode())
            for k, v in (f.metadata or {}).items():
                _set_text(ds, k.decode(), v)

    def write_batch(self, batch: pa.RecordBatch) -> None:
        _ensure_space(self._path, int(batch.nbytes * 1.1))
        n = batch.num_rows
        for name, col in zip(self._names, batch.columns, strict=True):
            if col.null_count:
                msg = f"HDF5 output cannot hold missing values (column {name!r})"
                raise DataError(msg)
            ds = self._group[name]
            start = ds.shape[0]
            ds.resize((start + n,))
            if pa.types.is_string(col.type) or pa.types.is_large_string(col.type):
                ds[start:] = np.asarray(col.to_pylist(), dtype=object)
            else:
                ds[start:] = col.to_numpy(zero_copy_only=False)

    def close(self) -> None:
        self._file.close()


def _text_attrs(obj: Any) -> dict[str, str]:
    """An object's attributes as text, reading only scalar string or number attributes.

    The shape and type of each attribute are checked before its value is read: a
    damaged attribute can crash libhdf5 when read, never when inspected.
    """
    out: dict[str, str] = {}
    for name in obj.attrs:
        aid = obj.attrs.get_id(name)
        if aid.shape not in ((), (1,)) or aid.dtype.kind not in "OSUifb":
            msg = f"attribute {name!r} is not a scalar"
            raise ValueError(msg)
        if aid.dtype.kind in "SU" and aid.dtype.itemsize > (1 << 20):
            msg = f"attribute {name!r} is too large"
            raise ValueError(msg)
        v = obj.attrs[name]
        out[name] = v.decode() if isinstance(v, bytes) else str(v)
    return out


def members(group: Any, source: str) -> dict[str, Any]:
    """A group's members, each a hard link inside this file; refused (DataError) are a
    link to another file or path (an external or soft link) and a dataset whose data is
    not in this file (external storage, a virtual dataset): opening them would read
    whatever file they name, a FIFO or another user's secrets among them."""
    import h5py

    out: dict[str, Any] = {}
    for name in group:
        link = group.get(name, getlink=True)
        if not isinstance(link, h5py.HardLink):
            kind = "external" if isinstance(link, h5py.ExternalLink) else "soft"
            msg = (f"{source}: HDF5 member {name!r} is an {kind} link; only data stored in "
                   "the file itself is read")
            raise DataError(msg)
        member = group[name]
        if isinstance(member, h5py.Dataset) and (member.external or member.is_virtual):
            where = "a virtual dataset" if member.is_virtual else "stored in external files"
            msg = (f"{source}: HDF5 dataset {name!r} is {where}; only data stored in the "
                   "file itself is read")
            raise DataError(msg)
        out[str(name)] = member
    return out


def open_table(f: IO[bytes], source: str,
               kind: str | None = None) -> tuple[Any, Iterator[pa.RecordBatch], Callable[[], None]]:
    """Open the table in an HDF5 file object: (Header, batch iterator, closer)."""
    import h5py

    from enctools.data.header import Header

    h5 = h5py.File(_by_name(f), "r")
    try:
        name = _table_name(h5, source, kind)
        g = h5[name]
        meta, schema, total = _read_layout(g, source, name)
    except DataError:
        h5.close()
        raise
    header = Header(str(meta["kind"]), schema, meta)
    return header, _batches(g, schema, total), h5.close


def _by_name(f: IO[bytes]) -> IO[bytes] | bytes:
    """A regular file's name, for HDF5's own driver; else the file object itself (a
    pipe's bytes held in memory). HDF5 reading through a Python file object calls back
    into Python, as late as the interpreter's exit when an open failed half-way."""
    name = getattr(f, "name", None)
    if isinstance(name, str) and not isinstance(f, io.BytesIO):
        with contextlib.suppress(OSError):
            if stat.S_ISREG(os.fstat(f.fileno()).st_mode):
                return os.fsencode(name)
    return f


def _table_name(h5: Any, source: str, kind: str | None) -> str:
    """The group holding the table: ``kind`` if present, else the only one."""
    import h5py

    groups = [k for k, v in members(h5, source).items()
              if isinstance(v, h5py.Group) and "kind" in v.attrs]
    if not groups:
        msg = f"{source}: HDF5 file holds no enctools table (no group with a 'kind' attribute)"
        raise DataError(msg)
    if kind is not None and kind in groups:
        return kind
    if len(groups) == 1:
        return str(groups[0])
    msg = f"{source}: HDF5 file holds several tables ({', '.join(groups)}); which one?"
    raise DataError(msg)


def _read_layout(g: Any, source: str, name: str) -> tuple[dict[str, Any], pa.Schema, int]:
    """A table group's stream metadata, Arrow schema and row count (checked, not read)."""
    import h5py

    try:
        gattrs = _text_attrs(g)
        meta = load_metadata(gattrs.get("enctools", "{}"), source)
        names = json.loads(gattrs["columns"])
        if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
            msg = "'columns' is not a list of names"
            raise ValueError(msg)
        fields = []
        datasets = members(g, source)
        for n in names:
            ds = datasets[n]
            if not isinstance(ds, h5py.Dataset) or len(ds.shape) != 1:
                msg = f"column {n!r} is not a one-dimensional dataset"
                raise ValueError(msg)
            _check_dataset(ds, n, source)
            attrs = _text_attrs(ds)
            arrow_type = attrs.pop("arrow_type")
            fields.append(pa.field(n, _arrow_type(arrow_type), metadata=attrs or None))
        nrows = {datasets[n].shape[0] for n in names}
    except (KeyError, ValueError, TypeError, RecursionError) as exc:
        msg = f"{source}: HDF5 table {name!r} is not an enctools table ({exc})"
        raise DataError(msg) from None
    if len(nrows) > 1:
        msg = f"{source}: HDF5 table {name!r} has columns of different lengths"
        raise DataError(msg)
    meta.setdefault("kind", gattrs["kind"])
    return meta, pa.schema(fields), nrows.pop() if nrows else 0


def _check_dataset(ds: Any, name: str, source: str) -> None:
    """A column's rows, chunk size and decoded size against :mod:`~enctools.data.limits`,
    from its layout alone (DataError naming the column)."""
    rows = int(ds.shape[0])
    where = f"{source}: HDF5 column {name!r}"
    if rows > limits.MAX_STREAM_ROWS:
        msg = f"{where} claims {rows} rows; at most {limits.MAX_STREAM_ROWS} are read"
        raise DataError(msg)
    item = max(int(ds.dtype.itemsize), 1)
    if ds.chunks is not None and int(ds.chunks[0]) * item > limits.MAX_HDF5_CHUNK_BYTES:
        msg = (f"{where} has chunks of {int(ds.chunks[0]) * item} bytes; at most "
               f"{limits.MAX_HDF5_CHUNK_BYTES} are read")
        raise DataError(msg)
    stored = int(ds.id.get_storage_size())
    if rows * item > limits.MAX_HDF5_EXPANSION * stored + limits.HDF5_EXPANSION_SLACK:
        msg = (f"{where} claims {rows * item} bytes of data in {stored} bytes of the file; "
               f"at most {limits.MAX_HDF5_EXPANSION} times as many are read")
        raise DataError(msg)


def _batches(g: Any, schema: pa.Schema, total: int) -> Iterator[pa.RecordBatch]:
    """The table's rows in batches of at most :data:`_CHUNK` rows (fewer for wide rows:
    :func:`~enctools.data.limits.batch_rows`)."""
    step = limits.batch_rows(schema, _CHUNK)
    for start in range(0, total, step):
        stop = min(start + step, total)
        arrays = []
        for fld in schema:
            data = g[fld.name][start:stop]
            if pa.types.is_string(fld.type):
                data = [x.decode() if isinstance(x, bytes) else x for x in data]
            arrays.append(pa.array(data, type=fld.type))
        yield pa.RecordBatch.from_arrays(arrays, schema=schema)
