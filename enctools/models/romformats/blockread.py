"""Memory tables read a block at a time: what a file claims checked first, then its words
read through one buffer of :data:`READ` bytes, never the whole file at once.

A table as this project writes it (a binary image; MIF, COE, ``$readmemh`` text of one
word a line, every line of one length; CSV ``address,correction``; Intel HEX) is read
from its first and last few KiB (the header, where the lines start and end), then a
block of lines at a time (Intel HEX: of records in order): :func:`blocks` yields its
words in address order. ``enc correct`` reads a table so (:func:`read_words`, the words
kept in the table's own word size), and ``enc make-rom``'s verification compares each
block with the table built (:func:`same_words`), so neither holds the file's text. A
file in any other layout (ranges, comments between words, Intel HEX out of order, a
controller's program) is read whole by its format's readers, as before
(:func:`~enctools.models.romformats.read_table`).

Before anything the size of is allocated, :func:`claimed_entries` reads what the file
claims (a binary image's length in words, a MIF's ``DEPTH``) and :func:`check_entries`
holds it to the code's addresses and to :data:`MAX_TABLE_BITS`: one line naming the
file and both figures.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator
from typing import Any

import numpy as np

from enctools.data import files
from enctools.errors import DataError
from enctools.models.romformats.columns import Rows
from enctools.models.romformats.words import MAX_TABLE_BITS, Target

#: bytes read at once (a block of lines, whole lines only): the tables of 2^20 entries
#: (2 MB a binary image of 16-bit words, 10-16 MB of text) already read in blocks of this
#: size, so that what a table's reading holds is the same for every larger table
READ = 1 << 20
#: bytes of a file's start and end read to find its layout
HEAD = 1 << 16


class NotInLayout(Exception):
    """A file that left the layout its start promised: read it whole instead."""


def claimed_entries(path: str, t: Target) -> int | None:
    """The entries a table file claims before its words are read: a binary image's length
    in words (DataError when it is not whole words), a MIF's ``DEPTH`` (DataError when
    ``WIDTH`` is not 1..32 bits); None for a format whose entries are its lines."""
    if t.fmt == "bin":
        size = _size(path)
        if size % t.storage_bytes:
            msg = f"{path}: {size} bytes is not a whole number of {t.storage_bytes}-byte words"
            raise DataError(msg)
        return size // t.storage_bytes
    if t.fmt != "mif":
        return None
    keys = _mif_keys(_mif_head(_head(path))[0])
    try:
        width = int(keys.get(b"WIDTH", b"16"))
        depth = int(keys[b"DEPTH"])
    except (KeyError, ValueError):
        return None  # the reader names what is missing
    if not 1 <= width <= 32:
        msg = f"{path}: WIDTH={width} bits, not a word of 1..32 bits"
        raise DataError(msg)
    return depth


def check_entries(path: str, t: Target, code_bits: int | None) -> None:
    """Refuse (DataError, one line naming the file and both figures) a table file that
    claims more entries than a ``code_bits``-bit code has addresses, or than the
    2^:data:`MAX_TABLE_BITS` a table may have, before anything of that size is allocated."""
    n = claimed_entries(path, t)
    if n is not None:
        _check_count(path, t, n, code_bits)


def _check_count(path: str, t: Target, n: int, code_bits: int | None) -> None:
    """:func:`check_entries` of ``n`` entries, claimed or counted."""
    what = f"DEPTH={n} entries" if t.fmt == "mif" else f"{n} entries"
    if code_bits is not None and code_bits <= MAX_TABLE_BITS and n > 1 << code_bits:
        msg = (f"{path}: {what} do not address a {code_bits}-bit code, more than its "
               f"2^{code_bits} = {1 << code_bits} addresses; check `code_bits`"
               + (", `width`" if t.fmt == "bin" else ""))
        raise DataError(msg)
    if n > 1 << MAX_TABLE_BITS:
        msg = (f"{path}: {what}, more than the 2^{MAX_TABLE_BITS} = {1 << MAX_TABLE_BITS} "
               f"a table may have")
        raise DataError(msg)


def head(path: str, size: int = HEAD) -> bytes:
    """The first ``size`` bytes of a file (DataError, one line, when it cannot be read)."""
    with files.open_to_read(path) as f:
        return f.read(size)


_head = head


def _size(path: str) -> int:
    with files.open_to_read(path) as f:
        return os.fstat(f.fileno()).st_size


def _tail(path: str, size: int = 4096) -> tuple[int, bytes]:
    """The offset of the file's last ``size`` bytes, and those bytes."""
    with files.open_to_read(path) as f:
        end = f.seek(0, os.SEEK_END)
        at = max(0, end - size)
        f.seek(at)
        return at, f.read()


