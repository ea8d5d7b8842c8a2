"""Writers of correction tables: one function per format, each writing a whole file.

The text tables (MIF, COE, MEM, Intel HEX) are written a block of lines at a time from
one buffer whose constant bytes (separators, line ends, the address digits that repeat
every block) are set once: a block then costs a table look-up of digits per 16 bits of
its words, stored straight into the lines, and one write. A correction table's values
change slowly, so most blocks are a few runs of equal words, each stored whole; a block
of many runs is written line by line, with the same bytes. COE and MEM, whose lines hold
no address, find the runs of a span of :data:`~.blocks.SPAN` lines at once and write a run
as one buffer of a few thousand of its lines listed as often as the run needs in one
``os.writev``; Intel HEX repeats a run of equal records' digits as
one 32-byte item. Every write but a file's last ends at a whole page of the file
(:class:`~.blocks.Gather`). Every writer takes the table in slices, in order, a block at
a time, so a table given as :class:`~.words.Words` (enc make-rom's) is never held whole:
nothing grows with the table. CSV is written
by :mod:`.csvtext`; the controllers' tables are formatted by Arrow's string kernels, a
block at a time. Every writer takes an open binary file (a real one: most write to its
descriptor), the signed values [LSB] (one per address), the
:class:`~enctools.models.romformats.words.Target` and the comment lines to put at the top
where the format has comments.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import IO

import numpy as np

from enctools.models.romformats.blocks import (
    LINES,
    LONG_RUN,
    RUNS,
    SPAN,
    Gather,
    column,
    put_bytes,
)
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
        np.take(tables[size], piece, out=column(lines, col, tables[size].dtype), mode="clip")
        left, col = left - size, col + size


#: characters a line of a controller's program holds at most here (ACS, SINUMERIK): their
#: manuals' limits were not found (enc-make-rom(1), Formats); a longer comment goes on
#: as further comment lines, the layout line (under 200) staying whole
PROGRAM_LINE = 200


def _comments(comment: list[str], prefix: str, ascii_only: bool = False,
              reserved: str = "", width: int | None = None) -> str:
    """The comment lines, each ``prefix`` + :func:`~.words.comment_text` + newline: nothing
    in them can end the comment or start a line of program or table; with ``width``, a
    longer one is cut into lines of at most ``width`` characters, each a comment."""
    lines = []
    for c in comment:
        text = comment_text(c, ascii_only, reserved)
        room = len(text) if width is None else max(1, width - len(prefix))
        lines += [f"{prefix}{text[i:i + room]}\n" for i in range(0, max(len(text), 1), room)]
    return "".join(lines)


#: words of a binary image converted and written at once
BIN_BLOCK = 1 << 20


def write_bin(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Raw two's-complement words, 1, 2 or 4 bytes each, in the target's byte order."""
    for start in range(0, values.size, BIN_BLOCK):
        values[start:start + BIN_BLOCK].astype(t.image_dtype, copy=False).tofile(f)


#: Intel HEX: data bytes a record, a segment (the 64 KiB a type 04 record addresses), the
#: text of a full data record (":10AAAA00" 32 digits of data, 2 of checksum, newline), of
#: a type 04 record, and the segments a block
IHEX_DATA, IHEX_SEGMENT, IHEX_LINE, IHEX_EXT, IHEX_SEGMENTS = 16, 1 << 16, 44, 16, 8


