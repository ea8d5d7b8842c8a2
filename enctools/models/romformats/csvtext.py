"""CSV correction tables: ``address,correction`` in decimal, the header line first.

Values of up to 16 bits are written from a table of every 16-bit value's text (a comma,
the sign, the digits, the newline: one 8-byte word each) and the five low digits of every
address, which repeat every 100 000 lines. The table is taken a span of
:data:`~.blocks.SPAN` lines at a time: a span whose values change seldom (a correction
table's, the table-1 model's 1680 times in 2^26 addresses) is written run by run, each
run's lines a fixed-width table after the run before in a reused buffer of
:data:`~.blocks.WRITE` bytes: its value words, then each line's first word (the address,
and the value's first bytes) in one pass (:meth:`CsvLines.runs`); a span of many values is
written a block of :data:`~.blocks.LINES` lines at a time (:meth:`CsvLines.text`). Wider
values are written by Arrow's CSV writer. Every buffer goes out through
:class:`~.blocks.Gather`: page-aligned ``os.writev`` calls.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from itertools import pairwise
from typing import IO

import numpy as np

from enctools.models.romformats.blocks import (
    LINES,
    LONG_RUN,
    RUNS,
    SPAN,
    WRITE,
    Gather,
    column,
    put_bytes,
)
from enctools.models.romformats.words import Target, twos

#: CSV lines whose address has fewer than 5 digits are formatted one by one
CSV_SHORT = 10_000


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
    out = Gather(f)
    for d in range(5, len(str(values.size - 1)) + 1):  # the addresses of d digits, by spans
        lines, end = CsvLines(d), min(values.size, 10 ** d)
        for start in range(max(short, 10 ** (d - 1)), end, SPAN):
            _write_span(out, lines, start, values[start:min(start + SPAN, end)])
    out.flush(whole=True)


def _write_span(out: Gather, lines: CsvLines, start: int, values: np.ndarray) -> None:
    """The lines of ``values`` (16-bit), addresses from ``start``, all of one length: run
    by run when its values change seldom, else a block at a time."""
    u = twos(values, 16)
    change = np.flatnonzero(u[1:] != u[:-1]) + 1
    if change.size * LONG_RUN < u.size:
        parts: Iterator[memoryview] = lines.runs(start, u, change)
    else:
        parts = (lines.text(start + k, values[k:k + LINES]) for k in range(0, u.size, LINES))
    for part in parts:
        out.add(part)
        out.flush()  # before the buffer is used again


def _fit_16_bits(values: np.ndarray) -> bool:
    """Whether every value is a signed 16-bit word's (a table's up to 16 bits wide)."""
    if values.dtype.itemsize <= 2:
        return True
    return bool(values.min() >= -(1 << 15) and values.max() < 1 << 15)


class CsvLines:
    """CSV lines ``address,value``, addresses of ``d`` digits (5..9) and values of 16-bit
    words, whose text and newline come from a table of every 16-bit value: run by run
    (:meth:`runs`) or a block at a time (:meth:`text`).

    Block by block: a table's values change slowly (the table-1 model's 1680 times in 2^26
    addresses, their lengths 32 times), so a block is a few runs of one value, at most
    100 000 addresses each: a run is a fixed-width table written in place like MIF's, its
    columns stored whole. A block of many values but few runs of lines of one length is
    written so too, each line's value looked up. A block of more runs than :data:`RUNS`
    builds each line in a row of :data:`ROW` bytes (4 spare, the address, the comma, the
    value's text) and copies the rows of each length, as items of that many bytes, to where
    their lines start. Nothing depends on the order of the copies within one numpy call."""

    ROW = 24

    def __init__(self, d: int) -> None:
        self.d = d
        self.words, sizes = _decimal_table()
        self.sizes = sizes + d  # a line's length [byte]
        self.fill = np.empty(100_000, np.uint64)  # a run's values, for a contiguous copy
        self.word = np.empty(LINES, np.uint64)  # a block's addresses
        self.out = np.empty(max(WRITE, LINES * (d + 8) + self.ROW), np.uint8)
        self.rows: np.ndarray | None = None
        # the five low digits of every address where a line's first word holds them all
        self.five = (_last_five()[2] << np.uint64(8 * (d - 5))
                     if d <= 8 and sys.byteorder == "little" else None)

    def runs(self, start: int, u: np.ndarray, change: np.ndarray) -> Iterator[memoryview]:
        """The lines of the 16-bit words ``u``, addresses from ``start``, a run of one value
        at a time (``change``: where each run but the first starts), each cut where the
        address digits above the last five change: runs written one after another into a
        buffer of :data:`~.blocks.WRITE` bytes, handed out when the next would not fit (the
        same buffer every time: written before the next is taken)."""
        bounds, at = [0, *change.tolist(), u.size], 0
        room = self.out.size - 8  # the last value word reaches past its line
        for k0, k1 in pairwise(bounds):
            word, width = self.words[u[k0]], int(self.sizes[u[k0]])
            a, end = start + k0, start + k1
            while a < end:
                n = min(end - a, 100_000 - a % 100_000, room // width)
                if at + n * width > room:
                    yield self.out[:at].data
                    at = 0
                self._one_value(at, n, width, word, a)
                at += n * width
                a += n
        if at:
            yield self.out[:at].data

    def _one_value(self, at: int, n: int, width: int, word: np.uint64, first: int) -> None:
        """``n`` lines of ``width`` bytes of the value ``word`` (its comma, text and newline)
        from byte ``at`` of the text, addresses from ``first`` in the 100 000 of one
        prefix: the value words first (each reaching into the next line), then each line's
        first word. Of up to 8 digits: the sum of the address's five low digits, its prefix
        and the value's first bytes, whose bytes do not overlap."""
        d, cv = self.d, self.fill[:n]
        cv.fill(word)
        np.copyto(self._words_at(at + d, np.uint64, n, width), cv)
        if self.five is None:
            self._addresses(at, n, width, first, cv)
            return
        q, r = divmod(first, 100_000)
        head = int.from_bytes(str(q).encode(), "little") if q else 0
        if d < 8:
            head |= (int(word) << 8 * d) & 0xFFFF_FFFF_FFFF_FFFF
        np.add(self.five[r:r + n], np.uint64(head), out=self._words_at(at, np.uint64, n, width))

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
        the line's next bytes (words read little-endian; ``cv`` is shifted in place); of
        9, or on a big-endian machine: the prefix, the first four digits and the last."""
        d = self.d
        q, r = divmod(first, 100_000)
        if self.five is not None:
            prefix = np.uint64(int.from_bytes(str(q).encode(), "little") if q else 0)
            word = np.bitwise_or(self.five[r:r + n], prefix, out=self.word[:n])
            if d < 8:
                word |= np.left_shift(cv, np.uint64(8 * d), out=cv)
            np.copyto(self._words_at(at, np.uint64, n, width), word)
            return
        four, one, _ = _last_five()
        put_bytes(self.out[at:at + n * width].reshape(n, width), 0, str(q).encode())
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
            np.take(dec, q // 10_000, out=column(rows, 1, np.uint32), mode="clip")
            q = q % 10_000
        np.take(dec, q, out=column(rows, d - 4, np.uint32), mode="clip")  # left zeros: spare
        np.take(dec, r, out=column(rows, d, np.uint32), mode="clip")
        np.take(self.words, u, out=column(rows, 4 + d, np.uint64), mode="clip")
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
