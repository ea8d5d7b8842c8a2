"""Readers of correction tables: the signed values [LSB] back from a file, one per address.

Each text format written in fixed-width lines has two readers:

- ``fast_<fmt>``: a file as this project writes it, read whole with numpy (Intel HEX)
  or by columns (:mod:`~enctools.models.romformats.columns`: MIF, COE, ``$readmemh``).
  It returns None for anything else, without naming a fault.
- ``read_<fmt>``: anything else the format allows (other record lengths, comments,
  ranges, radices, line breaks); it reads the file or raises DataError naming the fault.

Binary images, CSV tables (Arrow's CSV reader) and the controllers' programs (Arrow's
string kernels) have one reader each. A reader takes the file's bytes, the
:class:`~enctools.models.romformats.words.Target` and the file's name for messages.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

import numpy as np
import pyarrow as pa

from enctools.errors import DataError
from enctools.models.romformats.columns import fixed_rows, hex_lines
from enctools.models.romformats.words import (
    HEX_DIGIT,
    MAX_TABLE_BITS,
    Target,
    image_values,
    signed,
)

#: MIF radix names and their bases
RADIX = {b"HEX": 16, b"DEC": 10, b"UNS": 10, b"BIN": 2, b"OCT": 8}


def read_bin(data: bytes, t: Target, src: str) -> np.ndarray:
    """Raw two's-complement words in the target's size and byte order."""
    return image_values(data, t, src)


# --------------------------------------------------------------------- Intel HEX


def ihex_records(data: bytes) -> tuple[np.ndarray, np.ndarray] | None:
    """Every record's bytes in one array and where each starts, or None if a line is unusual."""
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
    if (rec[off].astype(np.int64) + 5 != size).any():
        return None
    if (np.add.reduceat(rec, off, dtype=np.uint64) & 255).any():
        return None
    return rec, off


def fast_ihex(data: bytes, t: Target, src: str) -> np.ndarray | None:
    """Intel HEX decoded whole: every record at once, the image from its data records in order.

    None when anything is unusual (blanks, unknown or misplaced records, gaps, records
    out of order).
    """
    records = ihex_records(data)
    if records is None:
        return None
    rec, off = records
    length, rtype = rec[off].astype(np.int64), rec[off + 3]
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
    at = off[data_rec]
    addr = upper[data_rec] + ((rec[at + 1].astype(np.int64) << 8) | rec[at + 2])
    n = length[data_rec]
    if data_rec.size and (addr[0] != 0 or (addr[1:] != addr[:-1] + n[:-1]).any()):
        return None
    keep = np.zeros(rec.size + 1, dtype=np.int8)  # +1 at each payload's start, -1 after its end
    keep[at + 4] = 1  # distinct places: a payload ends on its own checksum byte
    keep[at + 4 + n] = -1
    image = rec[np.cumsum(keep[:-1], dtype=np.int8).astype(bool)]
    return image_values(image.tobytes(), t, src)


