"""Reading and writing enctools streams: Arrow IPC, Parquet, HDF5, CSV and TSV; files and pipes.

A stream is a :class:`Header` (kind, Arrow schema with field metadata, and a JSON
metadata dict carrying the rig, the settings, the ground truth and the ``history``)
plus Arrow record batches.

- Input: a path, or ``-``/``None`` for stdin. A file's format is what its name says
  (its extension, or a CSV or TSV table's sidecar beside it), else what its content says
  where the signature is unambiguous; a pipe's, its first bytes
  (:mod:`enctools.data.formats`: the order of authority). Arrow IPC streams are read
  batch by batch; Parquet, Arrow files and HDF5 arriving on a pipe are buffered in
  memory first (they need seeking).
- Output: a path, whose extension chooses the format, or stdout (Arrow IPC stream,
  or Parquet, CSV, TSV with ``fmt``). Named outputs are written to a temporary file
  in the same folder and renamed only on success (a table with its sidecar); binary
  data never goes to a terminal.

Reading a pipe that can be stopped, reading ahead on a thread and the pipe buffer
size are :mod:`enctools.data.pipes`' job.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
import re
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import pyarrow as pa

from enctools.data import csvio, extent, files, h5io, limits, pipes
from enctools.data.formats import EXTENSIONS, FORMATS, MAGIC, detect_format, file_format
from enctools.data.formats import ends as file_ends
from enctools.data.formats import mismatch as format_mismatch
from enctools.data.header import Header, header_from_arrow, with_history
from enctools.data.native import ArrowWriter, native_file
from enctools.data.schemas import validate
from enctools.data.text import first_line
from enctools.errors import DataError, EncError, OutputError, SettingsError

__all__ = [
    "EXTENSIONS",
    "FORMATS",
    "MAGIC",
    "Header",
    "InputStream",
    "OutputStream",
    "check_output",
    "detect_format",
    "format_for_path",
    "open_input",
    "read_table",
    "with_history",
    "write_table",
]

BATCH_ROWS = 65536

# What the Arrow, Parquet and HDF5 decoders raise on corrupt or truncated input (h5py
# raises RuntimeError and KeyError for damaged B-trees and heaps; pyarrow's "not
# implemented" for a damaged type is an ArrowException).
_DECODE_ERRORS = (pa.ArrowException, OSError, EOFError, ValueError, KeyError, TypeError,
                  RuntimeError, IndexError, ArithmeticError, MemoryError)


# --------------------------------------------------------------------------- input


#: batches read ahead of the caller on a reader thread (InputStream.batches)
READ_AHEAD = 2


def _clean(b: pa.RecordBatch) -> pa.RecordBatch:
    """A batch without schema metadata (the header carries it)."""
    return b.replace_schema_metadata(None) if b.schema.metadata else b


class InputStream:
    """An open input stream: ``header`` now, ``batches()`` once, or ``read_all()``."""

    def __init__(self, header: Header, batches: Iterator[pa.RecordBatch], source: str,
                 fmt: str, closer: Any = None) -> None:
        self.header = header
        self._batches = batches
        self.source = source
        self.format = fmt
        self._closer = closer
        #: set to stop a read-ahead thread waiting on a pipe (see pipes.Prefixed)
        self.cancel: Any = None
        #: the rows the file says it holds (Parquet, HDF5), None when only reading tells
        self.claimed_rows: int | None = None

    @property
    def kind(self) -> str:
        return self.header.kind

    @property
    def schema(self) -> pa.Schema:
        return self.header.schema

    @property
    def meta(self) -> dict[str, Any]:
        return self.header.meta

    def batches(self, read_ahead: int = READ_AHEAD,
                prepare: Callable[[pa.RecordBatch], Any] | None = None,
                checked: bool = True) -> Iterator[Any]:
        """The record batches, in order (a truncated stream raises DataError).

        ``read_ahead`` batches are read on a thread while the caller works on the
        current one (reading a pipe or decoding releases the GIL): a filter then
        costs about the larger of its reading and its computing, not their sum.
        0 reads in the caller's thread. ``prepare``: a function of a batch run on
        that thread too (per-batch numpy work, which also releases the GIL); its
        results are yielded instead of the batches, its exceptions raised here.
        ``checked=False``: the values are left unchecked (:meth:`read_all` checks the table).
        """
        checks = limits.value_checks(self.kind, self.schema) if checked else []
        items: Iterator[Any] = (self._checked(_clean(b), checks) for b in self._batches)
        if prepare is not None:
            items = map(prepare, items)
        source = pipes.ReadAhead(items, read_ahead, self.cancel) if read_ahead > 0 else items
        try:
            yield from source
        except _DECODE_ERRORS as exc:
            if isinstance(exc, BrokenPipeError):
                raise
            msg = f"{self.source}: truncated or corrupt {self.format} data ({first_line(exc)})"
            raise DataError(msg) from None
        finally:
            if isinstance(source, pipes.ReadAhead) and not source.stop():
                self._closer = None  # the reader is still in a read: leave the file to it
            self.close()

    def _checked(self, batch: Any, checks: list) -> Any:
        """The batch (or table), once none of its values is missing and all are within
        :data:`~enctools.data.limits.VALUE_RANGES`."""
        limits.check_missing(batch, self.source)
        if checks:
            limits.check_batch(batch, checks, self.source)
        return batch

    def read_all(self, max_rows: int | None = None) -> pa.Table:
        """All batches as one table (schema without metadata).

        At most ``max_rows`` rows (default :data:`~enctools.data.limits.MAX_TABLE_ROWS`):
        a file that claims more is refused before it is read, one that holds more as
        soon as the batches read exceed it (DataError naming both numbers).
        """
        limit = limits.MAX_TABLE_ROWS if max_rows is None else max_rows
        if self.claimed_rows is not None and self.claimed_rows > limit:
            self.close()
            raise self._too_many(self.claimed_rows, limit)
        batches, rows = [], 0
        # no read-ahead, values checked once: a step run has hundreds of one-position batches
        for b in self.batches(read_ahead=0, checked=False):
            rows += b.num_rows
            if rows > limit:
                raise self._too_many(rows, limit, "over ")
            batches.append(b)
        table = pa.Table.from_batches(batches, schema=self.schema)
        return self._checked(table, limits.value_checks(self.kind, self.schema))

    def _too_many(self, rows: int, limit: int, over: str = "") -> DataError:
        return DataError(f"{self.source}: {over}{rows} rows; this command holds at most "
                         f"{limit} rows in memory (enc-streams(5), LIMITS)")

    def close(self) -> None:
        if self._closer is not None:
            with contextlib.suppress(Exception):
                self._closer()
            self._closer = None

    def __enter__(self) -> InputStream:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_input(path: str | os.PathLike[str] | None, expect: str | tuple[str, ...] | None = None,
               stdin: IO[bytes] | None = None) -> InputStream:
    """Open a stream from a path or stdin (``None`` or ``-``) and validate its header.

    ``expect``: the kind(s) the caller reads; anything else is a one-line DataError.
    """
    if path is None or str(path) == "-":
        if stdin is None and sys.stdin is None:
            msg = "no input: stdin is closed; give an input file"
            raise SettingsError(msg)
        if stdin is None and sys.stdin.isatty():
            msg = "no input: give an input file, or pipe a stream into the command"
            raise SettingsError(msg)
        stream = _open_pipe(stdin if stdin is not None else sys.stdin.buffer, "stdin")
    else:
        source = str(path)
        p = Path(path)
        if p.is_dir():
            msg = f"{source}: is a directory, not a stream file"
            raise DataError(msg)
        try:
            fh = open(p, "rb")  # noqa: SIM115 - closed by the stream
        except FileNotFoundError:
            msg = f"{source}: no such file"
            raise DataError(msg) from None
        except OSError as exc:
            msg = f"{source}: cannot open: {exc.strerror}"
            raise DataError(msg) from None
        try:
            # a named pipe, e.g. <(enc acquire ...), reads like stdin
            stream = _open_pipe(fh, source) if not fh.seekable() else _open_file(fh, source)
        except BaseException:
            fh.close()
            raise
    return _validated(stream, expect)


def _open_file(fh: IO[bytes], source: str) -> InputStream:
    """A stream from a seekable file: the format from its first bytes."""
    head, tail = file_ends(fh)
    if not head:
        msg = f"{source}: empty file"
        raise DataError(msg)
    fmt = file_format(source, fh) or _known_format(head, source)
    if fmt in csvio.FORMATS:  # a text table, read with its sidecar
        header, batches, rows, closer = csvio.open_table(fh, source)
        stream = InputStream(header, batches, source, fmt.upper(), closer)
        stream.claimed_rows = rows
        return stream
    try:
        return _open_arrows(fh, source) if fmt == "arrows" else _open_seekable(fh, fmt, source)
    except DataError as exc:  # named as one format, holding another: say which
        raise DataError(f"{exc}{format_mismatch(fmt, head, tail)}") from None


def _open_pipe(raw: IO[bytes], source: str) -> InputStream:
    """A stream from a pipe: Arrow IPC streams as they come, other formats buffered.

    A pipe behind a fresh buffered reader (stdin, a FIFO just opened) is read through
    its unbuffered file, so that the read-ahead thread can wait on it and be stopped.
    """
    import threading

    pipes.enlarge_pipe(raw)
    under = getattr(raw, "raw", None)
    cancel, owner = None, None
    if isinstance(under, io.FileIO) and pipes.is_fifo(under):
        # the buffered reader is kept alive with the stream: collected, it closes its file
        owner, raw, cancel = raw, under, threading.Event()
    prefix = pipes.read_fully(raw, 8)
    if not prefix:
        msg = f"{source}: no input (empty stream); was the command before it in the pipe ok?"
        raise DataError(msg)
    fmt = _known_format(prefix, source)
    if fmt == "arrows":
        wrapped = pipes.Prefixed(prefix, raw, cancel)
        wrapped.owner = owner
        stream = _open_arrows(io.BufferedReader(wrapped, buffer_size=1 << 20), source)
        stream.cancel = cancel
        return stream
    data = prefix + pipes.read_at_most(raw, limits.MAX_PIPE_BUFFER_BYTES)  # needs seeking
    if len(data) > limits.MAX_PIPE_BUFFER_BYTES:
        msg = (f"{source}: a {fmt} stream on a pipe is held in memory, and this one is over "
               f"{limits.MAX_PIPE_BUFFER_BYTES} bytes; give it as a file, or pipe Arrow IPC")
        raise DataError(msg)
    return _open_seekable(io.BytesIO(data), fmt, source)


def _validated(stream: InputStream, expect: str | tuple[str, ...] | None) -> InputStream:
    """The stream, once its header fits its kind (and the kind the caller reads)."""
    source = stream.source
    try:
        validate(stream.header.schema, stream.header.meta, expect, source)
    except DataError:
        stream.close()
        raise
    except (UnicodeDecodeError, TypeError, ValueError) as exc:
        stream.close()
        msg = f"{source}: corrupt metadata ({first_line(exc)})"
        raise DataError(msg) from None
    return stream


def _known_format(prefix: bytes, source: str) -> str:
    """The format named by a stream's first bytes; a one-line DataError for any other."""
    fmt = detect_format(prefix)
    if fmt is None:
        msg = (f"{source}: not an Arrow, Parquet or HDF5 stream, nor a CSV or TSV file with "
               f"its sidecar (starts with bytes {prefix[:8].hex(' ')})")
        raise DataError(msg)
    return fmt


