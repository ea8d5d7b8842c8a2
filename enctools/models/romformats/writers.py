"""Writers of correction tables: one function per format, each writing a whole file.

Big tables are formatted with numpy (fixed-width lines built as byte arrays, a
block of :data:`LINES` lines at a time) or Arrow's CSV and string kernels, never a
Python loop per line. Every writer takes an open binary file, the signed values [LSB]
(one per address), the :class:`~enctools.models.romformats.words.Target` and the
comment lines to put at the top where the format has comments.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import IO

import numpy as np

from enctools.models.romformats.words import Target, comment_text, twos

_HEX = np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)


_HEX_TABLES: dict[int, np.ndarray] = {}


def _hex_tables() -> dict[int, np.ndarray]:
    """ASCII upper-case hex of every 4-, 8- and 16-bit value: {digits: uint8/16/32 words}."""
    if not _HEX_TABLES:
        k = np.arange(1 << 16)
        digits = np.ascontiguousarray(np.stack([_HEX[(k >> s) & 15] for s in (12, 8, 4, 0)], 1))
        _HEX_TABLES[4] = digits.view(np.uint32).reshape(-1)
        _HEX_TABLES[2] = np.ascontiguousarray(digits[:256, 2:]).view(np.uint16).reshape(-1)
        _HEX_TABLES[1] = _HEX.copy()
    return _HEX_TABLES


def _hex_columns(u: np.ndarray, digits: int) -> list[np.ndarray]:
    """ASCII hex of non-negative integers, ``digits`` wide, as pieces for :func:`_lines`.

    The pieces are words of 4, 2 and 1 characters (uint32, uint16, uint8), left to
    right: one table look-up per 16 bits, and :func:`_lines` places each with one
    strided word copy rather than a byte loop.
    """
    tables = _hex_tables()
    u = u.astype(np.int64, copy=False)
    pieces = []
    left = digits
    while left:
        width = 4 if left >= 4 else 2 if left >= 2 else 1
        left -= width
        mask = (1 << (4 * width)) - 1
        pieces.append(tables[width][(u >> (4 * left)) & mask if left else u & mask])
    return pieces


def _hex_bytes(b: np.ndarray) -> np.ndarray:
    """ASCII hex (two digits a byte) of a uint8 array, as uint16 words of the same shape."""
    return _hex_tables()[2][b]


def _lines(parts: list[np.ndarray | bytes | list[np.ndarray]], n: int) -> np.ndarray:
    """Fixed-width lines (n, W) uint8 from parts placed left to right.

    A part is constant bytes, an array of n words (any unsigned dtype: its bytes in
    memory order) or of shape (n, k) (k words a line), or a list of such arrays.
    Every part is written with one strided copy of whole words.
    """
    flat: list[np.ndarray | bytes] = []
    for p in parts:
        if isinstance(p, list):
            flat.extend(p)
        else:
            flat.append(p)
    widths = [p.itemsize * (p.shape[1] if p.ndim == 2 else 1) if isinstance(p, np.ndarray)
              else len(p) for p in flat]
    w = sum(widths)
    buf = np.empty(n * w, dtype=np.uint8)
    col = 0
    for p, width in zip(flat, widths, strict=True):
        if isinstance(p, np.ndarray):
            strides = (w,) if p.ndim == 1 else (w, p.itemsize)
            np.ndarray(p.shape, p.dtype, buffer=buf, offset=col, strides=strides)[...] = p
        else:
            at = col
            while p:
                size = 4 if len(p) >= 4 else 2 if len(p) >= 2 else 1
                dt = np.dtype(f"u{size}")
                view = np.ndarray((n,), dt, buffer=buf, offset=at, strides=(w,))
                view[...] = np.frombuffer(p[:size], dt)[0]
                p, at = p[size:], at + size
        col += width
    return buf.reshape(n, w)


#: lines formatted at once: about 1 MB of text, which stays in the CPU's cache until written
LINES = 1 << 16


def _write_chunked(f: IO[bytes], values: np.ndarray,
                   make: Callable[[np.ndarray, int], np.ndarray], chunk: int = LINES) -> None:
    """Write the lines ``make(values[start:stop], start)`` block by block."""
    for start in range(0, values.size, chunk):
        f.write(make(values[start:start + chunk], start).reshape(-1).data)


def _comments(comment: list[str], prefix: str, ascii_only: bool = False,
              reserved: str = "") -> str:
    """The comment lines, each ``prefix`` + :func:`~.words.comment_text` + newline: nothing
    in them can end the comment or start a line of program or table."""
    return "".join(f"{prefix}{comment_text(c, ascii_only, reserved)}\n" for c in comment)


def write_bin(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Raw two's-complement words, 1, 2 or 4 bytes each, in the target's byte order."""
    values.astype(t.image_dtype, copy=False).tofile(f)