def read_ihex(data: bytes, t: Target, src: str) -> np.ndarray:
    """Intel HEX record by record: any record length and order, blanks, segment (02) and
    linear (04) extended addresses; start records (03, 05) are skipped."""
    chunks: dict[int, bytes] = {}
    upper = 0
    for no, raw in enumerate(data.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        rtype, addr, payload = _ihex_record(line, no, src)
        if rtype == 0:
            chunks[upper + addr] = payload
        elif rtype == 1:
            break
        elif rtype in (2, 4):
            upper = int.from_bytes(payload, "big") << (16 if rtype == 4 else 4)
        elif rtype not in (3, 5):
            msg = f"{src}: line {no}: unknown record type {rtype}"
            raise DataError(msg)
    else:
        msg = f"{src}: no end-of-file record (truncated?)"
        raise DataError(msg)
    size = max((a + len(b) for a, b in chunks.items()), default=0)
    if sum(len(b) for b in chunks.values()) != size:  # before the image is allocated
        msg = f"{src}: the records leave gaps in the image (or overlap)"
        raise DataError(msg)
    image = bytearray(size)
    for a, b in chunks.items():
        image[a:a + len(b)] = b
    return image_values(bytes(image), t, src)


def _ihex_record(line: bytes, no: int, src: str) -> tuple[int, int, bytes]:
    """Type, 16-bit address and payload of one record (line ``no``), its checksum checked."""
    if not line.startswith(b":"):
        msg = f"{src}: line {no} does not start with ':'"
        raise DataError(msg)
    try:
        rec = bytes.fromhex(line[1:].decode("ascii"))
    except ValueError:
        msg = f"{src}: line {no} is not hexadecimal"
        raise DataError(msg) from None
    if len(rec) < 5 or len(rec) != rec[0] + 5 or sum(rec) & 0xFF:
        msg = f"{src}: line {no}: bad record length or checksum"
        raise DataError(msg)
    return rec[3], (rec[1] << 8) | rec[2], rec[4:-1]


# --------------------------------------------------------------------- hex words


def _hex_tokens(tokens: list[bytes], width: int, src: str) -> np.ndarray:
    """Signed values (two's complement in ``width`` bits) of hex tokens.

    Tokens of one length (up to 16 digits) are decoded as one array of digits.
    """
    if not tokens:
        return np.zeros(0, dtype=np.int64)
    if len({len(tok) for tok in tokens}) == 1 and len(tokens[0]) <= 16:
        d = HEX_DIGIT[np.frombuffer(b"".join(tokens), np.uint8).reshape(len(tokens), -1)]
        if (d == 255).any():
            msg = f"{src}: a value is not hexadecimal"
            raise DataError(msg)
        u = np.zeros(len(tokens), dtype=np.uint64)
        for k in range(d.shape[1]):
            u <<= np.uint64(4)
            u |= d[:, k]
        return signed(u, width)
    try:
        u = np.array([int(tok, 16) for tok in tokens], dtype=np.uint64)
    except ValueError:
        msg = f"{src}: a value is not hexadecimal"
        raise DataError(msg) from None
    return signed(u, width)


def _by_address(addr: np.ndarray, values: np.ndarray, depth: int, src: str) -> np.ndarray:
    """The values placed at their addresses 0..depth-1, each address given a value."""
    if addr.size and (addr.min() < 0 or addr.max() >= depth):
        msg = f"{src}: an address is outside DEPTH={depth}"
        raise DataError(msg)
    out = np.zeros(depth, dtype=np.int64)
    out[addr] = values
    seen = np.zeros(depth, dtype=bool)
    seen[addr] = True
    if not seen.all():
        msg = f"{src}: {int((~seen).sum())} of {depth} addresses have no value"
        raise DataError(msg)
    return out


# --------------------------------------------------------------------- MIF


def _mif_keys(head: bytes) -> dict[bytes, bytes]:
    """The ``KEY = value;`` settings of a MIF header, keys and values upper-case."""
    return {k.strip().upper(): v.strip().upper()
            for k, v in re.findall(rb"(\w+)\s*=\s*([^;]+);", head)}


def fast_mif(data: bytes, t: Target, src: str) -> np.ndarray | None:
    """A MIF file whose content lines are all alike (``addr : value;``, hex): by columns.

    Addresses that count 0, 1, 2, ... are checked block by block, without an array of
    them; others are placed by address (DataError unless each of 0..DEPTH-1 comes once).
    """
    begin, end = data.find(b"BEGIN"), data.rfind(b"END")
    while begin >= 0 and b"--" in data[data.rfind(b"\n", 0, begin) + 1:begin]:  # a comment's
        begin = data.find(b"BEGIN", begin + 5)
    if begin < 0 or end < begin:
        return None
    head = re.sub(rb"%[^%]*%", b"", re.sub(rb"--[^\n]*", b"", data[:begin]))
    if not re.search(rb"CONTENT\s*$", head):
        return None
    keys = _mif_keys(head)
    try:
        width, depth = int(keys[b"WIDTH"]), int(keys[b"DEPTH"])
    except (KeyError, ValueError):
        return None
    if keys.get(b"ADDRESS_RADIX", b"HEX") != b"HEX" or keys.get(b"DATA_RADIX", b"HEX") != b"HEX":
        return None
    start = data.find(b"\n", begin, end) + 1
    if start <= 0 or data[begin + 5:start].strip() or depth == 0:
        return None
    rows = fixed_rows(data, start, end)
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
        msg = f"{src}: addresses do not cover 0..DEPTH-1={depth - 1} once each"
        raise DataError(msg)
    out = np.empty(depth, dtype=np.int64)
    out[addr] = values
    return out


def read_mif(data: bytes, t: Target, src: str) -> np.ndarray:
    """Any MIF: ``--`` and ``% %`` comments, every radix, ``addr : v1 v2 ...;`` runs and
    ``[a0..a1] : v1 v2 ...;`` ranges (the values repeated over the range)."""
    text = re.sub(rb"%[^%]*%", b"", re.sub(rb"--[^\n]*", b"", data))
    head, sep, body = text.partition(b"CONTENT")
    if not sep:
        msg = f"{src}: no CONTENT section (not a MIF file)"
        raise DataError(msg)
    keys = _mif_keys(head)
    try:
        width, depth = int(keys[b"WIDTH"]), int(keys[b"DEPTH"])
    except (KeyError, ValueError):
        msg = f"{src}: WIDTH and DEPTH must be given before CONTENT"
        raise DataError(msg) from None
    if not 0 < depth <= 1 << MAX_TABLE_BITS:
        msg = f"{src}: DEPTH={depth}, not 1..{1 << MAX_TABLE_BITS} (2^{MAX_TABLE_BITS}) entries"
        raise DataError(msg)
    arad = RADIX.get(keys.get(b"ADDRESS_RADIX", b"HEX"), 16)
    drad = RADIX.get(keys.get(b"DATA_RADIX", b"HEX"), 16)
    statements = [_mif_statement(stmt, arad, drad, src)
                  for stmt in body.partition(b"BEGIN")[2].rpartition(b"END")[0].split(b";")
                  if stmt.strip()]
    if any(a.start < 0 or a.stop > depth for a, _ in statements if len(a)):
        msg = f"{src}: an address is outside DEPTH={depth}"
        raise DataError(msg)
    covered = sum(len(a) for a, _ in statements)
    if covered > depth:  # before the values are spread over their addresses
        msg = f"{src}: the content gives {covered} values, more than DEPTH={depth} addresses"
        raise DataError(msg)
    missing = depth - _union(a for a, _ in statements)
    if missing:
        msg = f"{src}: {missing} of {depth} addresses have no value"
        raise DataError(msg)
    # negative decimals: two's complement; a range's values repeated over it
    addrs = [np.arange(a.start, a.stop, dtype=np.int64) for a, _ in statements]
    words = [np.resize(np.array([v & ((1 << width) - 1) for v in w], dtype=np.uint64), len(a))
             for a, w in statements]
    values = signed(np.concatenate(words) if words else np.zeros(0, np.uint64), width)
    return _by_address(np.concatenate(addrs) if addrs else np.zeros(0, np.int64), values,
                       depth, src)


def _union(ranges: Iterable[range]) -> int:
    """How many addresses the ranges cover, each counted once."""
    total, reach = 0, 0
    for r in sorted((r for r in ranges if len(r)), key=lambda r: r.start):
        total += max(0, r.stop - max(r.start, reach))
        reach = max(reach, r.stop)
    return total


def _mif_statement(stmt: bytes, arad: int, drad: int, src: str) -> tuple[range, list[int]]:
    """Addresses and values of one content statement (without its ``;``): a range's
    values as listed, to be repeated over it."""
    lhs, colon, rhs = stmt.partition(b":")
    words = [int(w, drad) for w in rhs.split()]
    if not (colon and words):
        msg = f"{src}: cannot read the content statement {stmt.strip()!r}"
        raise DataError(msg)
    lhs = lhs.strip()
    if lhs.startswith(b"["):
        a0, a1 = (int(x, arad) for x in lhs.strip(b"[]").split(b".."))
        return range(a0, a1 + 1), words
    a0 = int(lhs, arad)
    return range(a0, a0 + len(words)), words


# --------------------------------------------------------------------- COE


def _coe_head(data: bytes) -> tuple[bytes, int]:
    """The text of a COE file before its vector, without the comment lines (``;`` first on
    the line), and the offset of the line that starts the vector (the end if none does)."""
    comments = re.compile(rb"(?m)^[ \t]*;[^\n]*")
    for k in re.finditer(rb"memory_initialization_vector", data, re.IGNORECASE):
        start = data.rfind(b"\n", 0, k.start()) + 1
        if not data[start:k.start()].lstrip().startswith(b";"):
            return comments.sub(b"", data[:k.start()]), start
    return comments.sub(b"", data), len(data)


def fast_coe(data: bytes, t: Target, src: str) -> np.ndarray | None:
    """A hex COE file as written here: one ``value,`` a line, the last ``value;``."""
    head, at = _coe_head(data)
    m = re.compile(rb"memory_initialization_vector\s*=[ \t]*\r?\n", re.IGNORECASE).search(data, at)
    if m is None or not re.search(rb"memory_initialization_radix\s*=\s*16\s*;", head,
                                  re.IGNORECASE):
        return None
    end = data.rstrip().rfind(b"\n") + 1
    last = re.fullmatch(rb"\s*([0-9A-Fa-f]{1,16})\s*;\s*", data[end:])
    if last is None or end <= m.end():
        return None
    body = hex_lines(data, m.end(), end, rb"[ \t]*,[ \t]*\r?\n", t.width)
    if body is None:
        return None
    return np.append(body, signed(np.array([int(last.group(1), 16)], np.uint64), t.width))


def read_coe(data: bytes, t: Target, src: str) -> np.ndarray:
    """Any COE: radix 2..16, values separated by commas, blanks and line breaks."""
    head, at = _coe_head(data)
    m = re.search(rb"memory_initialization_radix\s*=\s*(\d+)\s*;", head, re.IGNORECASE)
    v = re.compile(rb"memory_initialization_vector\s*=([^;]*);", re.IGNORECASE).search(data, at)
    if not (m and v):
        msg = f"{src}: no memory_initialization_radix/vector (not a COE file)"
        raise DataError(msg)
    radix = int(m.group(1))
    tokens = v.group(1).replace(b",", b" ").split()
    if radix == 16:
        return _hex_tokens(tokens, t.width, src)
    u = np.array([int(x, radix) for x in tokens], dtype=np.int64)
    return signed(u.astype(np.uint64), t.width)


# --------------------------------------------------------------------- $readmemh


def fast_mem(data: bytes, t: Target, src: str) -> np.ndarray | None:
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
    return hex_lines(data, pos, len(data), rb"[ \t]*\r?\n", t.width)


def read_mem(data: bytes, t: Target, src: str) -> np.ndarray:
    """Any $readmemh text: ``//`` and ``/* */`` comments, words separated by any blanks,
    ``@addr`` jumps (the words must then cover 0..n-1 without gaps)."""
    text = re.sub(rb"//[^\n]*", b"", data)
    text = re.sub(rb"/\*.*?\*/", b"", text, flags=re.DOTALL)
    tokens = text.split()
    if not any(tok.startswith(b"@") for tok in tokens[1:]):
        if tokens and tokens[0].startswith(b"@"):
            if int(tokens[0][1:], 16) != 0:
                msg = f"{src}: the table does not start at address 0"
                raise DataError(msg)
            tokens = tokens[1:]
        return _hex_tokens(tokens, t.width, src)
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
        msg = f"{src}: addresses have gaps"
        raise DataError(msg)
    return signed(np.array([out[i] for i in range(n)], dtype=np.uint64), t.width)


# --------------------------------------------------------------------- CSV


def read_csv(data: bytes, t: Target, src: str) -> np.ndarray:
    """``address,correction`` in decimal, after ``#`` comment lines if any (older
    versions wrote them; Arrow's CSV reader)."""
    import io

    import pyarrow.csv as pcsv
    body = data
    while body.startswith(b"#"):
        body = body.partition(b"\n")[2]
    try:
        # one thread: Arrow's pool left running could abort the interpreter at exit
        # (pyarrow 14: SIGABRT after a clean run, a third of runs)
        table = pcsv.read_csv(io.BytesIO(body), pcsv.ReadOptions(use_threads=False))
    except pa.ArrowInvalid as exc:
        msg = f"{src}: not a CSV table ({str(exc).splitlines()[0]})"
        raise DataError(msg) from None
    if table.column_names[:2] != ["address", "correction"]:
        msg = f"{src}: the header must be 'address,correction'"
        raise DataError(msg)
    a = table.column("address").to_numpy()
    if not np.array_equal(a, np.arange(a.size)):
        msg = f"{src}: addresses are not 0, 1, 2, ... without gaps"
        raise DataError(msg)
    corr = table.column("correction")
    if not pa.types.is_integer(corr.type) or corr.null_count:
        msg = f"{src}: a correction is not a whole number"
        raise DataError(msg)
    return corr.to_numpy().astype(np.int64)


# --------------------------------------------------------------------- controllers


def _lines_array(data: bytes) -> pa.Array:
    """Every line of ``data`` (with its newline) as an Arrow string array: no Python objects."""
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
        msg = "the file is not text (invalid UTF-8)"
        raise DataError(msg) from None


def _indexed(data: bytes, prefix: bytes, pattern: str, src: str) -> np.ndarray:
    """Values of the lines starting with ``prefix`` matching ``pattern`` (groups i, v), by index."""
    import pyarrow.compute as pc
    lines = pc.utf8_trim_whitespace(_lines_array(data))
    lines = lines.filter(pc.starts_with(lines, prefix.decode()))
    if len(lines) == 0:
        msg = f"{src}: no table entries found"
        raise DataError(msg)
    ok = pc.match_substring_regex(lines, pattern)
    if not pc.all(ok).as_py():
        bad = str(lines.filter(pc.invert(ok))[0].as_py())
        msg = f"{src}: cannot read the table line {bad.strip()!r}"
        raise DataError(msg)
    parts = pc.extract_regex(lines, pattern)
    idx = pc.cast(parts.field("i"), pa.int64()).to_numpy()
    try:
        val = pc.cast(parts.field("v"), pa.float64()).to_numpy()
    except pa.ArrowInvalid:
        msg = f"{src}: a table value is not a number"
        raise DataError(msg) from None
    if not np.array_equal(np.sort(idx), np.arange(idx.size)):
        msg = f"{src}: the table's indices have gaps or repeats"
        raise DataError(msg)
    out = np.empty(idx.size)
    out[idx] = val
    return out


def _from_closed(values_deg: np.ndarray, t: Target, src: str) -> np.ndarray:
    """Table values [LSB] from a controller's points 0..360 deg [deg] (the 360 deg one dropped)."""
    if not np.all(np.isfinite(values_deg)):
        msg = f"{src}: a table value is not a finite number"
        raise DataError(msg)
    counts = values_deg / t.count_deg * t.sign
    q = np.rint(counts)
    if np.max(np.abs(q)) >= 2.0 ** 62:
        msg = f"{src}: a table value is beyond any word width"
        raise DataError(msg)
    if np.max(np.abs(q - counts)) > 1e-3:
        msg = f"{src}: values are not whole multiples of the lsb {t.count_deg!r} deg"
        raise DataError(msg)
    if q[0] != q[-1]:
        msg = f"{src}: the 0 deg and 360 deg values differ (a rotary table must close)"
        raise DataError(msg)
    return q[:-1].astype(np.int64)


def read_acs(data: bytes, t: Target, src: str) -> np.ndarray:
    """An ACS SPiiPlus program: ``NAME(i)=value`` [deg] lines in any order and the
    ``ERRORMAP1D`` statement spanning 0..360 deg."""
    base, step, vals = acs_map(data, t.name, src)
    if base != 0.0 or abs(step * (vals.size - 1) - 360.0) > 1e-9:
        msg = f"{src}: the map does not span 0..360 deg"
        raise DataError(msg)
    return _from_closed(vals, t, src)


def acs_map(data: bytes, name: str, src: str) -> tuple[float, float, np.ndarray]:
    """An ACS program's error map: ERRORMAP1D's base and step [deg] and the ``NAME(i)=value``
    values [deg], in index order."""
    number = r"[-+0-9.eE]+"
    vals = _indexed(data, name.encode() + b"(",
                    rf"^\s*{re.escape(name)}\((?P<i>\d+)\)\s*=\s*(?P<v>{number})\s*$", src)
    code = re.sub(rb"![^\n]*", b"", data)  # what comments say is not read
    m = re.search(rf"ERRORMAP1D\s+[^,]+,\s*[^,]+,\s*({number})\s*,\s*({number})\s*,\s*"
                  rf"{re.escape(name)}".encode(), code)
    if not m:
        msg = f"{src}: no ERRORMAP1D statement for array {name}"
        raise DataError(msg)
    try:
        return float(m.group(1)), float(m.group(2)), vals
    except ValueError:
        msg = f"{src}: ERRORMAP1D's base or step is not a number"
        raise DataError(msg) from None


def read_siemens(data: bytes, t: Target, src: str) -> np.ndarray:
    """A SINUMERIK ``$AA_ENC_COMP`` table [deg] in any order, with STEP, MIN=0, MAX=360
    and IS_MODULO=1."""
    _, lo, hi, modulo, vals = siemens_table(data, src)
    if lo != 0.0 or hi != 360.0 or modulo != 1:
        msg = f"{src}: a rotary table needs MIN=0, MAX=360 and IS_MODULO=1"
        raise DataError(msg)
    return _from_closed(vals, t, src)


def siemens_table(data: bytes, src: str) -> tuple[float, float, float, float, np.ndarray]:
    """A SINUMERIK table's STEP, MIN, MAX, IS_MODULO and values [deg] in index order, the
    points spanning MIN..MAX at STEP."""
    vals = _indexed(data, b"$AA_ENC_COMP[",
                    r"^\s*\$AA_ENC_COMP\[\s*\d+\s*,\s*(?P<i>\d+)\s*,\s*\w+\s*\]\s*="
                    r"\s*(?P<v>[-+0-9.eE]+)\s*$", src)

    code = re.sub(rb";[^\n]*", b"", data)  # what comments say is not read

    def key(name: bytes) -> float:
        m = re.search(rb"\$AA_ENC_COMP_" + name + rb"\[[^]]*\]\s*=\s*([-+0-9.eE]+)", code)
        if not m:
            msg = f"{src}: no $AA_ENC_COMP_{name.decode()}"
            raise DataError(msg)
        return float(m.group(1))

    step, lo, hi, modulo = key(b"STEP"), key(b"MIN"), key(b"MAX"), key(b"IS_MODULO")
    if abs(step * (vals.size - 1) - (hi - lo)) > 1e-9:
        msg = f"{src}: {vals.size} points at STEP={step} do not span {lo}..{hi}"
        raise DataError(msg)
    return step, lo, hi, modulo, vals