def _open_arrows(f: IO[bytes], source: str) -> InputStream:
    try:
        reader = pa.ipc.open_stream(f)
    except _DECODE_ERRORS as exc:
        msg = f"{source}: truncated or corrupt Arrow stream ({first_line(exc)})"
        raise DataError(msg) from None
    batches = pipes.one_stream(reader, f, source)
    return InputStream(header_from_arrow(reader.schema, source), batches, source,
                       "Arrow IPC stream", f.close)


def _open_seekable(f: IO[bytes], fmt: str, source: str) -> InputStream:
    try:
        if fmt == "parquet":
            return _open_parquet(f, source)
        if fmt == "arrow":
            return _open_arrow_file(f, source)
        return _open_hdf5(f, source)
    except DataError:
        f.close()
        raise
    except _DECODE_ERRORS as exc:
        f.close()
        msg = f"{source}: truncated or corrupt {fmt} file ({first_line(exc)})"
        raise DataError(msg) from None


def _native(f: IO[bytes]) -> pa.NativeFile:
    """The file as pyarrow's own reader (a buffer, or the file opened again by name):
    reading a Python file object, pyarrow may leave a read pending on one of its threads
    when opening a truncated file fails, and the process aborts at exit (SIGABRT)."""
    return (pa.BufferReader(f.getvalue()) if isinstance(f, io.BytesIO)
            else native_file(f.name))  # any name the file system takes


