"""Writers and readers of correction tables for FPGAs and motion controllers.

Every writer takes the signed table values (one per address) and writes one file;
every reader gives the values back, so an export can be checked. Big tables are
formatted with numpy (fixed-width lines built as byte arrays) or Arrow's CSV
writer, never a Python loop per line.

========  ==================================================================
bin       raw two's-complement words, little or big endian, 1/2/4 bytes each
ihex      Intel HEX: the raw image, 16 data bytes a record, type 04 extended
          linear address records (32-bit byte addresses: at most 4 GiB)
mif       Altera/Intel Memory Initialization File (WIDTH, DEPTH, HEX radix)
coe       Xilinx coefficient file (memory_initialization_radix=16;
          memory_initialization_vector=...;)
mem       Verilog ``$readmemh`` text: one hex word a line, // comments
csv       ``address,correction`` in decimal
acs       ACS SPiiPlus ACSPL+ program: a REAL array filled element by
          element, then ``ERRORMAP1D axis, zone, base, step, array`` and
          ``ERRORMAPON``; values in degrees
siemens   SINUMERIK interpolatory compensation (``$AA_ENC_COMP``) for a
          rotary axis with modulo: points 0..k, 0 deg and 360 deg both present
          with the same value, no gaps, ``$AA_ENC_COMP_STEP/MIN/MAX/IS_MODULO``;
          values in degrees
========  ==================================================================

Hex words are two's complement in ``width`` bits, ``ceil(width / 4)`` digits.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from enctools.errors import DataError, UsageError

FORMATS = ("bin", "ihex", "mif", "coe", "mem", "csv", "acs", "siemens")
EXTENSIONS = {".bin": "bin", ".rom": "bin", ".hex": "ihex", ".ihex": "ihex", ".mif": "mif",
              ".coe": "coe", ".mem": "mem", ".csv": "csv", ".prg": "acs", ".acs": "acs",
              ".spf": "siemens", ".mpf": "siemens", ".ini": "siemens"}
#: formats whose table is a controller's interpolation-point table (0 and 360 deg)
CONTROLLER = ("acs", "siemens")
#: entries a target accepts at most (None: only the 2^28 of enctools.rom).
#: Intel HEX: 32-bit byte addresses. The controllers' tables are sized by the
#: control's configuration (SINUMERIK MD38000 MM_ENC_COMP_MAX_POINTS, the ACS
#: controller's user memory): conservative defaults, raised with --max-entries.
MAX_ENTRIES: dict[str, int | None] = {"bin": None, "ihex": None, "mif": None, "coe": None,
                                      "mem": None, "csv": None, "acs": 100_000, "siemens": 5_000}
IHEX_MAX_BYTES = 1 << 32
_HEX = np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)
_HEX_VALUE = np.full(256, 255, dtype=np.uint8)
_HEX_VALUE[np.frombuffer(b"0123456789", np.uint8)] = np.arange(10)
_HEX_VALUE[np.frombuffer(b"ABCDEF", np.uint8)] = np.arange(10, 16)
_HEX_VALUE[np.frombuffer(b"abcdef", np.uint8)] = np.arange(10, 16)


@dataclass(frozen=True)
class Target:
    """How to write a table: format and its options."""

    fmt: str
    width: int = 16
    endian: str = "little"
    count_deg: float = 360.0 / 2 ** 23  # one LSB of the stored value [deg] (controllers)
    axis: str = "AX1"  # siemens axis name, or ACS axis number
    zone: int = 0  # ACS zone / SINUMERIK measuring system index
    name: str = "ENC_COMP"  # ACS array name
    max_entries: int | None = None

    @property
    def storage_bytes(self) -> int:
        return 1 if self.width <= 8 else 2 if self.width <= 16 else 4

    @property
    def hex_digits(self) -> int:
        return (self.width + 3) // 4


def format_for(path: str, fmt: str | None) -> str:
    """The table format: ``fmt`` if given, else from the file's extension."""
    if fmt:
        if fmt not in FORMATS:
            raise UsageError(f"unknown table format {fmt!r} (formats: {', '.join(FORMATS)})")
        return fmt
    ext = Path(path).suffix.lower()
    if ext not in EXTENSIONS:
        raise UsageError(f"cannot tell the table format of {path!r} from its extension; "
                         f"use --target ({', '.join(FORMATS)})")
    return EXTENSIONS[ext]


def check_capacity(target: Target, entries: int) -> None:
    """Refuse (UsageError, one line) a table the target cannot hold."""
    rows = entries + 1 if target.fmt in CONTROLLER else entries
    limit = target.max_entries if target.max_entries is not None else MAX_ENTRIES[target.fmt]
    if limit is not None and rows > limit:
        raise UsageError(
            f"{target.fmt}: {rows} table points exceed the {limit} this target holds; use fewer "
            f"--address-bits, or --max-entries if your control is configured for more")
    if target.fmt == "ihex" and entries * target.storage_bytes > IHEX_MAX_BYTES:
        raise UsageError(f"ihex: {entries * target.storage_bytes} bytes exceed the 4 GiB of "
                         "32-bit Intel HEX addresses")
    if target.fmt == "bin" and target.endian not in ("little", "big"):
        raise UsageError(f"--endian must be little or big, not {target.endian!r}")