def _mif_head(data: bytes) -> tuple[bytes, int]:
    """A MIF's settings before CONTENT (comments removed) and the offset of the line after
    ``CONTENT BEGIN`` (-1 when ``data`` does not reach it)."""
    begin = data.find(b"BEGIN")
    while begin >= 0 and b"--" in data[data.rfind(b"\n", 0, begin) + 1:begin]:  # a comment's
        begin = data.find(b"BEGIN", begin + 5)
    if begin < 0:
        return re.sub(rb"%[^%]*%", b"", re.sub(rb"--[^\n]*", b"", data)), -1
    head = re.sub(rb"%[^%]*%", b"", re.sub(rb"--[^\n]*", b"", data[:begin]))
    start = data.find(b"\n", begin) + 1
    if not re.search(rb"CONTENT\s*$", head) or start <= 0 or data[begin + 5:start].strip():
        return head, -1
    return head, start


def _mif_keys(head: bytes) -> dict[bytes, bytes]:
    """The ``KEY = value;`` settings of a MIF header, keys and values upper-case."""
    return {k.strip().upper(): v.strip().upper()
            for k, v in re.findall(rb"(\w+)\s*=\s*([^;]+);", head)}


def _lines(path: str, start: int, stop: int, width: int) -> Iterator[tuple[int, Rows]]:
    """(first line, lines) of the lines of ``width`` bytes from byte ``start`` to ``stop``,
    read a block at a time into one buffer (each block's newlines checked)."""
    n = (stop - start) // width
    per = max(1, READ // width)
    buf = bytearray(min(n, per) * width)
    with files.open_to_read(path) as f:
        f.seek(start)
        for k in range(0, n, per):
            m = min(per, n - k)
            view = memoryview(buf)[:m * width]
            if f.readinto(view) != m * width:
                raise NotInLayout
            rows = Rows(buf, 0, m, width)  # type: ignore[arg-type]
            if not (rows.word(width - 1, 1) == 10).all():
                raise NotInLayout
            yield k, rows


def _hex_column(path: str, start: int, stop: int, first: bytes, value: tuple[int, int],
                width: int, fixed: list[tuple[int, int]], address: tuple[int, int] | None
                ) -> Iterator[np.ndarray]:
    """The words of lines like ``first`` from ``start`` to ``stop``: the hex digits at
    ``value``, the columns ``fixed`` as in ``first``, the hex at ``address`` counting 0, 1, 2..."""
    w = len(first)
    for k, rows in _lines(path, start, stop, w):
        for a, b in fixed:
            if a < b and not (rows.same(a, b) and bytes(rows.line(0)[a:b]) == first[a:b]):
                raise NotInLayout
        if address is not None:
            got = rows.hex_block(*address, 64)
            if got is None or not np.array_equal(got, np.arange(k, k + rows.n)):
                raise NotInLayout
        words = rows.hex_block(*value, width)
        if words is None:
            raise NotInLayout
        yield words


def blocks(path: str, t: Target) -> tuple[int, Iterator[np.ndarray]] | None:
    """The entries of a table file in one of the layouts this project writes, and its
    words [LSB] in address order a block at a time; None when its start is not in one
    (the iterator raises :class:`NotInLayout` when a later line leaves it)."""
    if t.fmt == "bin":
        return _bin_blocks(path, t)
    finder = {"mif": _mif_layout, "coe": _coe_layout, "mem": _mem_layout,
              "csv": _csv_layout, "ihex": _ihex_layout}.get(t.fmt)
    found = None if finder is None else finder(path, t)
    # every entry takes a byte of the file at least: a size read from a record (Intel HEX's
    # last address) is believed only that far
    return None if found is None or found[0] > _size(path) else found


def _bin_blocks(path: str, t: Target) -> tuple[int, Iterator[np.ndarray]]:
    n = claimed_entries(path, t) or 0

    def words() -> Iterator[np.ndarray]:
        per = READ // t.storage_bytes
        buf = np.empty(min(n, per), dtype=t.image_dtype)
        with files.open_to_read(path) as f:
            for k in range(0, n, per):
                part = buf[:min(per, n - k)]
                if f.readinto(part.view(np.uint8).data) != part.nbytes:
                    raise NotInLayout
                yield part

    return n, words()


def _mif_layout(path: str, t: Target) -> tuple[int, Iterator[np.ndarray]] | None:
    data = _head(path)
    head, start = _mif_head(data)
    keys = _mif_keys(head)
    if start < 0 or keys.get(b"ADDRESS_RADIX", b"HEX") != b"HEX" or \
            keys.get(b"DATA_RADIX", b"HEX") != b"HEX":
        return None
    try:
        width, depth = int(keys[b"WIDTH"]), int(keys[b"DEPTH"])
    except (KeyError, ValueError):
        return None
    at, tail = _tail(path)
    end = at + tail.rfind(b"END")
    nl = data.find(b"\n", start)
    if nl < 0 or end < start or depth == 0:
        return None
    first = data[start:nl + 1]
    m = re.fullmatch(rb"(\s*)([0-9A-Fa-f]+)(\s*:\s*)([0-9A-Fa-f]+)(\s*;\s*)", first)
    if m is None or (end - start) % len(first) or (end - start) // len(first) != depth \
            or tail[end - at:].strip() not in (b"END;", b"END"):
        return None
    fixed = [m.span(g) for g in (1, 3, 5)]
    return depth, _hex_column(path, start, end, first, m.span(4), width, fixed, m.span(2))


def _coe_layout(path: str, t: Target) -> tuple[int, Iterator[np.ndarray]] | None:
    data = _head(path)
    m = re.compile(rb"(?m)^memory_initialization_radix=16;\r?\n"
                   rb"memory_initialization_vector=\r?\n").search(data)
    if m is None or re.search(rb"(?m)^[ \t]*[^;\s]", data[:m.start()]):
        return None  # anything but comment lines before the radix: read whole
    start = m.end()
    at, tail = _tail(path)
    end = at + tail.rstrip().rfind(b"\n") + 1
    nl = data.find(b"\n", start)
    last = re.fullmatch(rb"([0-9A-Fa-f]{1,8});\n", tail[end - at:])
    if nl < 0 or last is None or end <= start:
        return None
    first = data[start:nl + 1]
    line = re.fullmatch(rb"([0-9A-Fa-f]{1,8})(,\n)", first)
    if line is None or (end - start) % len(first):
        return None
    rows = (end - start) // len(first)
    final = _one_hex(last.group(1), t.width)

    def words() -> Iterator[np.ndarray]:
        yield from _hex_column(path, start, end, first, line.span(1), t.width,
                               [line.span(2)], None)
        yield final

    return rows + 1, words()


def _one_hex(text: bytes, width: int) -> np.ndarray:
    from enctools.models.romformats.words import signed

    return signed(np.array([int(text, 16)], dtype=np.uint64), width)


def _mem_layout(path: str, t: Target) -> tuple[int, Iterator[np.ndarray]] | None:
    data = _head(path)
    pos = 0
    while data.startswith(b"//", pos):
        pos = data.find(b"\n", pos) + 1
        if pos == 0:
            return None
    if not data.startswith(b"@0\n", pos):
        return None
    start = pos + 3
    nl = data.find(b"\n", start)
    size = _size(path)
    first = data[start:nl + 1]
    line = re.fullmatch(rb"([0-9A-Fa-f]{1,8})(\n)", first)
    if nl < 0 or line is None or (size - start) % len(first):
        return None
    return (size - start) // len(first), _hex_column(path, start, size, first, line.span(1),
                                                     t.width, [], None)