def _open_parquet(f: IO[bytes], source: str) -> InputStream:
    import pyarrow.parquet as pq

    native = _native(f)
    try:
        # pre-buffering holds the whole file; a column chunk read whole, its row group's
        # decoded bytes a few times over: read a page at a time
        pf = pq.ParquetFile(native, pre_buffer=False, buffer_size=limits.PARQUET_READ_BYTES)
        header = header_from_arrow(pf.schema_arrow, source)
        rows = pf.metadata.num_rows
        if rows > limits.MAX_STREAM_ROWS:
            msg = f"{source}: claims {rows} rows; at most {limits.MAX_STREAM_ROWS} are read"
            raise DataError(msg)
        extent.check_parquet(f, pf.metadata, source, groups=True)  # one walk, both checks
    except BaseException:
        native.close()
        raise
    batches = pf.iter_batches(batch_size=limits.batch_rows(pf.schema_arrow, BATCH_ROWS))
    stream = InputStream(header, batches, source, "Parquet",
                         lambda: (native.close(), f.close()))
    stream.claimed_rows = rows
    return stream


def _open_arrow_file(f: IO[bytes], source: str) -> InputStream:
    native = _native(f)
    try:
        reader = pa.ipc.open_file(native)
        header = header_from_arrow(reader.schema, source)
        extent.check_arrow_file(f, source)
    except BaseException:
        native.close()
        raise
    batches = (reader.get_batch(i) for i in range(reader.num_record_batches))
    return InputStream(header, batches, source, "Arrow file", lambda: (native.close(), f.close()))