# --------------------------------------------------------------------- helpers


def _twos(values: np.ndarray, width: int) -> np.ndarray:
    """Two's complement of signed values in ``width`` bits, as non-negative int64."""
    return values.astype(np.int64) & ((1 << width) - 1)


def _hex_tables() -> dict[int, np.ndarray]:
    """ASCII upper-case hex of every 4-, 8- and 16-bit value: {digits: uint8/16/32 words}."""
    if not _HEX_TABLES:
        k = np.arange(1 << 16)
        digits = np.ascontiguousarray(np.stack([_HEX[(k >> s) & 15] for s in (12, 8, 4, 0)], 1))
        _HEX_TABLES[4] = digits.view(np.uint32).reshape(-1)
        _HEX_TABLES[2] = np.ascontiguousarray(digits[:256, 2:]).view(np.uint16).reshape(-1)
        _HEX_TABLES[1] = _HEX.copy()
    return _HEX_TABLES


_HEX_TABLES: dict[int, np.ndarray] = {}


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
        word = (u >> (4 * left)) & ((1 << (4 * width)) - 1) if left else u & ((1 << (4 * width)) - 1)
        pieces.append(tables[width][word])
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
        flat.extend(p if isinstance(p, list) else [p])
    widths = [p.itemsize * (p.shape[1] if p.ndim == 2 else 1) if isinstance(p, np.ndarray)
              else len(p) for p in flat]
    w = sum(widths)
    buf = np.empty(n * w, dtype=np.uint8)
    col = 0
    for p, width in zip(flat, widths):
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


def _write_chunked(f: IO[bytes], values: np.ndarray, make: Any, chunk: int = LINES) -> None:
    for start in range(0, values.size, chunk):
        f.write(make(values[start:start + chunk], start).reshape(-1).data)


def _parse_hex_tokens(tokens: list[bytes] | np.ndarray, width: int, source: str) -> np.ndarray:
    """Signed values from hex tokens (two's complement in ``width`` bits)."""
    if len(tokens) == 0:
        return np.zeros(0, dtype=np.int64)
    lens = {len(t) for t in tokens} if isinstance(tokens, list) else {tokens.shape[1]}
    if isinstance(tokens, list) and len(lens) == 1:
        arr = np.frombuffer(b"".join(tokens), dtype=np.uint8).reshape(len(tokens), -1)
    elif isinstance(tokens, list):
        try:
            u = np.array([int(t, 16) for t in tokens], dtype=np.uint64)
        except ValueError:
            raise DataError(f"{source}: a value is not hexadecimal") from None
        return _signed(u, width)
    else:
        arr = tokens
    d = _HEX_VALUE[arr]
    if (d == 255).any():
        raise DataError(f"{source}: a value is not hexadecimal")
    if arr.shape[1] > 16:
        raise DataError(f"{source}: a hex value has more than 16 digits")
    acc = np.uint32 if arr.shape[1] <= 8 else np.uint64
    u = np.zeros(arr.shape[0], dtype=acc)
    for k in range(arr.shape[1]):
        u <<= acc(4)
        u |= d[:, k]
    return _signed(u.astype(np.uint64, copy=False), width)


def _signed(u: np.ndarray, width: int) -> np.ndarray:
    """Signed int64 from two's complement in ``width`` bits (u: uint64)."""
    s = u.astype(np.int64)
    if width >= 63:
        return s
    s &= (1 << width) - 1
    s -= (s >> (width - 1)) << width
    return s


def _lines_array(data: bytes):
    """Every line of ``data`` (with its newline) as an Arrow string array: no Python objects."""
    import pyarrow as pa
    buf = np.frombuffer(data, dtype=np.uint8)
    ends = np.flatnonzero(buf == 10) + 1
    if not data.endswith(b"\n"):
        ends = np.r_[ends, len(data)]
    offsets = np.r_[0, ends].astype(np.int64)
    arr = pa.Array.from_buffers(pa.large_binary(), offsets.size - 1,
                                [None, pa.py_buffer(offsets), pa.py_buffer(data)])
    try:
        return arr.cast(pa.large_string())
    except pa.ArrowInvalid:
        raise DataError("the file is not text (invalid UTF-8)") from None


def _hex_array(arr, width: int, src: str) -> np.ndarray:
    """Signed values of an Arrow string array of hex tokens (fixed width: vectorised)."""
    import pyarrow as pa
    import pyarrow.compute as pc
    arr = pc.utf8_trim_whitespace(arr)
    if len(arr) == 0:
        return np.zeros(0, dtype=np.int64)
    arr = arr.cast(pa.large_string()) if arr.type != pa.large_string() else arr
    lens = pc.binary_length(arr).to_numpy(zero_copy_only=False)
    if arr.null_count == 0 and lens.min() == lens.max() and lens[0] > 0:
        offs = np.frombuffer(arr.buffers()[1], dtype=np.int64)[arr.offset:arr.offset + len(arr) + 1]
        raw = np.frombuffer(arr.buffers()[2], dtype=np.uint8)[offs[0]:offs[-1]]
        return _parse_hex_tokens(raw.reshape(len(arr), int(lens[0])), width, src)
    return _parse_hex_tokens([x.encode() for x in arr.to_pylist()], width, src)


