"""Writers of correction tables: one function per format, each writing a whole file.

The text tables (MIF, COE, MEM, Intel HEX, CSV) are written a block of lines at a time
from one buffer whose constant bytes (separators, line ends, the address digits that
repeat every block) are set once: a block then costs a table look-up of digits per 16
bits of its words, stored straight into the lines, and one write. A correction table's
values change slowly, so most blocks are a few runs of equal words (in CSV also: of lines
of one length), each stored whole; a block of many runs is written line by line, with
the same bytes. COE and MEM, whose lines hold no address, write a run as one buffer of a
few thousand of its lines listed as often as the run needs in one ``os.writev``; Intel HEX
repeats a run of equal records' digits as one 32-byte item. Every write but a file's last
ends at a whole page of the file (:class:`_Gather`). Nothing grows with the table but the
table (and a binary image or Intel HEX in the other byte order than the table's: its
image). CSV of values over 16 bits and the controllers' tables are formatted by Arrow's
CSV writer and string kernels, a block at a time. Every writer takes an open binary file
(a real one: most write to its descriptor), the signed values [LSB] (one per address), the
:class:`~enctools.models.romformats.words.Target` and the comment
lines to put at the top where the format has comments.
"""

from __future__ import annotations

import mmap
import os
import sys
from typing import IO

import numpy as np

from enctools.models.romformats.words import Target, comment_text, twos

_HEX = np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)


_HEX_TABLES: dict[int, np.ndarray] = {}


def _hex_tables() -> dict[int, np.ndarray]:
    """ASCII upper-case hex of every 4-, 8- and 16-bit value: {digits: uint8/16/32 words}
    (and, at 0, of every two bytes)."""
    if not _HEX_TABLES:
        k = np.arange(1 << 16)
        digits = np.ascontiguousarray(np.stack([_HEX[(k >> s) & 15] for s in (12, 8, 4, 0)], 1))
        _HEX_TABLES[4] = digits.view(np.uint32).reshape(-1)
        _HEX_TABLES[2] = np.ascontiguousarray(digits[:256, 2:]).view(np.uint16).reshape(-1)
        _HEX_TABLES[1] = _HEX.copy()
        # 0: the four digits of two bytes in memory order, by the bytes read as '<u2'
        _HEX_TABLES[0] = _HEX_TABLES[4][((k & 0xFF) << 8) | (k >> 8)]
    return _HEX_TABLES


#: lines a block: 16^4, so that the low four hex digits of an address repeat every block
#: (about 1 MB of MIF text, which stays in the CPU's cache until written)
LINES = 1 << 16
#: runs of equal words (or, in CSV, of lines of one length) in a block below which each run
#: is written whole rather than line by line (a correction table's values change slowly:
#: the table-1 model's 1680 times in 2^26 addresses, runs of some 40 000 lines)
RUNS = 64


def _column(lines: np.ndarray, col: int, dtype: type | np.dtype, shape: tuple[int, ...] = (),
            strides: tuple[int, ...] = ()) -> np.ndarray:
    """A word of ``dtype`` at byte ``col`` of every line of ``lines`` (m, w) uint8 (a view;
    ``shape``/``strides`` add axes after the line's, e.g. 16 words 2 bytes apart)."""
    m, w = lines.shape
    return np.ndarray((m, *shape), dtype, buffer=lines, offset=col, strides=(w, *strides))


def _put_bytes(lines: np.ndarray, col: int, text: bytes) -> None:
    """The same bytes at ``col`` in every line: whole words copied from a contiguous column
    (numpy's strided fill of an unaligned scalar is several times slower)."""
    m = lines.shape[0]
    while text:
        size = 8 if len(text) >= 8 else 4 if len(text) >= 4 else 2 if len(text) >= 2 else 1
        dt = np.dtype(f"u{size}")
        np.copyto(_column(lines, col, dt), np.full(m, np.frombuffer(text[:size], dt)[0]))
        text, col = text[size:], col + size