def _csv_layout(path: str, t: Target) -> tuple[int, Iterator[np.ndarray]] | None:
    """A CSV table without comment lines: its lines counted a block at a time (the
    entries), then read by Arrow's streaming reader a block at a time."""
    if not _head(path, 64).startswith(b"address,correction\n"):
        return None
    lines = 0
    with files.open_to_read(path) as f:
        while chunk := f.read(READ):
            lines += chunk.count(b"\n")
    return lines - 1, _csv_words(path, t)


def _pieces(path: str, skip_line: bool = False, size: int | None = None) -> Iterator[bytes]:
    """The file's text a block of whole lines at a time (about ``size`` bytes, default
    :data:`READ`), its first line left out if ``skip_line``."""
    rest = b""
    with files.open_to_read(path) as f:
        if skip_line:
            f.readline()
        while True:
            chunk = f.read(size or READ)
            text = rest + chunk
            cut = text.rfind(b"\n") + 1 if chunk else len(text)
            text, rest = text[:cut], text[cut:]
            if not text:
                return
            yield text


def _csv_words(path: str, t: Target) -> Iterator[np.ndarray]:
    """The corrections of a CSV table, a block of whole lines at a time, each block read by
    Arrow's CSV reader (its streaming reader holds far more than its block size)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    types = {"address": pa.int64(), "correction": pa.int64()}
    # one thread: Arrow's pool left running could abort the interpreter at exit
    read = pcsv.ReadOptions(use_threads=False, column_names=list(types))
    convert = pcsv.ConvertOptions(column_types=types)
    done = 0
    # the header checked by the caller; a quarter block: Arrow's pool keeps what it freed
    for text in _pieces(path, skip_line=True, size=max(1, READ // 4)):
        try:
            batch = pcsv.read_csv(pa.py_buffer(text), read, convert_options=convert)
        except (pa.ArrowInvalid, ValueError):
            raise NotInLayout from None
        a = batch.column(0).to_numpy()
        if batch.column(1).null_count or not np.array_equal(a, np.arange(done, done + a.size)):
            raise NotInLayout
        done += a.size
        yield batch.column(1).to_numpy()


def _ihex_layout(path: str, t: Target) -> tuple[int, Iterator[np.ndarray]] | None:
    """Intel HEX that starts with an extended linear address record: its image's size from
    the last data record after the last such record in the file's last 256 KiB."""
    if not _head(path, 16).startswith(b":02000004"):
        return None
    at, tail = _tail(path, 1 << 18)
    upper, end = None, None
    for line in tail.split(b"\n")[1 if at else 0:]:
        line = line.strip()
        try:
            rec = bytes.fromhex(line[1:].decode("ascii"))
        except (ValueError, UnicodeDecodeError):
            return None
        if len(rec) < 5:
            continue
        if rec[3] == 4 and len(rec) == 7:
            upper = int.from_bytes(rec[4:6], "big") << 16
        elif rec[3] == 0 and upper is not None:
            end = upper + ((rec[1] << 8) | rec[2]) + rec[0]
    if end is None or end % t.storage_bytes:
        return None
    return end // t.storage_bytes, _ihex_words(path, t)


