"""The words of a correction table: how they are written (:class:`Target`) and their
two's complement both ways.

A table value is a signed integer [LSB]; a file stores it as a word of ``width``
bits in two's complement (``ceil(width / 4)`` hex digits in text formats), or as
1, 2 or 4 bytes of a binary image in the target's byte order. A table too large to
hold is given to the writers as :class:`Words`, a block at a time.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from enctools.errors import DataError

#: the largest table enctools builds or reads: 2^28 entries (enc make-rom's `address_bits`)
MAX_TABLE_BITS = 28


@dataclass(frozen=True)
class Target:
    """How to write a table: format and its options."""

    fmt: str
    width: int = 16
    endian: str = "little"
    count_deg: float = 360.0 / 2 ** 23  # one LSB of the stored value [deg] (controllers)
    axis: str = ""  # the axis as the program names it ("": its format's default_axis)
    zone: int = 0  # ACS zone / SINUMERIK measuring system index
    name: str = "ENC_COMP"  # ACS array name
    max_entries: int | None = None
    sign: int = 1  # acs: +1 a value is the correction, -1 the error (minus the correction)
    decimals: int | None = None  # controllers: digits after the point (None: shortest)

    def __post_init__(self) -> None:
        if not self.axis:
            from enctools.models.romformats import registry

            fmt = registry.find(self.fmt)
            object.__setattr__(self, "axis", fmt.default_axis if fmt is not None else "")

    @property
    def storage_bytes(self) -> int:
        """Bytes a word of a binary image: 1, 2 or 4."""
        return 1 if self.width <= 8 else 2 if self.width <= 16 else 4

    @property
    def hex_digits(self) -> int:
        """Hex digits a word of a text format."""
        return (self.width + 3) // 4

    @property
    def image_dtype(self) -> np.dtype:
        """The signed word of a binary image, in the target's byte order."""
        return np.dtype(f"{'<' if self.endian == 'little' else '>'}i{self.storage_bytes}")


def comment_text(text: str, ascii_only: bool = False, reserved: str = "") -> str:
    """``text`` made safe to stand in a one-line comment of a table file or machine program.

    Every character that is not printable (C0 and C1 controls, CR, LF, TAB, ESC, DEL,
    NEL U+0085, line and paragraph separators U+2028/2029, format characters such as
    bidi overrides, lone surrogates of undecodable file names) and every ``reserved``
    character (one that could close the format's comment, e.g. MIF's ``%``) becomes a
    visible escape (``\\n``, ``\\x1b``, ``\\u2028``, ``\\x25``); with ``ascii_only`` every
    other non-ASCII character becomes ``?``. The result is one line of text.
    """
    if text.isascii() and text.isprintable() and not any(c in text for c in reserved):
        return text
    out = []
    for ch in text:
        if not ch.isprintable():
            out.append(ascii(ch)[1:-1])
        elif ch in reserved:
            out.append(f"\\x{ord(ch):02x}")
        elif ascii_only and not ch.isascii():
            out.append("?")
        else:
            out.append(ch)
    return "".join(out)


def twos(values: np.ndarray, width: int) -> np.ndarray:
    """Two's complement of signed values in ``width`` bits, as unsigned words of 1, 2 or 4
    bytes (the size of a binary image's words)."""
    size = 1 if width <= 8 else 2 if width <= 16 else 4
    u = values.astype(f"i{size}", copy=False).view(f"u{size}")
    return u & ((1 << width) - 1) if width < 8 * size else u


def signed(u: np.ndarray, width: int) -> np.ndarray:
    """Signed int64 from two's complement in ``width`` bits (u: uint64)."""
    s = u.astype(np.int64)
    if width >= 63:
        return s
    s &= (1 << width) - 1
    s -= (s >> (width - 1)) << width
    return s


def image_values(image: bytes, t: Target, src: str) -> np.ndarray:
    """The signed values of a binary image of words (DataError if not whole words)."""
    if len(image) % t.storage_bytes:
        msg = f"{src}: {len(image)} bytes is not a whole number of {t.storage_bytes}-byte words"
        raise DataError(msg)
    return np.frombuffer(image, dtype=t.image_dtype).astype(np.int64)


#: the value of each byte as a hex digit (0..15), 255 where the byte is not one
HEX_DIGIT = np.full(256, 255, dtype=np.uint8)
HEX_DIGIT[np.frombuffer(b"0123456789", np.uint8)] = np.arange(10)
HEX_DIGIT[np.frombuffer(b"ABCDEF", np.uint8)] = np.arange(10, 16)
HEX_DIGIT[np.frombuffer(b"abcdef", np.uint8)] = np.arange(10, 16)


class Words:
    """A table's words [LSB] given a block at a time, never held whole: sliced as an array
    (``words[a:b]`` is an ndarray of those words), with its ``size``, ``dtype``, ``min()``
    and ``max()`` known beforehand. ``chunk(k)`` gives words ``k * block ..``; the two
    blocks used last are kept, so that a writer taking the table in order, in slices of any
    size, has each block made once. ``np.asarray(words)`` makes the whole table (for the
    small ones: a controller's points)."""

    ndim = 1

    def __init__(self, size: int, dtype: np.dtype | type, block: int,
                 chunk: Callable[[int], np.ndarray], lo: int, hi: int) -> None:
        self.size, self.dtype, self.block = size, np.dtype(dtype), block
        self._chunk, self._lo, self._hi = chunk, lo, hi
        self._recent: dict[int, np.ndarray] = {}

    @property
    def shape(self) -> tuple[int]:
        return (self.size,)

    def __len__(self) -> int:
        return self.size

    def min(self) -> int:
        return self._lo

    def max(self) -> int:
        return self._hi

    def _get(self, k: int) -> np.ndarray:
        got = self._recent.get(k)
        if got is None:
            got = self._chunk(k)
            if len(self._recent) >= 2:
                self._recent.pop(next(iter(self._recent)))
            self._recent[k] = got
        return got

    def __getitem__(self, key: slice) -> np.ndarray:
        if not isinstance(key, slice):
            msg = "a table's words are taken as slices"
            raise TypeError(msg)
        a, b, step = key.indices(self.size)
        if step != 1:
            msg = "a table's words are taken as slices of step 1"
            raise ValueError(msg)
        if b <= a:
            return np.empty(0, self.dtype)
        k0, k1 = a // self.block, (b - 1) // self.block
        parts = [self._get(k)[max(a - k * self.block, 0):b - k * self.block]
                 for k in range(k0, k1 + 1)]
        return parts[0] if len(parts) == 1 else np.concatenate(parts)

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        whole = self[0:self.size]
        return whole if dtype is None else whole.astype(dtype)