def _put_hex(lines: np.ndarray, col: int, u: np.ndarray, digits: int) -> None:
    """Upper-case hex of the unsigned words ``u`` (each < 16^digits), ``digits`` wide, at
    ``col`` of every line: 4, 2 or 1 digits a look-up, stored into the lines directly."""
    tables = _hex_tables()
    left = digits
    while left:
        size = 4 if left >= 4 else 2 if left >= 2 else 1
        piece = u >> (4 * (left - size)) if left > size else u
        if left < digits:  # the digits above this piece are in the pieces before
            piece = piece & ((1 << (4 * size)) - 1)
        np.take(tables[size], piece, out=_column(lines, col, tables[size].dtype), mode="clip")
        left, col = left - size, col + size


def _comments(comment: list[str], prefix: str, ascii_only: bool = False,
              reserved: str = "") -> str:
    """The comment lines, each ``prefix`` + :func:`~.words.comment_text` + newline: nothing
    in them can end the comment or start a line of program or table."""
    return "".join(f"{prefix}{comment_text(c, ascii_only, reserved)}\n" for c in comment)


def write_bin(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Raw two's-complement words, 1, 2 or 4 bytes each, in the target's byte order."""
    values.astype(t.image_dtype, copy=False).tofile(f)


#: Intel HEX: data bytes a record, a segment (the 64 KiB a type 04 record addresses), the
#: text of a full data record (":10AAAA00" 32 digits of data, 2 of checksum, newline), of
#: a type 04 record, and the segments a block
IHEX_DATA, IHEX_SEGMENT, IHEX_LINE, IHEX_EXT, IHEX_SEGMENTS = 16, 1 << 16, 44, 16, 8


def write_ihex(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Intel HEX of the raw image: 16 data bytes a record, a type 04 record every 64 KiB."""
    image = np.ascontiguousarray(values.astype(t.image_dtype, copy=False)).view(np.uint8)
    full = image.size // IHEX_SEGMENT
    if full:
        _ihex_segments(f, image[:full * IHEX_SEGMENT])
    base = full * IHEX_SEGMENT
    if base < image.size:  # the last segment, in part: its records one by one
        f.write(_ihex_record(4, 0, [(base >> 24) & 0xFF, (base >> 16) & 0xFF]))
        rest = image[base:]
        f.write(b"".join(_ihex_record(0, a, rest[a:a + IHEX_DATA].tolist())
                         for a in range(0, rest.size, IHEX_DATA)))
    f.write(b":00000001FF\n")


def _ihex_segments(f: IO[bytes], image: np.ndarray) -> None:
    """Whole 64 KiB segments of the image (uint8), IHEX_SEGMENTS a block: the records'
    lengths, addresses, types and newlines are the same in every segment and set once."""
    records = IHEX_SEGMENT // IHEX_DATA
    seg_text = IHEX_EXT + records * IHEX_LINE
    block = np.empty((min(IHEX_SEGMENTS, image.size // IHEX_SEGMENT), seg_text), np.uint8)
    addr = np.arange(0, IHEX_SEGMENT, IHEX_DATA, dtype=np.uint32)
    for segment in block:
        lines = segment[IHEX_EXT:].reshape(-1, IHEX_LINE)  # a view: the row is contiguous
        _put_bytes(lines, 0, b":10")
        _put_hex(lines, 3, addr, 4)
        _put_bytes(lines, 7, b"00")
        _put_bytes(lines, IHEX_LINE - 1, b"\n")
    # a record's checksum is this, less its data bytes' sum (mod 256)
    checks = ((-(IHEX_DATA + (addr >> 8) + (addr & 0xFF))) & 0xFF).astype(np.uint8)
    out = _Gather(f)
    for base in range(0, image.size, IHEX_SEGMENT * block.shape[0]):
        data = image[base:base + IHEX_SEGMENT * block.shape[0]].reshape(-1, records, IHEX_DATA)
        for j in range(data.shape[0]):
            at = base + j * IHEX_SEGMENT
            block[j, :IHEX_EXT] = np.frombuffer(
                _ihex_record(4, 0, [(at >> 24) & 0xFF, (at >> 16) & 0xFF]), np.uint8)
        text = block[:data.shape[0]]
        _ihex_data(text, data, checks)
        out.add(text.reshape(-1).data)
        out.flush()  # before the block is used again
    out.flush(whole=True)


def _ihex_data(text: np.ndarray, data: np.ndarray, checks: np.ndarray) -> None:
    """The data digits and checksums of the records of whole segments ``data`` (segments,
    records, 16) uint8 into their text (segments, its bytes): the 32 digits of each run of
    equal records, as a table's slowly changing values give, formatted once and repeated
    as one 32-byte item, or every record's looked up 16 bits at a time; the checksums
    looked up for every record at once. ``checks``: each record's checksum were its data
    bytes all 0 (uint8)."""
    segs, records, _ = data.shape
    flat = data.reshape(-1, IHEX_DATA)
    words = flat.view(np.uint64)
    new = np.ones(words.shape[0], bool)  # where a run of equal records starts
    np.not_equal(words[1:, 0], words[:-1, 0], out=new[1:])
    new[1:] |= words[1:, 1] != words[:-1, 1]
    heads = np.flatnonzero(new)
    if heads.size >= RUNS * segs:
        np.take(_hex_tables()[0], data.view("<u2"), mode="clip",
                out=_column(text, IHEX_EXT + 9, np.uint32, (records, IHEX_DATA // 2),
                            (IHEX_LINE, 4)))
        sums = _byte_sums(flat).astype(np.uint8)
    else:
        item = np.dtype(f"V{2 * IHEX_DATA}")
        lengths = np.diff(heads, append=flat.shape[0])
        digits = np.frombuffer(flat[heads].tobytes().hex().upper().encode(), item)
        np.copyto(_column(text, IHEX_EXT + 9, item, (records,), (IHEX_LINE,)),
                  np.repeat(digits, lengths).reshape(segs, records))
        sums = np.repeat(_byte_sums(flat[heads]).astype(np.uint8), lengths)
    # looked up into a contiguous array, then stored (4x a look-up into the lines)
    index = np.subtract(checks, sums.reshape(segs, records), dtype=np.uint8)
    np.copyto(_column(text, IHEX_EXT + 9 + 2 * IHEX_DATA, np.uint16, (records,), (IHEX_LINE,)),
              np.take(_hex_tables()[2], index))


def _byte_sums(data: np.ndarray) -> np.ndarray:
    """The sum of each record's 16 bytes (..., 16) uint8, as uint32 (..., ): eight bytes at
    a time in 16-bit lanes of a 64-bit word (4x numpy's sum over the last axis)."""
    x = data.view(np.uint64)
    lanes = np.uint64(0x00FF00FF00FF00FF)
    pairs = (x & lanes) + ((x >> np.uint64(8)) & lanes)  # 4 lanes of 2 bytes' sums
    total = pairs[..., 0] + pairs[..., 1]  # each lane <= 1020
    return ((total * np.uint64(0x0001000100010001)) >> np.uint64(48)).astype(np.uint32)


def _ihex_record(rtype: int, addr: int, data: list[int]) -> bytes:
    body = [len(data), (addr >> 8) & 0xFF, addr & 0xFF, rtype, *data]
    body.append((-sum(body)) & 0xFF)
    return b":" + bytes(body).hex().upper().encode() + b"\n"


def _write_words(f: IO[bytes], values: np.ndarray, t: Target, lines: np.ndarray, col: int) -> None:
    """The table's words in hex at ``col`` of the lines, a block of ``lines`` at a time."""
    m = lines.shape[0]
    for start in range(0, values.size, m):
        u = twos(values[start:start + m], t.width)
        block = lines[:u.size]
        cuts = np.flatnonzero(u[1:] != u[:-1]) + 1
        if cuts.size < RUNS:  # a table's values change slowly: each run's word stored whole
            for k0, k1 in zip([0, *cuts.tolist()], [*cuts.tolist(), u.size], strict=True):
                _put_bytes(block[k0:k1], col, f"{int(u[k0]):0{t.hex_digits}X}".encode())
        else:
            _put_hex(block, col, u, t.hex_digits)
        f.write(block.reshape(-1).data)


def write_mif(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Altera/Intel MIF: WIDTH, DEPTH, hex radices, one ``addr : value;`` a line."""
    adig = max(1, (int(values.size - 1).bit_length() + 3) // 4)
    head = _comments(comment, "-- ", reserved="%")  # % opens a block comment
    head += (f"WIDTH={t.width};\nDEPTH={values.size};\n\nADDRESS_RADIX=HEX;\nDATA_RADIX=HEX;\n\n"
             "CONTENT BEGIN\n")
    f.write(head.encode())
    low = min(adig, 4)  # the address digits that repeat every block of LINES
    lines = np.empty((min(values.size, LINES), 1 + adig + 3 + t.hex_digits + 2), np.uint8)
    _put_hex(lines, 1 + adig - low, np.arange(lines.shape[0], dtype=np.uint32), low)
    _put_bytes(lines, 1 + adig, b" : ")
    _put_bytes(lines, lines.shape[1] - 2, b";\n")
    for start in range(0, values.size, LINES):
        top = f"{start // LINES:0{adig - 4}X}" if adig > 4 else ""
        _put_bytes(lines, 0, b"\t" + top.encode())
        _write_words(f, values[start:start + LINES], t, lines, 1 + adig + 3)
    f.write(b"END;\n")


def write_coe(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Xilinx COE, radix 16: one ``value,`` a line, the last ``value;``."""
    head = _comments(comment, "; ")
    f.write((head + "memory_initialization_radix=16;\nmemory_initialization_vector=\n").encode())
    _write_word_lines(f, values[:-1], t, b",\n")
    f.write(f"{int(twos(values[-1:], t.width)[0]):0{t.hex_digits}X};\n".encode())


def write_mem(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Verilog ``$readmemh`` text: ``//`` comments, ``@0``, one hex word a line."""
    f.write(_comments(comment, "// ", reserved="*").encode())  # no /* or */
    f.write(b"@0\n")
    _write_word_lines(f, values, t, b"\n")


#: lines of one word's text that a run of that word is written from, the same buffer again
#: and again in one system call (24 KiB of COE's 16-bit words: stays in the CPU's cache)
RUN_LINES = 4096


def _write_word_lines(f: IO[bytes], values: np.ndarray, t: Target, end: bytes) -> None:
    """The table's words in hex, each followed by ``end``, a block of :data:`LINES` at a
    time: a block of few runs of equal words as each run's text, :data:`RUN_LINES` lines of
    it formatted once and written as often as the run needs (``os.writev``); a block of
    many runs formatted line by line into one buffer."""
    if not values.size:
        return
    width = t.hex_digits + len(end)
    lines = np.empty((min(values.size, LINES), width), np.uint8)
    _put_bytes(lines, t.hex_digits, end)
    out = _Gather(f)
    for start in range(0, values.size, LINES):
        u = twos(values[start:start + LINES], t.width)
        cuts = np.flatnonzero(u[1:] != u[:-1]) + 1
        if cuts.size < RUNS:  # a table's values change slowly
            for k0, k1 in zip([0, *cuts.tolist()], [*cuts.tolist(), u.size], strict=True):
                line = f"{int(u[k0]):0{t.hex_digits}X}".encode() + end
                text = line * min(k1 - k0, RUN_LINES)
                whole, part = divmod(k1 - k0, RUN_LINES)
                out.add(*[text] * whole, memoryview(text)[:part * width])
        else:
            block = lines[:u.size]
            _put_hex(block, 0, u, t.hex_digits)
            out.add(block.reshape(-1).data)
        out.flush()  # before the block's buffer is used again
    out.flush(whole=True)


class _Gather:
    """Buffers written to a file in order, in as few system calls as ``os.writev`` allows:
    the same bytes written several times are one buffer listed several times. Every write
    but the last ends at a whole page of the file (the kernel copies a page-aligned write
    some 15 % faster): the bytes past it, less than a page, are kept (copied) for the next.
    ``flush(whole=True)`` writes what is left."""

    def __init__(self, f: IO[bytes]) -> None:
        f.flush()  # what the file object holds goes first
        self.fd = f.fileno()
        self.at = f.tell()  # the file's size [byte]
        self.parts: list[memoryview] = []
        self.most = os.sysconf("SC_IOV_MAX")

    def add(self, *parts: bytes | memoryview) -> None:
        """Buffers to write after those added before (none is changed until flushed)."""
        self.parts += [memoryview(p).cast("B") for p in parts if len(p)]

    def flush(self, whole: bool = False) -> None:
        """Write the buffers added, to the last whole page of the file (``whole``: every
        byte)."""
        size = sum(p.nbytes for p in self.parts)
        cut = size if whole else size - (self.at + size) % mmap.PAGESIZE
        head: list[memoryview] = []
        for k, p in enumerate(self.parts):
            if cut - p.nbytes < 0:  # the bytes from ``cut`` on are kept
                head.append(p[:cut])
                self.parts = [memoryview(b"".join([p[cut:], *self.parts[k + 1:]]))]
                break
            head.append(p)
            cut -= p.nbytes
        else:
            self.parts = []
        i = 0
        while i < len(head):  # a write may take fewer bytes than asked
            done = os.writev(self.fd, head[i:i + self.most])
            self.at += done
            while i < len(head) and done >= head[i].nbytes:
                done -= head[i].nbytes
                i += 1
            if done:
                head[i] = head[i][done:]


def write_csv(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """``address,correction`` in decimal, the header line first: no comment lines, which
    pandas, Miller and csvkit would take for the header (``comment`` is left out)."""
    f.write(b"address,correction\n")
    short = min(values.size, CSV_SHORT)  # addresses of 1..4 digits: a few lines, one by one
    f.write("".join(f"{k},{v}\n" for k, v in enumerate(values[:short].tolist())).encode())
    if values.size == short:
        return
    if not _fit_16_bits(values):  # no table of every value's text: Arrow's, a block at a time
        import pyarrow as pa
        import pyarrow.csv as pcsv
        for start in range(short, values.size, LINES):
            v = values[start:start + LINES]
            pcsv.write_csv(pa.table({"address": pa.array(np.arange(start, start + v.size)),
                                     "correction": pa.array(v.astype(np.int64))}),
                           f, pcsv.WriteOptions(include_header=False))
        return
    out = _Gather(f)
    for d in range(5, len(str(values.size - 1)) + 1):  # the addresses of d digits, by blocks
        lines = _CsvLines(d)
        for start in range(max(short, 10 ** (d - 1)), min(values.size, 10 ** d), LINES):
            out.add(lines.text(start, values[start:min(start + LINES, 10 ** d)]))
            out.flush()  # before the block's buffer is used again
    out.flush(whole=True)


def _fit_16_bits(values: np.ndarray) -> bool:
    """Whether every value is a signed 16-bit word's (a table's up to 16 bits wide)."""
    if values.dtype.itemsize <= 2:
        return True
    return bool(values.min() >= -(1 << 15) and values.max() < 1 << 15)


#: CSV lines whose address has fewer than 5 digits are formatted one by one
CSV_SHORT = 10_000


class _CsvLines:
    """CSV lines ``address,value`` of one block, addresses of ``d`` digits (5..9) and values
    of 16-bit words, whose text and newline come from a table of every 16-bit value.

    A table's values change slowly (the table-1 model's 1680 times in 2^26 addresses, their
    lengths 32 times), so a block is a few runs of one value, at most 100 000 addresses
    each: a run is a fixed-width table written in place like MIF's, its columns stored
    whole. A block of many values but few runs of lines of one length is written so too,
    each line's value looked up. A block of more runs than :data:`RUNS` builds each line
    in a row of :data:`ROW` bytes (4 spare, the address, the comma, the value's text) and
    copies the rows of each length, as items of that many bytes, to where their lines
    start. Nothing depends on the order of the copies within one numpy call."""

    ROW = 24

    def __init__(self, d: int) -> None:
        self.d = d
        self.words, sizes = _decimal_table()
        self.sizes = sizes + d  # a line's length [byte]
        self.fill = np.empty(LINES, np.uint64)  # a run's values, for a contiguous copy
        self.word = np.empty(LINES, np.uint64)  # and its addresses
        self.out = np.empty(LINES * (d + 8) + self.ROW, np.uint8)
        self.rows: np.ndarray | None = None

    def text(self, start: int, values: np.ndarray) -> memoryview:
        """The block's lines, addresses from ``start``, as one buffer."""
        u = twos(values, 16)
        first = -start % 100_000  # the address digits above the last five change there
        fives = np.arange(first if first else 100_000, u.size, 100_000)
        cuts = np.union1d(np.flatnonzero(u[1:] != u[:-1]) + 1, fives)
        if cuts.size < RUNS:  # runs of one value
            return self._runs(start, u, cuts, self.sizes[u[np.r_[0, cuts]]], same=True)
        size = self.sizes[u]
        cuts = np.union1d(np.flatnonzero(size[1:] != size[:-1]) + 1, fives)
        if cuts.size < RUNS:  # runs of lines of one length
            return self._runs(start, u, cuts, size[np.r_[0, cuts]], same=False)
        return self._rows(start, u, size)

    def _runs(self, start: int, u: np.ndarray, cuts: np.ndarray, sizes: np.ndarray,
              same: bool) -> memoryview:
        """:meth:`text` of a block of few runs: each of lines of one length (``sizes``), of
        one value if ``same``."""
        d, at = self.d, 0
        for k0, k1, width in zip([0, *cuts.tolist()], [*cuts.tolist(), u.size], sizes.tolist(),
                                 strict=True):
            n = k1 - k0
            # the comma and value's 8 bytes reach into the next line: stored first,
            # overwritten after
            cv = self.fill[:n]
            if same:
                cv[...] = self.words[u[k0]]
            else:
                np.take(self.words, u[k0:k1], out=cv, mode="clip")
            np.copyto(self._words_at(at + d, np.uint64, n, width), cv)
            self._addresses(at, n, width, start + k0, cv)
            at += n * width
        return self.out[:at].data

    def _addresses(self, at: int, n: int, width: int, first: int, cv: np.ndarray) -> None:
        """The addresses from ``first`` of ``n`` lines of ``width`` bytes from byte ``at``
        of the text, in the 100 000 of one prefix; ``cv``: the lines' comma and value
        words. Of up to 8 digits: one word a line, the address and (after it, to 8 bytes)
        the line's next bytes (words read little-endian); of 9, or on a big-endian machine:
        the prefix, the first four digits and the last."""
        d = self.d
        q, r = divmod(first, 100_000)
        four, one, five = _last_five()
        if d <= 8 and sys.byteorder == "little":
            word = np.left_shift(five[r:r + n], np.uint64(8 * (d - 5)), out=self.word[:n])
            if q:
                word |= np.uint64(int.from_bytes(str(q).encode(), "little"))
            if d < 8:
                word |= cv << np.uint64(8 * d)
            np.copyto(self._words_at(at, np.uint64, n, width), word)
            return
        _put_bytes(self.out[at:at + n * width].reshape(n, width), 0, str(q).encode())
        np.copyto(self._words_at(at + d - 5, np.uint32, n, width), four[r:r + n])
        np.copyto(self._words_at(at + d - 1, np.uint8, n, width), one[r:r + n])

    def _words_at(self, offset: int, dtype: type, count: int, stride: int) -> np.ndarray:
        """``count`` words of ``dtype`` in the block's text from byte ``offset``, ``stride``
        bytes apart (the last may reach past the lines: the text has room)."""
        return np.ndarray((count,), dtype, buffer=self.out, offset=offset, strides=(stride,))

    def _rows(self, start: int, u: np.ndarray, size: np.ndarray) -> memoryview:
        """:meth:`text` of a block of many runs, line by line (as rows)."""
        if self.rows is None:
            self.rows = np.zeros((LINES, self.ROW), np.uint8)
        m, d = u.size, self.d
        rows = self.rows[:m]
        q, r = np.divmod(np.arange(start, start + m, dtype=np.uint32), 10_000)
        dec = _decimal_digits()
        if d == 9:  # q has 5 digits: its first, then its last four
            np.take(dec, q // 10_000, out=_column(rows, 1, np.uint32), mode="clip")
            q = q % 10_000
        np.take(dec, q, out=_column(rows, d - 4, np.uint32), mode="clip")  # left zeros: spare
        np.take(dec, r, out=_column(rows, d, np.uint32), mode="clip")
        np.take(self.words, u, out=_column(rows, 4 + d, np.uint64), mode="clip")
        end = np.cumsum(size, dtype=np.int64)
        first = end - size
        for n in np.flatnonzero(np.bincount(size)):
            at = np.flatnonzero(size == n)
            item = np.dtype(f"V{n}")
            np.ndarray((self.out.size - n + 1,), item, buffer=self.out, strides=(1,))[
                first[at]] = np.ndarray((m,), item, buffer=rows, offset=4, strides=(self.ROW,))[at]
        return self.out[:int(end[-1])].data


_DECIMAL_TABLE: list[np.ndarray] = []


def _decimal_table() -> tuple[np.ndarray, np.ndarray]:
    """A comma, the text of every 16-bit two's complement word's value and a newline,
    zero-padded to 8 bytes (uint64, indexed by the word), and its length [byte] (uint8).

    Built as little-endian numbers, whose first byte is the lowest: the five digits with
    leading zeros shifted down past the zeros, the newline put after them, shifted up
    past the comma and the sign."""
    if not _DECIMAL_TABLE:
        value = np.arange(1 << 16, dtype=np.int32)
        value[1 << 15:] -= 1 << 16
        mag = np.abs(value)
        digits = 1 + sum((mag >= 10 ** p).astype(np.int32) for p in range(1, 5))
        neg = (value < 0).astype(np.uint64)
        five = sum((ord("0") + (mag // 10 ** (4 - k)) % 10).astype(np.uint64) << np.uint64(8 * k)
                   for k in range(5))
        nd = digits.astype(np.uint64)
        word = (five >> (np.uint64(8) * (np.uint64(5) - nd))) | (np.uint64(10) << np.uint64(8) * nd)
        word = (word << (np.uint64(8) * (np.uint64(1) + neg))) | np.uint64(ord(",")) \
            | (neg * np.uint64(ord("-") << 8))
        size = 1 + digits + (value < 0) + 1  # the comma, the sign, the digits, the newline
        _DECIMAL_TABLE.extend([word.astype("<u8").view(np.uint64), size.astype(np.uint8)])
    return _DECIMAL_TABLE[0], _DECIMAL_TABLE[1]


_DECIMAL: list[np.ndarray] = []


_LAST_FIVE: list[np.ndarray] = []


def _last_five() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The five decimal digits of 0..99 999, with leading zeros: the first four as uint32
    words, the last as uint8, and all five in the low bytes of uint64 words."""
    if not _LAST_FIVE:
        k = np.arange(100_000)
        four, one = _decimal_digits()[k // 10], (ord("0") + k % 10).astype(np.uint8)
        five = four.astype(np.uint64) | (one.astype(np.uint64) << np.uint64(32))
        _LAST_FIVE.extend([four, one, five])
    return _LAST_FIVE[0], _LAST_FIVE[1], _LAST_FIVE[2]


def _decimal_digits() -> np.ndarray:
    """The four decimal digits of 0..9999, with leading zeros, as uint32 words."""
    if not _DECIMAL:
        k = np.arange(10_000)[:, None] // np.array([1000, 100, 10, 1]) % 10
        _DECIMAL.append((ord("0") + k).astype(np.uint8).view(np.uint32).reshape(-1))
    return _DECIMAL[0]


def _closed(values: np.ndarray) -> np.ndarray:
    """The table with its first value repeated at 360 deg (rotary tables)."""
    return np.append(values, values[:1])


def _decimal_text(steps: np.ndarray, decimals: int) -> object:
    """Whole numbers of 10^-decimals as decimal text with exactly ``decimals`` digits after
    the point (an Arrow string array), from the integers: no binary fraction is printed."""
    import pyarrow as pa
    import pyarrow.compute as pc
    mag = pc.utf8_lpad(pc.cast(pa.array(np.abs(steps)), pa.string()), decimals + 1, "0")
    sign = pc.if_else(pa.array(steps < 0), "-", "")
    return pc.binary_join_element_wise(sign, pc.utf8_slice_codeunits(mag, 0, -decimals), ".",
                                       pc.utf8_slice_codeunits(mag, -decimals), "")


def _write_assignments(f: IO[bytes], values: np.ndarray, before: str, between: str,
                       t: Target) -> None:
    """Lines ``<before><index><between><value>``, by Arrow: the values [LSB] at the
    target's decimals (x its sign) when it has them, else in shortest round-trip decimals."""
    import pyarrow as pa
    import pyarrow.compute as pc
    for start in range(0, values.size, 1 << 20):
        chunk = values[start:start + (1 << 20)]
        idx = pc.cast(pa.array(np.arange(start, start + chunk.size)), pa.string())
        if t.decimals is not None and t.decimals > 0:
            val = _decimal_text(chunk.astype(np.int64) * t.sign, t.decimals)
        else:
            val = pc.cast(pa.array(chunk * (t.count_deg * t.sign)), pa.string())
        lines = pc.binary_join_element_wise(before, idx, between, val, "\n", "")
        offsets = np.frombuffer(lines.buffers()[1], dtype=np.int32)[lines.offset:]
        data = lines.buffers()[2]
        f.write(memoryview(data)[offsets[0]:offsets[lines.__len__()]])


def write_acs(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """ACS SPiiPlus program: a REAL array [deg] 0..360 deg, ERRORMAP1D, ERRORMAPON."""
    v = _closed(values)
    step = 360.0 / values.size
    head = _comments(comment, "! ", ascii_only=True)
    head += (f"! enctools table: {v.size} points 0..360 deg, step {step!r} deg, "
             f"lsb {t.count_deg!r} deg\n"
             f"GLOBAL REAL {t.name}({v.size})\nINT AXIS_NO\nAXIS_NO = {t.axis}\n")
    f.write(head.encode())
    _write_assignments(f, v, f"{t.name}(", ")=", t)
    f.write((f"ERRORUNMAP AXIS_NO, {t.zone}\n"
             f"ERRORMAP1D AXIS_NO, {t.zone}, 0, {step!r}, {t.name}\n"
             f"ERRORMAPON AXIS_NO, {t.zone}\nSTOP\n").encode())


def write_siemens(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """SINUMERIK ``$AA_ENC_COMP`` table [deg] of a rotary axis with modulo, 0..360 deg."""
    v = _closed(values)
    step = 360.0 / values.size
    e, ax = t.zone, t.axis
    head = _comments(comment, "; ", ascii_only=True)
    head += (f"; enctools table: {v.size} points 0..360 deg, lsb {t.count_deg!r} deg\n"
             "%_N_AX_EEC_INI\nCHANDATA(1)\n")
    f.write(head.encode())
    _write_assignments(f, v, f"$AA_ENC_COMP[{e},", f",{ax}]=", t)
    f.write((f"$AA_ENC_COMP_STEP[{e},{ax}]={step!r}\n$AA_ENC_COMP_MIN[{e},{ax}]=0.0\n"
             f"$AA_ENC_COMP_MAX[{e},{ax}]=360.0\n$AA_ENC_COMP_IS_MODULO[{e},{ax}]=1\nM17\n").encode())