def _open_hdf5(f: IO[bytes], source: str) -> InputStream:
    extent.check_hdf5(f, source)
    header, batches, closer = h5io.open_table(f, source)
    return InputStream(header, batches, source, "HDF5", lambda: (closer(), f.close()))


def read_table(path: str | os.PathLike[str] | None,
               expect: str | tuple[str, ...] | None = None) -> tuple[Header, pa.Table]:
    """Read a whole stream: its header and one table."""
    with open_input(path, expect) as s:
        return s.header, s.read_all()


# -------------------------------------------------------------------------- output


def format_for_path(path: str, fmt: str | None = None) -> str:
    """The output format: ``fmt`` if given, else from the file's extension."""
    return files.format_by_extension(path, fmt, FORMATS, EXTENSIONS, "format",
                                     f"use one of {', '.join(sorted(EXTENSIONS))} or `fmt`")


def check_output(path: str | None, force: bool = False, fmt: str | None = None,
                 stdout: IO[bytes] | None = None) -> None:
    """Fail early (before any work) when the output cannot be written."""
    if path is None or path == "-":
        fmt = fmt or "arrows"
        if fmt not in ("arrows", "parquet", *csvio.FORMATS):
            msg = f"{fmt} cannot be written to a pipe (it needs seeking); use -o FILE"
            raise SettingsError(msg)
        out = stdout if stdout is not None else sys.stdout
        if out is None:
            raise OutputError("stdout is closed: the stream cannot be written there; "
                              "give an output file")
        if fmt not in csvio.FORMATS and hasattr(out, "isatty") and out.isatty():
            msg = "refusing to write binary data to a terminal; use -o FILE or a pipe"
            raise SettingsError(msg)
        return
    files.check_new_file(path, force)
    if format_for_path(path, fmt) in csvio.FORMATS:  # its sidecar is written with it
        files.check_new_file(csvio.checked_sidecar_path(path), force)