def _ihex_words(path: str, t: Target) -> Iterator[np.ndarray]:
    """The words of Intel HEX whose data records run in order without gaps (types 00, 04
    and the end, 01, last), a block of whole records at a time."""
    from enctools.models.romformats.readers import ihex_records

    upper, expect, carry, ended = 0, 0, b"", False
    for text in _pieces(path, size=max(1, READ // 4)):  # decoded in a few copies of it
        found = ihex_records(text)
        if found is None or ended:
            raise NotInLayout
        rec, off = found
        length, rtype = rec[off].astype(np.int64), rec[off + 3]
        eof = np.flatnonzero(rtype == 1)
        ended = eof.size > 0
        if not np.isin(rtype, (0, 1, 4)).all() or eof.size > 1 or \
                (ended and eof[0] != rtype.size - 1):
            raise NotInLayout
        ext = np.flatnonzero(rtype == 4)
        if (length[ext] != 2).any():
            raise NotInLayout
        high = np.full(rtype.size, upper, dtype=np.int64)
        high[ext] = ((rec[off[ext] + 4].astype(np.int64) << 8) | rec[off[ext] + 5]) << 16
        last = np.maximum.accumulate(np.where(rtype == 4, np.arange(rtype.size), -1))
        high = np.where(last >= 0, high[np.maximum(last, 0)], upper)
        if ext.size:
            upper = int(high[ext[-1]])
        data = np.flatnonzero(rtype == 0)
        at = off[data]
        addr = high[data] + ((rec[at + 1].astype(np.int64) << 8) | rec[at + 2])
        n = length[data]
        if data.size and (addr[0] != expect or (addr[1:] != addr[:-1] + n[:-1]).any()):
            raise NotInLayout
        expect += int(n.sum())
        keep = np.zeros(rec.size + 1, dtype=np.int8)  # as readers.fast_ihex
        keep[at + 4] = 1
        keep[at + 4 + n] = -1
        image = carry + rec[np.cumsum(keep[:-1], dtype=np.int8).astype(bool)].tobytes()
        whole = len(image) - len(image) % t.storage_bytes
        carry = image[whole:]
        yield np.frombuffer(image[:whole], dtype=t.image_dtype)
    if not ended or carry:
        raise NotInLayout


def _dtype(t: Target) -> np.dtype:
    return np.dtype(f"i{t.storage_bytes}")


def read_words(path: str, t: Target, code_bits: int | None = None) -> np.ndarray | None:
    """The words [LSB] of a table file in a layout this project writes, read a block at a
    time into an array of the table's word size (1, 2 or 4 bytes an entry); None when the
    file is in another layout (read it whole). Its entries (a CSV's, COE's or MEM's lines
    counted) are held to a ``code_bits``-bit code's addresses before they are allocated
    (DataError, :func:`check_entries`)."""
    found = blocks(path, t)
    if found is None:
        return None
    n, words = found
    if n < 0:
        return None
    _check_count(path, t, n, code_bits)
    dtype = _dtype(t)
    lo, hi = np.iinfo(dtype).min, np.iinfo(dtype).max
    out = np.empty(n, dtype=dtype)
    k = 0
    try:
        for block in words:
            if k + block.size > n or (block.size and (block.min() < lo or block.max() > hi)):
                return None
            out[k:k + block.size] = block
            k += block.size
    except NotInLayout:
        return None
    return out if k == n else None


def same_words(path: str, t: Target, values: Any) -> bool | None:
    """Whether a table file holds ``values`` [LSB] (an array, or a table sliced a block at a
    time), read a block at a time; None when the file is in another layout."""
    found = blocks(path, t)
    if found is None:
        return None
    n, words = found
    if n != len(values):
        return False
    # compared in pieces within one of the table's own blocks: no slice of it is joined
    step = getattr(values, "block", None) or max(n, 1)
    k = 0
    try:
        for block in words:
            if k + block.size > n:
                return False
            a = 0
            while a < block.size:
                b = min(block.size, a + step - (k + a) % step)
                if not np.array_equal(block[a:b], values[k + a:k + b]):
                    return False
                a = b
            k += block.size
    except NotInLayout:
        return None
    return k == n
