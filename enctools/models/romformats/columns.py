"""Lines of equal length read by columns: the machinery of the fast readers.

A table file as this project writes it has one entry a line, every line of the
same length, so a field sits at the same columns of every line. Such lines are
read as strided words straight from the file's bytes, a block of 2^20 lines at a
time (work arrays stay small: the verification of a 2^26-entry MIF stays under 2 GB),
and hex digits are decoded two at a time by one table look-up.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np

from enctools.models.romformats.words import HEX_DIGIT, signed

#: lines decoded at once
BLOCK = 1 << 20
#: marks a byte (or pair of bytes) that is not a hex digit in the look-up tables
NOT_HEX = 256


@cache
def _hex_one() -> np.ndarray:
    """Value of every byte read as one hex digit: 0..15, or NOT_HEX."""
    v = HEX_DIGIT.astype(np.uint16)
    v[v == 255] = NOT_HEX
    return v


@cache
def _hex_pairs() -> np.ndarray:
    """Value of every two ASCII bytes read as a native uint16: 0..255, or NOT_HEX."""
    v = _hex_one()
    two = np.where((v[:, None] | v[None, :]) & NOT_HEX, NOT_HEX, (v[:, None] << 4) | v[None, :])
    code = np.frombuffer(np.arange(1 << 16, dtype=np.uint16).tobytes(), np.uint8).reshape(-1, 2)
    return two[code[:, 0], code[:, 1]].astype(np.uint16)


@dataclass(frozen=True)
class Rows:
    """Lines of equal length in a byte buffer: ``n`` lines of ``width`` bytes from ``start``."""

    data: bytes
    start: int
    n: int
    width: int

    def word(self, col: int, size: int) -> np.ndarray:
        """Bytes col..col+size-1 of every line as one unsigned (native order) word each."""
        return np.ndarray((self.n,), np.dtype(f"u{size}"), buffer=self.data,
                          offset=self.start + col, strides=(self.width,))

    def line(self, k: int) -> bytes:
        """Line k, its newline included."""
        return self.data[self.start + k * self.width:self.start + (k + 1) * self.width]

    def same(self, a: int, b: int) -> bool:
        """Whether bytes a..b-1 of every line equal those of the first line."""
        while a < b:
            size = 4 if b - a >= 4 else 2 if b - a >= 2 else 1
            w = self.word(a, size)
            if not (w == w[0]).all():
                return False
            a += size
        return True

    def blocks(self, rows: int = BLOCK) -> Iterator[tuple[int, Rows]]:
        """(first line, lines) in blocks of ``rows`` lines: work arrays stay small."""
        for k in range(0, self.n, rows):
            yield k, Rows(self.data, self.start + k * self.width, min(rows, self.n - k), self.width)

    def hex(self, a: int, b: int, width: int) -> np.ndarray | None:
        """Signed values (two's complement in ``width`` bits) of the hex digits in columns a..b-1.

        None if a digit is not hex or there are more than 16.
        """
        out = np.empty(self.n, dtype=np.int64)
        for k, block in self.blocks():
            v = block.hex_block(a, b, width)
            if v is None:
                return None
            out[k:k + block.n] = v
        return out

    def counts(self, a: int, b: int) -> bool | None:
        """Whether the hex numbers in columns a..b-1 are 0, 1, 2, ... (None: not all hex).

        Checked block by block, without an array of every address.
        """
        for k, block in self.blocks():
            v = block.hex_block(a, b, 64)
            if v is None:
                return None
            if not np.array_equal(v, np.arange(k, k + block.n)):
                return False
        return True

    def hex_block(self, a: int, b: int, width: int) -> np.ndarray | None:
        """:meth:`hex` of every line at once: two digits a look-up on unaligned uint16 words."""
        digits = b - a
        if not 0 < digits <= 16:
            return None
        acc = np.uint32 if digits <= 8 else np.uint64
        u: np.ndarray[Any, np.dtype[np.unsignedinteger[Any]]] = np.zeros(self.n, dtype=acc)
        bad = np.zeros(self.n, dtype=np.uint16)
        if digits % 2:
            one = _hex_one()[self.word(a, 1)]
            bad |= one
            u |= one
            a += 1
        pairs = _hex_pairs()
        for col in range(a, b, 2):
            v = pairs[self.word(col, 2)]
            bad |= v
            u <<= acc(8)
            u |= v  # a non-hex pair (NOT_HEX) spoils u, but then bad says so
        if (bad & NOT_HEX).any():
            return None
        if width in (8, 16, 32) and 4 * digits == width:
            word = np.dtype(f"u{width // 8}")
            return u.astype(word).view(np.dtype(f"i{width // 8}")).astype(np.int64)
        return signed(u.astype(np.uint64), width) if width < 64 else u.astype(np.int64)


def fixed_rows(data: bytes, start: int, stop: int) -> Rows | None:
    """The lines of data[start:stop] when every one has the same length (newline included)."""
    nl = data.find(b"\n", start, stop)
    width = nl + 1 - start
    if nl < 0 or (stop - start) % width:
        return None
    rows = Rows(data, start, (stop - start) // width, width)
    return rows if (rows.word(width - 1, 1) == 10).all() else None


def hex_lines(data: bytes, start: int, stop: int, tail: bytes, width: int) -> np.ndarray | None:
    """Values of the lines ``<blanks><hex><tail>`` all alike in data[start:stop], or None."""
    rows = fixed_rows(data, start, stop)
    if rows is None:
        return None
    m = re.fullmatch(rb"([ \t]*)([0-9A-Fa-f]+)(" + tail + rb")", rows.line(0))
    if m is None or not (rows.same(*m.span(1)) and rows.same(*m.span(3))):
        return None
    return rows.hex(*m.span(2), width)