class OutputStream:
    """Writes one stream batch by batch; a named file appears only when closed cleanly.

    Use as a context manager: an exception inside the block removes the temporary file
    (nothing partial is left). With ``keep_partial=True`` (acquisition), any other ending
    instead closes everything written so far into a valid file under the final name (see
    :meth:`keeps`): a device fault, an interruption (SIGINT, SIGTERM), a closed
    downstream pipe, a sibling output that failed, even a bug. Bad usage or bad input
    (SettingsError, DataError), or a failure of this output itself, still leaves nothing.
    """

    def __init__(self, path: str | None, header: Header, force: bool = False,
                 fmt: str | None = None, stdout: IO[bytes] | None = None,
                 keep_partial: bool = False, group: files.OutputGroup | None = None,
                 unit: str | None = None) -> None:
        check_output(path, force, fmt, stdout)
        self.unit = unit or csvio.ERROR_UNIT  # of the angle errors in a CSV or TSV table
        self.path = None if path in (None, "-") else str(path)
        # what a command writes, enctools reads back: the header fits its kind
        validate(header.schema, {**header.meta, "kind": header.kind}, header.kind,
                 f"output {self.path or 'stdout'}")
        self._checks = limits.value_checks(header.kind, header.schema)
        self.header = header
        self.force = force
        self.group = group  # a named file is then renamed with the group's others
        self.keep_partial = keep_partial
        self.rows = 0
        self._schema = header.arrow_schema()
        if self.path is None:
            self.format = fmt or "arrows"
            self._sink: Any = stdout if stdout is not None else sys.stdout.buffer
            pipes.enlarge_pipe(self._sink)
            self._tmp = None
        else:
            self.format = format_for_path(self.path, fmt)
            p = Path(self.path)
            try:
                fd, tmp = files.new_temporary(p)
            except OSError as exc:
                msg = f"output {self.path}: cannot create a file in {p.parent}: {exc.strerror}"
                raise OutputError(msg, self.path) from None
            os.close(fd)
            self._tmp = tmp
            self._sink = None
        self._writer = self._make_writer()

    def _make_writer(self) -> Any:
        target = self._tmp if self._tmp is not None else self._sink
        try:
            if self.format in csvio.FORMATS:
                return csvio.TableWriter(target, self.header, self.format, self.unit)
            if self.format in ("arrows", "arrow", "parquet"):
                return ArrowWriter(self.format, target, self._schema)
            return h5io.TableWriter(target, self._schema)
        except OSError as exc:
            self._discard()
            raise self._write_error(exc) from None
        except BaseException:
            self._discard()
            raise

    def write(self, batch: pa.RecordBatch | pa.Table) -> None:
        """Append a batch (or table) whose columns match the header's schema."""
        if isinstance(batch, pa.Table):
            for b in batch.to_batches(max_chunksize=BATCH_ROWS):
                self.write(b)
            return
        if batch.schema.remove_metadata() != self._schema.remove_metadata():
            batch = pa.RecordBatch.from_arrays(batch.columns, schema=self._schema)
        if self._checks:  # a result out of range (NaN weights...) is a fault, not an output
            limits.check_batch(batch, self._checks, f"output {self.path or 'stdout'}")
        try:
            self._writer.write_batch(batch)
        except OSError as exc:
            raise self._write_error(exc) from None
        self.rows += batch.num_rows

    def _write_error(self, exc: OSError) -> OSError | OutputError:
        """A failed write as a one-line error naming the output (a closed pipe stays EPIPE)."""
        text = str(exc)
        if isinstance(exc, BrokenPipeError) or "Broken pipe" in text or "errno 32" in text:
            return BrokenPipeError(32, "Broken pipe")
        m = re.search(r"\[errno \d+\] (.*)", text)
        reason = m.group(1) if m else (exc.strerror or text)
        return OutputError(f"output {self.path or 'stdout'}: {reason}", self.path)

    def close(self) -> None:
        """Finish the stream; a named file is renamed into place."""
        if self._writer is None:
            return
        writer, self._writer = self._writer, None
        try:
            writer.close()
        except OSError as exc:
            self._discard()
            raise self._write_error(exc) from None
        if self._tmp is not None:
            assert self.path is not None  # a temporary file is made for a named output only
            if isinstance(writer, csvio.TableWriter):  # the table and its sidecar together
                tmp, self._tmp = self._tmp, None
                csvio.stage(tmp, self.path, writer.sidecar(Path(self.path).name), self.force,
                            self.group)
                return
            if self.group is not None:
                self.group.stage(self._tmp, self.path, self.force)
                self._tmp = None
                return
            try:  # a file, device or FIFO that appeared meanwhile is refused
                files.rename_into_place(self._tmp, self.path, self.force)
            except OutputError as exc:
                self._discard()
                raise OutputError(exc.template, self.path) from None
            except OSError as exc:
                self._discard()
                raise self._write_error(exc) from None
            self._tmp = None
        else:
            with contextlib.suppress(AttributeError):
                self._sink.flush()

    def _discard(self) -> None:
        if self._tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(self._tmp)
            self._tmp = None

    def abort(self, keep: bool | None = None) -> bool:
        """Stop writing: remove a temporary file, or (keep_partial) finish it.

        True when what was written is kept (closed into its file, or ended on stdout).
        """
        if self.keep_partial if keep is None else keep:
            try:
                self.close()
                return True
            except Exception:  # noqa: BLE001 - closing after a failure must not hide it
                pass
        writer, self._writer = self._writer, None
        if writer is not None:
            with contextlib.suppress(Exception):
                writer.close()
        self._discard()
        return False

    def __enter__(self) -> OutputStream:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: object) -> None:
        if exc is None:
            self.close()
        else:
            self.abort(self.keep_partial and self.keeps(exc))

    def keeps(self, exc: BaseException) -> bool:
        """Whether ``keep_partial`` keeps what was written when ``exc`` ends the writing.

        Kept for every ending but bad usage or bad input (an error of exit status 2:
        settings, usage, data) and a failure of this output itself: a sibling output's
        failure (an OutputError naming another path, or the pipe downstream closed) keeps
        this one.
        """
        if isinstance(exc, OutputError):
            return exc.path != self.path
        if isinstance(exc, BrokenPipeError) or (isinstance(exc, OSError)
                                                and exc.errno == errno.EPIPE):
            return self.path is not None  # the closed pipe is stdout, not this file
        return not (isinstance(exc, EncError) and exc.exit_code == 2)


def write_table(path: str | None, header: Header, table: pa.Table, force: bool = False,
                fmt: str | None = None, group: files.OutputGroup | None = None,
                unit: str | None = None) -> None:
    """Write a whole table as one stream (a named file renamed with ``group``'s others;
    the angle errors of a CSV or TSV table in ``unit``, arcsec unless given)."""
    with OutputStream(path, header, force=force, fmt=fmt, group=group, unit=unit) as out:
        out.write(table)