def write_ihex(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Intel HEX of the raw image: 16 data bytes a record, a type 04 record every 64 KiB."""
    image = np.ascontiguousarray(values.astype(t.image_dtype, copy=False)).view(np.uint8)
    seg = 1 << 16
    for base in range(0, image.size, seg):
        f.write(_ihex_record(4, 0, [(base >> 24) & 0xFF, (base >> 16) & 0xFF]))
        data = image[base:base + seg]
        full = data.size // 16
        if full:
            rec = np.empty((full, 21), dtype=np.uint8)
            rec[:, 0] = 16
            off = np.arange(full, dtype=np.int64) * 16
            rec[:, 1] = off >> 8
            rec[:, 2] = off & 0xFF
            rec[:, 3] = 0
            rec[:, 4:20] = data[:full * 16].reshape(full, 16)
            rec[:, 20] = (-rec[:, :20].astype(np.int64).sum(axis=1)) & 0xFF
            f.write(_lines([b":", _hex_bytes(rec), b"\n"], full).reshape(-1).data)
        rest = data[full * 16:]
        if rest.size:
            f.write(_ihex_record(0, full * 16, rest.tolist()))
    f.write(b":00000001FF\n")


def _ihex_record(rtype: int, addr: int, data: list[int]) -> bytes:
    body = [len(data), (addr >> 8) & 0xFF, addr & 0xFF, rtype, *data]
    body.append((-sum(body)) & 0xFF)
    return b":" + bytes(body).hex().upper().encode() + b"\n"


def write_mif(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Altera/Intel MIF: WIDTH, DEPTH, hex radices, one ``addr : value;`` a line."""
    adig = max(1, (int(values.size - 1).bit_length() + 3) // 4)
    head = _comments(comment, "-- ", reserved="%")  # % opens a block comment
    head += (f"WIDTH={t.width};\nDEPTH={values.size};\n\nADDRESS_RADIX=HEX;\nDATA_RADIX=HEX;\n\n"
             "CONTENT BEGIN\n")
    f.write(head.encode())

    def make(v: np.ndarray, start: int) -> np.ndarray:
        addr = _hex_columns(np.arange(start, start + v.size, dtype=np.int64), adig)
        return _lines([b"\t", addr, b" : ", _hex_columns(twos(v, t.width), t.hex_digits),
                       b";\n"], v.size)

    _write_chunked(f, values, make)
    f.write(b"END;\n")


def write_coe(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Xilinx COE, radix 16: one ``value,`` a line, the last ``value;``."""
    head = _comments(comment, "; ")
    f.write((head + "memory_initialization_radix=16;\nmemory_initialization_vector=\n").encode())

    def make(v: np.ndarray, start: int) -> np.ndarray:
        lines = _lines([_hex_columns(twos(v, t.width), t.hex_digits), b",\n"], v.size)
        if start + v.size == values.size:
            lines[-1, -2] = ord(";")
        return lines

    _write_chunked(f, values, make)


def write_mem(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Verilog ``$readmemh`` text: ``//`` comments, ``@0``, one hex word a line."""
    f.write(_comments(comment, "// ", reserved="*").encode())  # no /* or */
    f.write(b"@0\n")
    _write_chunked(f, values, lambda v, s: _lines([_hex_columns(twos(v, t.width),
                                                                t.hex_digits), b"\n"], v.size))


def write_csv(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """``address,correction`` in decimal, the header line first: no comment lines, which
    pandas, Miller and csvkit would take for the header (``comment`` is left out)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv
    f.write(b"address,correction\n")
    table = pa.table({"address": pa.array(np.arange(values.size, dtype=np.int64)),
                      "correction": pa.array(values.astype(np.int64))})
    pcsv.write_csv(table, f, pcsv.WriteOptions(include_header=False))


def _closed(values: np.ndarray) -> np.ndarray:
    """The table with its first value repeated at 360 deg (rotary tables)."""
    return np.append(values, values[:1])


def _write_assignments(f: IO[bytes], values: np.ndarray, before: str, between: str) -> None:
    """Lines ``<before><index><between><value>`` (shortest round-trip decimals), by Arrow."""
    import pyarrow as pa
    import pyarrow.compute as pc
    for start in range(0, values.size, 1 << 20):
        chunk = values[start:start + (1 << 20)]
        idx = pc.cast(pa.array(np.arange(start, start + chunk.size)), pa.string())
        val = pc.cast(pa.array(chunk), pa.string())
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
    _write_assignments(f, v * t.count_deg, f"{t.name}(", ")=")
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
    _write_assignments(f, v * t.count_deg, f"$AA_ENC_COMP[{e},", f",{ax}]=")
    f.write((f"$AA_ENC_COMP_STEP[{e},{ax}]={step!r}\n$AA_ENC_COMP_MIN[{e},{ax}]=0.0\n"
             f"$AA_ENC_COMP_MAX[{e},{ax}]=360.0\n$AA_ENC_COMP_IS_MODULO[{e},{ax}]=1\nM17\n").encode())