def _body_lines(data: bytes, comment: str):
    """Lines without comments (starting with ``comment``) and blank lines."""
    import pyarrow.compute as pc
    lines = pc.utf8_trim_whitespace(_lines_array(data))
    keep = pc.and_(pc.invert(pc.starts_with(lines, comment)), pc.greater(pc.utf8_length(lines), 0))
    return lines.filter(keep)


# --------------------------------------------------------------------- writers


def write_table(path: str, values: np.ndarray, target: Target, force: bool = False,
                comment: list[str] | None = None) -> int:
    """Write ``values`` to ``path`` atomically (temporary file, then rename); return its size."""
    check_capacity(target, values.size)
    from enctools.data.files import check_new_file, write_atomic

    check_new_file(path, force)
    write_atomic(path, lambda f: WRITERS[target.fmt](f, values, target, comment or []))
    return Path(path).stat().st_size


def _write_bin(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    dt = np.dtype(f"{'<' if t.endian == 'little' else '>'}i{t.storage_bytes}")
    values.astype(dt, copy=False).tofile(f)


def _write_ihex(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    dt = np.dtype(f"{'<' if t.endian == 'little' else '>'}i{t.storage_bytes}")
    image = np.ascontiguousarray(values.astype(dt, copy=False)).view(np.uint8)
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
    body = [len(data), (addr >> 8) & 0xFF, addr & 0xFF, rtype] + list(data)
    body.append((-sum(body)) & 0xFF)
    return b":" + bytes(body).hex().upper().encode() + b"\n"


def _write_mif(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    adig = max(1, (int(values.size - 1).bit_length() + 3) // 4)
    head = "".join(f"-- {c}\n" for c in comment)
    head += (f"WIDTH={t.width};\nDEPTH={values.size};\n\nADDRESS_RADIX=HEX;\nDATA_RADIX=HEX;\n\n"
             "CONTENT BEGIN\n")
    f.write(head.encode())

    def make(v: np.ndarray, start: int) -> np.ndarray:
        addr = _hex_columns(np.arange(start, start + v.size, dtype=np.int64), adig)
        return _lines([b"\t", addr, b" : ", _hex_columns(_twos(v, t.width), t.hex_digits),
                       b";\n"], v.size)

    _write_chunked(f, values, make)
    f.write(b"END;\n")


def _write_coe(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    head = "".join(f"; {c}\n" for c in comment)
    f.write((head + "memory_initialization_radix=16;\nmemory_initialization_vector=\n").encode())

    def make(v: np.ndarray, start: int) -> np.ndarray:
        lines = _lines([_hex_columns(_twos(v, t.width), t.hex_digits), b",\n"], v.size)
        if start + v.size == values.size:
            lines[-1, -2] = ord(";")
        return lines

    _write_chunked(f, values, make)


def _write_mem(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    f.write("".join(f"// {c}\n" for c in comment).encode())
    f.write(b"@0\n")
    _write_chunked(f, values, lambda v, s: _lines([_hex_columns(_twos(v, t.width),
                                                                t.hex_digits), b"\n"], v.size))


def _write_csv(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    import pyarrow as pa
    import pyarrow.csv as pcsv
    f.write("".join(f"# {c}\n" for c in comment).encode() + b"address,correction\n")
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


def _write_acs(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    v = _closed(values)
    step = 360.0 / values.size
    head = "".join(f"! {c}\n" for c in comment)
    head += (f"! enctools table: {v.size} points 0..360 deg, step {step!r} deg, "
             f"lsb {t.count_deg!r} deg\n"
             f"GLOBAL REAL {t.name}({v.size})\nINT AXIS_NO\nAXIS_NO = {t.axis}\n")
    f.write(head.encode())
    _write_assignments(f, v * t.count_deg, f"{t.name}(", ")=")
    f.write((f"ERRORUNMAP AXIS_NO, {t.zone}\n"
             f"ERRORMAP1D AXIS_NO, {t.zone}, 0, {step!r}, {t.name}\n"
             f"ERRORMAPON AXIS_NO, {t.zone}\nSTOP\n").encode())


def _write_siemens(f: IO[bytes], values: np.ndarray, t: Target, comment: list[str]) -> None:
    v = _closed(values)
    step = 360.0 / values.size
    e, ax = t.zone, t.axis
    head = "".join(f"; {c}\n" for c in comment)
    head += (f"; enctools table: {v.size} points 0..360 deg, lsb {t.count_deg!r} deg\n"
             "%_N_AX_EEC_INI\nCHANDATA(1)\n")
    f.write(head.encode())
    _write_assignments(f, v * t.count_deg, f"$AA_ENC_COMP[{e},", f",{ax}]=")
    f.write((f"$AA_ENC_COMP_STEP[{e},{ax}]={step!r}\n$AA_ENC_COMP_MIN[{e},{ax}]=0.0\n"
             f"$AA_ENC_COMP_MAX[{e},{ax}]=360.0\n$AA_ENC_COMP_IS_MODULO[{e},{ax}]=1\nM17\n").encode())


WRITERS = {"bin": _write_bin, "ihex": _write_ihex, "mif": _write_mif, "coe": _write_coe,
           "mem": _write_mem, "csv": _write_csv, "acs": _write_acs, "siemens": _write_siemens}


# --------------------------------------------------------------------- readers


def read_table(path: str, target: Target) -> np.ndarray:
    """The signed values of a table file (DataError, one line, when it is malformed)."""
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        raise DataError(f"{path}: no such file") from None
    try:
        return READERS[target.fmt](data, target, str(path))
    except (ValueError, OverflowError, IndexError, KeyError) as exc:
        # a malformed word the general readers meet one at a time
        raise DataError(f"{path}: not a readable {target.fmt} table "
                        f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None


def _read_bin(data: bytes, t: Target, src: str) -> np.ndarray:
    if len(data) % t.storage_bytes:
        raise DataError(f"{src}: {len(data)} bytes is not a whole number of "
                        f"{t.storage_bytes}-byte words")
    dt = np.dtype(f"{'<' if t.endian == 'little' else '>'}i{t.storage_bytes}")
    return np.frombuffer(data, dtype=dt).astype(np.int64)


def _read_ihex_fast(data: bytes, t: Target, src: str) -> np.ndarray | None:
    """Intel HEX decoded whole: every record at once, the image from its data records in order.

    None when anything is unusual (blanks, unknown or misplaced records, gaps, records
    out of order): the record-by-record reader then reads it or names the line at fault.
    """
    if b" " in data or b"\t" in data:
        return None
    buf = np.frombuffer(data, dtype=np.uint8)
    ends = np.flatnonzero(buf == 10)
    if not data.endswith(b"\n"):
        ends = np.r_[ends, len(data)]
    starts = np.r_[0, ends[:-1] + 1]
    chars = ends - starts
    cr = ends > starts
    cr[cr] = buf[ends[cr] - 1] == 13
    chars -= cr
    if chars.size == 0 or chars.min() < 11 or (chars % 2 == 0).any() or (buf[starts] != 58).any():
        return None
    try:
        rec = np.frombuffer(bytes.fromhex(data.translate(None, b":\r\n").decode("ascii")), np.uint8)
    except ValueError:
        return None
    size = (chars - 1) // 2  # bytes a record
    off = np.r_[0, np.cumsum(size)[:-1]]
    length, rtype = rec[off].astype(np.int64), rec[off + 3]
    if (length + 5 != size).any() or (np.add.reduceat(rec, off, dtype=np.uint64) & 255).any():
        return None
    eof = np.flatnonzero(rtype == 1)
    if eof.size != 1 or eof[0] != rtype.size - 1 or not np.isin(rtype, (0, 1, 4)).all():
        return None
    ext = np.flatnonzero(rtype == 4)
    if (length[ext] != 2).any():
        return None
    upper = np.zeros(rtype.size, dtype=np.int64)
    upper[ext] = ((rec[off[ext] + 4].astype(np.int64) << 8) | rec[off[ext] + 5]) << 16
    last = np.where(rtype == 4, np.arange(rtype.size), 0)
    upper = upper[np.maximum.accumulate(last)]
    data_rec = np.flatnonzero(rtype == 0)
    addr = upper[data_rec] + ((rec[off[data_rec] + 1].astype(np.int64) << 8) | rec[off[data_rec] + 2])
    n = length[data_rec]
    if data_rec.size and (addr[0] != 0 or (addr[1:] != addr[:-1] + n[:-1]).any()):
        return None
    keep = np.zeros(rec.size + 1, dtype=np.int8)  # +1 at each payload's start, -1 after its end
    keep[off[data_rec] + 4] = 1  # distinct places: a payload ends on its own checksum byte
    keep[off[data_rec] + 4 + n] = -1
    image = rec[np.cumsum(keep[:-1], dtype=np.int8).astype(bool)]
    return _read_bin(image.tobytes(), t, src)


def _read_ihex(data: bytes, t: Target, src: str) -> np.ndarray:
    fast = _read_ihex_fast(data, t, src)
    if fast is not None:
        return fast
    chunks: dict[int, bytes] = {}
    upper = 0
    eof = False
    for no, raw in enumerate(data.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        if not line.startswith(b":"):
            raise DataError(f"{src}: line {no} does not start with ':'")
        try:
            rec = bytes.fromhex(line[1:].decode("ascii"))
        except ValueError:
            raise DataError(f"{src}: line {no} is not hexadecimal") from None
        if len(rec) < 5 or len(rec) != rec[0] + 5 or sum(rec) & 0xFF:
            raise DataError(f"{src}: line {no}: bad record length or checksum")
        rtype, addr, payload = rec[3], (rec[1] << 8) | rec[2], rec[4:-1]
        if rtype == 0:
            chunks[upper + addr] = payload
        elif rtype == 1:
            eof = True
            break
        elif rtype == 4:
            upper = int.from_bytes(payload, "big") << 16
        elif rtype == 2:
            upper = int.from_bytes(payload, "big") << 4
        elif rtype not in (3, 5):
            raise DataError(f"{src}: line {no}: unknown record type {rtype}")
    if not eof:
        raise DataError(f"{src}: no end-of-file record (truncated?)")
    size = max((a + len(b) for a, b in chunks.items()), default=0)
    image = bytearray(size)
    filled = 0
    for a, b in chunks.items():
        image[a:a + len(b)] = b
        filled += len(b)
    if filled != size:
        raise DataError(f"{src}: the records leave gaps in the image")
    return _read_bin(bytes(image), t, src)


def _hex_pairs() -> np.ndarray:
    """Value of every two ASCII bytes read as a native uint16: 0..255, or 256 if not hex."""
    if "pairs" not in _HEX_TABLES:
        v = _HEX_VALUE.astype(np.uint16)
        v[v == 255] = 256
        _HEX_TABLES["ones"] = v  # one digit: 0..15, or 256 if not hex
        two = np.where((v[:, None] | v[None, :]) & 256, 256, (v[:, None] << 4) | v[None, :])
        code = np.frombuffer(np.arange(1 << 16, dtype=np.uint16).tobytes(), np.uint8).reshape(-1, 2)
        _HEX_TABLES["pairs"] = two[code[:, 0], code[:, 1]].astype(np.uint16)
    return _HEX_TABLES["pairs"]


@dataclass(frozen=True)
class _Rows:
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

    def chunks(self, rows: int = 1 << 20) -> Iterator[tuple[int, _Rows]]:
        """(first line, lines) in blocks of ``rows`` lines: work arrays stay small."""
        for k in range(0, self.n, rows):
            yield k, _Rows(self.data, self.start + k * self.width, min(rows, self.n - k), self.width)

    def hex(self, a: int, b: int, width: int) -> np.ndarray | None:
        """Signed values (two's complement in ``width`` bits) of the hex digits in columns a..b-1.

        Two digits a table look-up on unaligned uint16 words read straight from the
        lines, a block of lines at a time; None if a digit is not hex or there are
        more than 16.
        """
        out = np.empty(self.n, dtype=np.int64)
        for k, block in self.chunks():
            v = block._hex(a, b, width)
            if v is None:
                return None
            out[k:k + block.n] = v
        return out

    def counts(self, a: int, b: int) -> bool | None:
        """Whether the hex numbers in columns a..b-1 are 0, 1, 2, ... (None: not all hex)."""
        for k, block in self.chunks():
            v = block._hex(a, b, 64)
            if v is None:
                return None
            if not np.array_equal(v, np.arange(k, k + block.n)):
                return False
        return True

    def _hex(self, a: int, b: int, width: int) -> np.ndarray | None:
        digits = b - a
        if not 0 < digits <= 16:
            return None
        acc = np.uint32 if digits <= 8 else np.uint64
        u = np.zeros(self.n, dtype=acc)
        bad = np.zeros(self.n, dtype=np.uint16)
        if digits % 2:
            _hex_pairs()
            one = _HEX_TABLES["ones"][self.word(a, 1)]
            bad |= one
            u |= one
            a += 1
        pairs = _hex_pairs()
        for col in range(a, b, 2):
            v = pairs[self.word(col, 2)]
            bad |= v
            u <<= acc(8)
            u |= v  # a non-hex pair (256) spoils u, but then bad says so
        if (bad & 256).any():
            return None
        if width in (8, 16, 32) and 4 * digits == width:
            return u.astype(np.dtype(f"u{width // 8}")).view(np.dtype(f"i{width // 8}")).astype(np.int64)
        return _signed(u.astype(np.uint64), width) if width < 64 else u.astype(np.int64)


def _fixed_rows(data: bytes, start: int, stop: int) -> _Rows | None:
    """The lines of data[start:stop] when every one has the same length (newline included)."""
    nl = data.find(b"\n", start, stop)
    width = nl + 1 - start
    if nl < 0 or (stop - start) % width:
        return None
    rows = _Rows(data, start, (stop - start) // width, width)
    return rows if (rows.word(width - 1, 1) == 10).all() else None


def _read_mif_fixed(data: bytes, src: str) -> np.ndarray | None:
    """A MIF file whose content lines are all alike (``addr : value;``, hex): by columns.

    None for anything else (the general reader then reads it or names the fault).
    """
    begin, end = data.find(b"BEGIN"), data.rfind(b"END")
    if begin < 0 or end < begin:
        return None
    head = re.sub(rb"%[^%]*%", b"", re.sub(rb"--[^\n]*", b"", data[:begin]))
    if not re.search(rb"CONTENT\s*$", head):
        return None
    keys = {k.strip().upper(): v.strip().upper()
            for k, v in re.findall(rb"(\w+)\s*=\s*([^;]+);", head)}
    try:
        width, depth = int(keys[b"WIDTH"]), int(keys[b"DEPTH"])
    except (KeyError, ValueError):
        return None
    if keys.get(b"ADDRESS_RADIX", b"HEX") != b"HEX" or keys.get(b"DATA_RADIX", b"HEX") != b"HEX":
        return None
    start = data.find(b"\n", begin, end) + 1
    if start <= 0 or data[begin + 5:start].strip() or depth == 0:
        return None
    rows = _fixed_rows(data, start, end)
    if rows is None or rows.n != depth:
        return None
    m = re.fullmatch(rb"(\s*)([0-9A-Fa-f]+)(\s*:\s*)([0-9A-Fa-f]+)(\s*;\s*)", rows.line(0))
    if m is None or not all(rows.same(*m.span(g)) for g in (1, 3, 5)):
        return None
    counting = rows.counts(*m.span(2))
    values = rows.hex(*m.span(4), width)
    if counting is None or values is None:
        return None
    if counting:
        return values
    addr = rows.hex(*m.span(2), 64)
    if addr is None:
        return None
    if not np.array_equal(np.sort(addr), np.arange(depth)):
        raise DataError(f"{src}: addresses do not cover 0..DEPTH-1={depth - 1} once each")
    out = np.empty(depth, dtype=np.int64)
    out[addr] = values
    return out


def _read_mif(data: bytes, t: Target, src: str) -> np.ndarray:
    fixed = _read_mif_fixed(data, src)
    if fixed is not None:
        return fixed
    text = re.sub(rb"--[^\n]*", b"", data)
    text = re.sub(rb"%[^%]*%", b"", text)
    head, sep, body = text.partition(b"CONTENT")
    if not sep:
        raise DataError(f"{src}: no CONTENT section (not a MIF file)")
    keys = {k.strip().upper(): v.strip().upper()
            for k, v in re.findall(rb"(\w+)\s*=\s*([^;]+);", head)}
    try:
        width, depth = int(keys[b"WIDTH"]), int(keys[b"DEPTH"])
    except (KeyError, ValueError):
        raise DataError(f"{src}: WIDTH and DEPTH must be given before CONTENT") from None
    radix = {b"HEX": 16, b"DEC": 10, b"UNS": 10, b"BIN": 2, b"OCT": 8}
    arad = radix.get(keys.get(b"ADDRESS_RADIX", b"HEX"), 16)
    drad = keys.get(b"DATA_RADIX", b"HEX")
    body = body.partition(b"BEGIN")[2].rpartition(b"END")[0]
    out = np.zeros(depth, dtype=np.int64)
    seen = np.zeros(depth, dtype=bool)
    if arad == 16 and drad == b"HEX" and b"[" not in body:
        import pyarrow.compute as pc
        lines = _body_lines(body, "--")
        fixed = _fixed_mif(lines, width, depth, src)
        if fixed is not None:
            return fixed
        pattern = r"^(?P<a>[0-9A-Fa-f]+)\s*:\s*(?P<v>[0-9A-Fa-f]+)\s*;$"
        if pc.all(pc.match_substring_regex(lines, pattern)).as_py():
            parts = pc.extract_regex(lines, pattern)
            a = _hex_array(parts.field("a"), 63, src)
            if a.size and (a.min() < 0 or a.max() >= depth):
                raise DataError(f"{src}: an address is outside DEPTH={depth}")
            out[a] = _hex_array(parts.field("v"), width, src)
            seen[a] = True
            if not seen.all():
                raise DataError(f"{src}: {int((~seen).sum())} of {depth} addresses have no value")
            return out
    stmts = body.split(b";")
    simple = re.compile(rb"^\s*([0-9A-Fa-f]+)\s*:\s*([0-9A-Fa-f]+)\s*$")
    addrs, vals = [], []
    for s in stmts:
        if not s.strip():
            continue
        m = simple.match(s)
        if m and arad == 16 and drad == b"HEX":
            addrs.append(m.group(1))
            vals.append(m.group(2))
            continue
        lhs, _, rhs = s.partition(b":")
        words = rhs.split()
        lhs = lhs.strip()
        if lhs.startswith(b"["):
            a0, a1 = (int(x, arad) for x in lhs.strip(b"[]").split(b".."))
            rng = range(a0, a1 + 1)
        else:
            a0 = int(lhs, arad)
            rng = range(a0, a0 + len(words))
        for i, a in enumerate(rng):
            w = words[i % len(words)] if lhs.startswith(b"[") else words[i]
            v = int(w, radix.get(drad, 16))
            if drad == b"DEC" and v < 0:
                v &= (1 << width) - 1
            out[a] = _signed(np.array([v], np.uint64), width)[0]
            seen[a] = True
    if addrs:
        a = _parse_hex_tokens(addrs, 63, src)
        if a.min() < 0 or a.max() >= depth:
            raise DataError(f"{src}: an address is outside DEPTH={depth}")
        out[a] = _parse_hex_tokens(vals, width, src)
        seen[a] = True
    if not seen.all():
        raise DataError(f"{src}: {int((~seen).sum())} of {depth} addresses have no value")
    return out


def _fixed_mif(lines, width: int, depth: int, src: str) -> np.ndarray | None:
    """MIF body lines all alike (``addr : value;`` at fixed columns): parsed as one 2D array."""
    import pyarrow as pa
    import pyarrow.compute as pc
    if len(lines) != depth or depth == 0:
        return None
    lines = lines.cast(pa.large_string())
    lens = pc.binary_length(lines).to_numpy(zero_copy_only=False)
    if lens.min() != lens.max():
        return None
    offs = np.frombuffer(lines.buffers()[1], dtype=np.int64)[lines.offset:lines.offset + depth + 1]
    raw = np.frombuffer(lines.buffers()[2], dtype=np.uint8)[offs[0]:offs[-1]].reshape(depth, -1)
    first = bytes(raw[0])
    m = re.fullmatch(rb"([0-9A-Fa-f]+)(\s*:\s*)([0-9A-Fa-f]+)(\s*;)", first)
    if m is None:
        return None
    for g in (2, 4):
        a, b = m.span(g)
        if not (raw[:, a:b] == raw[0, a:b]).all():
            return None
    addr = _parse_hex_tokens(np.ascontiguousarray(raw[:, m.start(1):m.end(1)]), 63, src)
    if not np.array_equal(addr, np.arange(depth)):
        order = np.argsort(addr)
        if not np.array_equal(addr[order], np.arange(depth)):
            raise DataError(f"{src}: addresses do not cover 0..DEPTH-1={depth - 1} once each")
    out = np.empty(depth, dtype=np.int64)
    out[addr] = _parse_hex_tokens(np.ascontiguousarray(raw[:, m.start(3):m.end(3)]), width, src)
    return out


def _hex_column_lines(data: bytes, start: int, stop: int, tail: bytes, width: int
                      ) -> np.ndarray | None:
    """Values of lines ``<hex><tail>`` all alike in data[start:stop], or None (general reader)."""
    rows = _fixed_rows(data, start, stop)
    if rows is None:
        return None
    m = re.fullmatch(rb"([ \t]*)([0-9A-Fa-f]+)(" + tail + rb")", rows.line(0))
    if m is None or not (rows.same(*m.span(1)) and rows.same(*m.span(3))):
        return None
    return rows.hex(*m.span(2), width)


def _read_coe_fixed(data: bytes, t: Target) -> np.ndarray | None:
    """A hex COE file as written here: one ``value,`` a line, the last ``value;``."""
    m = re.search(rb"memory_initialization_vector\s*=[ \t]*\r?\n", data, re.IGNORECASE)
    if m is None or not re.search(rb"memory_initialization_radix\s*=\s*16\s*;", data[:m.start()],
                                  re.IGNORECASE):
        return None
    end = data.rstrip().rfind(b"\n") + 1
    last = re.fullmatch(rb"\s*([0-9A-Fa-f]+)\s*;\s*", data[end:])
    if last is None or end <= m.end():
        return None
    body = _hex_column_lines(data, m.end(), end, rb"[ \t]*,[ \t]*\r?\n", t.width)
    if body is None:
        return None
    return np.append(body, _parse_hex_tokens([last.group(1)], t.width, ""))


def _read_mem_fixed(data: bytes, t: Target) -> np.ndarray | None:
    """A $readmemh file as written here: // comment lines, @0, one hex word a line."""
    pos = 0
    while data.startswith(b"//", pos):
        pos = data.find(b"\n", pos) + 1
        if pos == 0:
            return None
    at = re.match(rb"@0+[ \t]*\r?\n", data[pos:pos + 64])
    pos += at.end() if at else 0
    if pos >= len(data):
        return None
    return _hex_column_lines(data, pos, len(data), rb"[ \t]*\r?\n", t.width)


def _read_coe(data: bytes, t: Target, src: str) -> np.ndarray:
    fixed = _read_coe_fixed(data, t)
    if fixed is not None:
        return fixed
    m = re.search(rb"memory_initialization_radix\s*=\s*(\d+)\s*;", data, re.IGNORECASE)
    v = re.search(rb"memory_initialization_vector\s*=([^;]*);", data, re.IGNORECASE)
    if not (m and v):
        raise DataError(f"{src}: no memory_initialization_radix/vector (not a COE file)")
    if int(m.group(1)) == 16:
        import pyarrow.compute as pc
        lines = _body_lines(v.group(1), ";")
        if not pc.any(pc.match_substring_regex(lines, r",.*,|\s")).as_py():
            return _hex_array(pc.replace_substring(lines, ",", ""), t.width, src)
    tokens = v.group(1).replace(b",", b" ").split()
    if int(m.group(1)) == 16:
        return _parse_hex_tokens(tokens, t.width, src)
    u = np.array([int(x, int(m.group(1))) for x in tokens], dtype=np.int64)
    return _signed(u.astype(np.uint64), t.width)


def _read_mem(data: bytes, t: Target, src: str) -> np.ndarray:
    fixed = _read_mem_fixed(data, t)
    if fixed is not None:
        return fixed
    import pyarrow.compute as pc
    if b"/*" not in data:
        lines = _body_lines(data, "//")
        if len(lines) and lines[0].as_py() == "@0":
            lines = lines.slice(1)
        if not pc.any(pc.match_substring_regex(lines, r"[@\s/]")).as_py():
            return _hex_array(lines, t.width, src)
    text = re.sub(rb"//[^\n]*", b"", data)
    text = re.sub(rb"/\*.*?\*/", b"", text, flags=re.DOTALL)
    tokens = text.split()
    if not any(tok.startswith(b"@") for tok in tokens[1:]):
        if tokens and tokens[0].startswith(b"@"):
            if int(tokens[0][1:], 16) != 0:
                raise DataError(f"{src}: the table does not start at address 0")
            tokens = tokens[1:]
        return _parse_hex_tokens(tokens, t.width, src)
    out: dict[int, int] = {}
    addr = 0
    for tok in tokens:
        if tok.startswith(b"@"):
            addr = int(tok[1:], 16)
        else:
            out[addr] = int(tok, 16)
            addr += 1
    n = max(out) + 1
    if len(out) != n:
        raise DataError(f"{src}: addresses have gaps")
    return _signed(np.array([out[i] for i in range(n)], dtype=np.uint64), t.width)


def _read_csv(data: bytes, t: Target, src: str) -> np.ndarray:
    import io

    import pyarrow as pa
    import pyarrow.csv as pcsv
    body = data
    while body.startswith(b"#"):
        body = body.partition(b"\n")[2]
    try:
        table = pcsv.read_csv(io.BytesIO(body))
    except pa.ArrowInvalid as exc:
        raise DataError(f"{src}: not a CSV table ({str(exc).splitlines()[0]})") from None
    if table.column_names[:2] != ["address", "correction"]:
        raise DataError(f"{src}: the header must be 'address,correction'")
    a = table.column("address").to_numpy()
    if not np.array_equal(a, np.arange(a.size)):
        raise DataError(f"{src}: addresses are not 0, 1, 2, ... without gaps")
    corr = table.column("correction")
    if not pa.types.is_integer(corr.type) or corr.null_count:
        raise DataError(f"{src}: a correction is not a whole number")
    return corr.to_numpy().astype(np.int64)


def _indexed(data: bytes, prefix: bytes, pattern: str, src: str) -> np.ndarray:
    """Values of the lines starting with ``prefix`` that match ``pattern`` (groups i, v), by index."""
    import pyarrow as pa
    import pyarrow.compute as pc
    lines = pc.utf8_trim_whitespace(_lines_array(data))
    lines = lines.filter(pc.starts_with(lines, prefix.decode()))
    if len(lines) == 0:
        raise DataError(f"{src}: no table entries found")
    ok = pc.match_substring_regex(lines, pattern)
    if not pc.all(ok).as_py():
        bad = str(lines.filter(pc.invert(ok))[0].as_py())
        raise DataError(f"{src}: cannot read the table line {bad.strip()!r}")
    parts = pc.extract_regex(lines, pattern)
    idx = pc.cast(parts.field("i"), pa.int64()).to_numpy()
    try:
        val = pc.cast(parts.field("v"), pa.float64()).to_numpy()
    except pa.ArrowInvalid:
        raise DataError(f"{src}: a table value is not a number") from None
    if not np.array_equal(np.sort(idx), np.arange(idx.size)):
        raise DataError(f"{src}: the table's indices have gaps or repeats")
    out = np.empty(idx.size)
    out[idx] = val
    return out


def _from_closed(values_deg: np.ndarray, t: Target, src: str) -> np.ndarray:
    if not np.all(np.isfinite(values_deg)):
        raise DataError(f"{src}: a table value is not a finite number")
    counts = values_deg / t.count_deg
    q = np.rint(counts)
    if np.max(np.abs(q)) >= 2.0 ** 62:
        raise DataError(f"{src}: a table value is beyond any word width")
    if np.max(np.abs(q - counts)) > 1e-3:
        raise DataError(f"{src}: values are not whole multiples of the lsb {t.count_deg!r} deg")
    if q[0] != q[-1]:
        raise DataError(f"{src}: the 0 deg and 360 deg values differ (a rotary table must close)")
    return q[:-1].astype(np.int64)


def _read_acs(data: bytes, t: Target, src: str) -> np.ndarray:
    name = re.escape(t.name.encode())
    vals = _indexed(data, t.name.encode() + b"(",
                    r"^\s*" + re.escape(t.name) + r"\((?P<i>\d+)\)\s*=\s*(?P<v>[-+0-9.eE]+)\s*$", src)
    m = re.search(rb"ERRORMAP1D\s+[^,]+,\s*[^,]+,\s*([-+0-9.eE]+)\s*,\s*([-+0-9.eE]+)\s*,\s*" + name,
                  data)
    if not m:
        raise DataError(f"{src}: no ERRORMAP1D statement for array {t.name}")
    base, step = float(m.group(1)), float(m.group(2))
    if base != 0.0 or abs(step * (vals.size - 1) - 360.0) > 1e-9:
        raise DataError(f"{src}: the map does not span 0..360 deg")
    return _from_closed(vals, t, src)


def _read_siemens(data: bytes, t: Target, src: str) -> np.ndarray:
    vals = _indexed(data, b"$AA_ENC_COMP[",
                    r"^\s*\$AA_ENC_COMP\[\s*\d+\s*,\s*(?P<i>\d+)\s*,\s*\w+\s*\]\s*="
                    r"\s*(?P<v>[-+0-9.eE]+)\s*$", src)
    def key(name: bytes) -> float:
        m = re.search(rb"\$AA_ENC_COMP_" + name + rb"\[[^]]*\]\s*=\s*([-+0-9.eE]+)", data)
        if not m:
            raise DataError(f"{src}: no $AA_ENC_COMP_{name.decode()}")
        return float(m.group(1))
    step, lo, hi, modulo = key(b"STEP"), key(b"MIN"), key(b"MAX"), key(b"IS_MODULO")
    if lo != 0.0 or hi != 360.0 or modulo != 1:
        raise DataError(f"{src}: a rotary table needs MIN=0, MAX=360 and IS_MODULO=1")
    if abs(step * (vals.size - 1) - 360.0) > 1e-9:
        raise DataError(f"{src}: {vals.size} points at STEP={step} do not span 0..360 deg")
    return _from_closed(vals, t, src)


READERS = {"bin": _read_bin, "ihex": _read_ihex, "mif": _read_mif, "coe": _read_coe,
           "mem": _read_mem, "csv": _read_csv, "acs": _read_acs, "siemens": _read_siemens}
