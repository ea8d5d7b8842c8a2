"""Blocks of table text and their writing: buffers of fixed-width lines set a column at a
time, and a gatherer that hands them to the kernel in few, page-aligned ``os.writev`` calls.
Shared by the text-table writers (:mod:`.writers`, :mod:`.csvtext`)."""

from __future__ import annotations

import mmap
import os
from typing import IO

import numpy as np

#: lines a block: 16^4, so that the low four hex digits of an address repeat every block
#: (about 1 MB of MIF text, which stays in the CPU's cache until written)
LINES = 1 << 16
#: runs of equal words (or, in CSV, of lines of one length) in a block below which each run
#: is written whole rather than line by line (a correction table's values change slowly:
#: the table-1 model's 1680 times in 2^26 addresses, runs of some 40 000 lines)
RUNS = 64
#: lines of a span whose changes of value are found at once (CSV, COE, MEM)
SPAN = 1 << 17
#: the mean run [line] from which a span is written run by run
LONG_RUN = 1024
#: bytes of text gathered for one write (the kernel takes 256 KiB writes at some 1.5 times
#: the CPU of 1 MiB or larger ones)
WRITE = 1 << 22


def column(lines: np.ndarray, col: int, dtype: type | np.dtype, shape: tuple[int, ...] = (),
            strides: tuple[int, ...] = ()) -> np.ndarray:
    """A word of ``dtype`` at byte ``col`` of every line of ``lines`` (m, w) uint8 (a view;
    ``shape``/``strides`` add axes after the line's, e.g. 16 words 2 bytes apart)."""
    m, w = lines.shape
    return np.ndarray((m, *shape), dtype, buffer=lines, offset=col, strides=(w, *strides))


def put_bytes(lines: np.ndarray, col: int, text: bytes) -> None:
    """The same bytes at ``col`` in every line: whole words copied from a contiguous column
    (numpy's strided fill of an unaligned scalar is several times slower)."""
    m = lines.shape[0]
    while text:
        size = 8 if len(text) >= 8 else 4 if len(text) >= 4 else 2 if len(text) >= 2 else 1
        dt = np.dtype(f"u{size}")
        np.copyto(column(lines, col, dt), np.full(m, np.frombuffer(text[:size], dt)[0]))
        text, col = text[size:], col + size


class Gather:
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