def write_ihex(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Intel HEX of the raw image: 16 data bytes a record, a type 04 record every 64 KiB."""
    size = t.storage_bytes
    nbytes = values.size * size
    full = nbytes // IHEX_SEGMENT
    per = IHEX_SEGMENT * IHEX_SEGMENTS // size  # words of a block of whole segments

    def image(a: int, b: int) -> np.ndarray:  # the image of words a..b-1
        return np.ascontiguousarray(values[a:b].astype(t.image_dtype, copy=False)).view(np.uint8)

    if full:
        last = full * IHEX_SEGMENT // size
        _ihex_segments(f, (image(a, min(a + per, last)) for a in range(0, last, per)),
                       min(IHEX_SEGMENTS, full))
    base = full * IHEX_SEGMENT
    if base < nbytes:  # the last segment, in part: its records one by one
        f.write(_ihex_record(4, 0, [(base >> 24) & 0xFF, (base >> 16) & 0xFF]))
        rest = image(base // size, values.size)
        f.write(b"".join(_ihex_record(0, a, rest[a:a + IHEX_DATA].tolist())
                         for a in range(0, rest.size, IHEX_DATA)))
    f.write(b":00000001FF\n")


def _ihex_segments(f: IO[bytes], images: Iterable[np.ndarray], segments: int) -> None:
    """Whole 64 KiB segments of the image, given in ``images`` (uint8) of at most
    ``segments`` segments (<= IHEX_SEGMENTS) each: the records' lengths, addresses, types
    and newlines are the same in every segment and set once."""
    records = IHEX_SEGMENT // IHEX_DATA
    seg_text = IHEX_EXT + records * IHEX_LINE
    block = np.empty((segments, seg_text), np.uint8)
    addr = np.arange(0, IHEX_SEGMENT, IHEX_DATA, dtype=np.uint32)
    for segment in block:
        lines = segment[IHEX_EXT:].reshape(-1, IHEX_LINE)  # a view: the row is contiguous
        put_bytes(lines, 0, b":10")
        _put_hex(lines, 3, addr, 4)
        put_bytes(lines, 7, b"00")
        put_bytes(lines, IHEX_LINE - 1, b"\n")
    # a record's checksum is this, less its data bytes' sum (mod 256)
    checks = ((-(IHEX_DATA + (addr >> 8) + (addr & 0xFF))) & 0xFF).astype(np.uint8)
    out = Gather(f)
    check_text: dict[int, np.ndarray] = {}
    base = 0
    for image in images:
        data = image.reshape(-1, records, IHEX_DATA)
        for j in range(data.shape[0]):
            at = base + j * IHEX_SEGMENT
            block[j, :IHEX_EXT] = np.frombuffer(
                _ihex_record(4, 0, [(at >> 24) & 0xFF, (at >> 16) & 0xFF]), np.uint8)
        text = block[:data.shape[0]]
        _ihex_data(text, data, checks, check_text)
        out.add(text.reshape(-1).data)
        out.flush()  # before the block is used again
        base += image.size
    out.flush(whole=True)


def _ihex_data(text: np.ndarray, data: np.ndarray, checks: np.ndarray,
               check_text: dict[int, np.ndarray]) -> None:
    """The data digits and checksums of the records of whole segments ``data`` (segments,
    records, 16) uint8 into their text (segments, its bytes): the 32 digits and the byte sum
    of each run of equal records, as a table's slowly changing values give, found once and
    stored into the run's lines as one 32-byte item and a row of the checksums' text; or
    every record's looked up, 16 bits at a time. ``checks``: each record's checksum were its
    data bytes all 0 (uint8); ``check_text``: the checksums' text of the records of a
    segment whose data bytes all sum to the key (mod 256), uint16 words, filled as met."""
    segs, records, _ = data.shape
    flat = data.reshape(-1, IHEX_DATA)
    words = flat.view(np.uint64)
    new = np.ones(words.shape[0], bool)  # where a run of equal records starts
    np.not_equal(words[1:, 0], words[:-1, 0], out=new[1:])
    new[1:] |= words[1:, 1] != words[:-1, 1]
    heads = np.flatnonzero(new)
    digits = column(text, IHEX_EXT + 9, np.dtype(f"V{2 * IHEX_DATA}"), (records,), (IHEX_LINE,))
    sums = column(text, IHEX_EXT + 9 + 2 * IHEX_DATA, np.uint16, (records,), (IHEX_LINE,))
    if heads.size >= RUNS * segs:
        np.take(_hex_tables()[0], data.view("<u2"), mode="clip",
                out=column(text, IHEX_EXT + 9, np.uint32, (records, IHEX_DATA // 2),
                            (IHEX_LINE, 4)))
        # looked up into a contiguous array, then stored (4x a look-up into the lines)
        index = np.subtract(checks, _byte_sums(flat).astype(np.uint8).reshape(segs, records),
                            dtype=np.uint8)
        np.copyto(sums, np.take(_hex_tables()[2], index))
        return
    run_digits = np.frombuffer(flat[heads].tobytes().hex().upper().encode(), digits.dtype)
    ends = [*heads[1:].tolist(), flat.shape[0]]
    for k, e, item, total in zip(heads.tolist(), ends, run_digits,
                                 _byte_sums(flat[heads]).tolist(), strict=True):
        total &= 0xFF
        row = check_text.get(total)
        if row is None:
            row = np.take(_hex_tables()[2], np.subtract(checks, total, dtype=np.uint8))
            check_text[total] = row
        while k < e:  # the run's records in each segment it reaches
            seg, a = divmod(k, records)
            b = min(e - seg * records, records)
            digits[seg, a:b] = item
            sums[seg, a:b] = row[a:b]
            k = seg * records + b


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
                put_bytes(block[k0:k1], col, f"{int(u[k0]):0{t.hex_digits}X}".encode())
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
    put_bytes(lines, 1 + adig, b" : ")
    put_bytes(lines, lines.shape[1] - 2, b";\n")
    for start in range(0, values.size, LINES):
        top = f"{start // LINES:0{adig - 4}X}" if adig > 4 else ""
        put_bytes(lines, 0, b"\t" + top.encode())
        _write_words(f, values[start:start + LINES], t, lines, 1 + adig + 3)
    f.write(b"END;\n")


def write_coe(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Xilinx COE, radix 16: one ``value,`` a line, the last ``value;``."""
    head = _comments(comment, "; ")
    f.write((head + "memory_initialization_radix=16;\nmemory_initialization_vector=\n").encode())
    last = values.size - 1
    _write_word_lines(f, values, t, b",\n", last)
    f.write(f"{int(twos(values[last:last + 1], t.width)[0]):0{t.hex_digits}X};\n".encode())


def write_mem(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    """Verilog ``$readmemh`` text: ``//`` comments, ``@0``, one hex word a line."""
    f.write(_comments(comment, "// ", reserved="*").encode())  # no /* or */
    f.write(b"@0\n")
    _write_word_lines(f, values, t, b"\n")


#: lines of one word's text that a run of that word is written from, the same buffer again
#: and again in one system call (24 KiB of COE's 16-bit words: stays in the CPU's cache)
RUN_LINES = 4096


def _write_word_lines(f: IO[bytes], values: np.ndarray, t: Target, end: bytes,
                      stop: int | None = None) -> None:
    """The table's words in hex, each followed by ``end``, a span of :data:`SPAN` lines at
    a time: a span whose values change seldom as each run's text, :data:`RUN_LINES` lines
    of it formatted once and written as often as the run needs (``os.writev``), a span of
    many runs a block of :data:`LINES` at a time, formatted line by line into one buffer.
    ``stop``: the words before it only (None: all)."""
    n = values.size if stop is None else stop
    if not n:
        return
    width = t.hex_digits + len(end)
    lines = np.empty((min(n, LINES), width), np.uint8)
    put_bytes(lines, t.hex_digits, end)
    out = Gather(f)
    for start in range(0, n, SPAN):
        u = twos(values[start:min(start + SPAN, n)], t.width)
        cuts = np.flatnonzero(u[1:] != u[:-1]) + 1
        if cuts.size * LONG_RUN < u.size:  # a table's values change slowly
            for k0, k1 in zip([0, *cuts.tolist()], [*cuts.tolist(), u.size], strict=True):
                line = f"{int(u[k0]):0{t.hex_digits}X}".encode() + end
                text = line * min(k1 - k0, RUN_LINES)
                whole, part = divmod(k1 - k0, RUN_LINES)
                out.add(*[text] * whole, memoryview(text)[:part * width])
            out.flush()
            continue
        for k in range(0, u.size, LINES):
            block = lines[:min(LINES, u.size - k)]
            _put_hex(block, 0, u[k:k + LINES], t.hex_digits)
            out.add(block.reshape(-1).data)
            out.flush()  # before the block's buffer is used again
    out.flush(whole=True)


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
    head = _comments(comment, "! ", ascii_only=True, width=PROGRAM_LINE)
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
    # punch tape format: the file's name, %_N_..._INI, first in its first line
    head = "%_N_AX_EEC_INI\n" + _comments(comment, "; ", ascii_only=True, width=PROGRAM_LINE)
    head += (f"; enctools table: {v.size} points 0..360 deg, lsb {t.count_deg!r} deg\n"
             "CHANDATA(1)\n")
    f.write(head.encode())
    _write_assignments(f, v, f"$AA_ENC_COMP[{e},", f",{ax}]=", t)
    f.write((f"$AA_ENC_COMP_STEP[{e},{ax}]={step!r}\n$AA_ENC_COMP_MIN[{e},{ax}]=0.0\n"
             f"$AA_ENC_COMP_MAX[{e},{ax}]=360.0\n$AA_ENC_COMP_IS_MODULO[{e},{ax}]=1\nM17\n").encode())
