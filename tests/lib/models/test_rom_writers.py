"""The table writers' bytes, line for line against a plain formatter of each format.

The writers build their text with numpy, block by block; the formatter here writes one
line at a time with Python's own formatting, as each format's documentation describes
it. Sizes cross the writers' blocks and Intel HEX's 64 KiB segments and end in a
partial line or record; widths include odd ones; values cover each width's extremes.
"""

from __future__ import annotations

import tempfile

import numpy as np
import pytest

from enctools.models import romformats as rf
from enctools.models.romformats import blocks, csvtext, writers

COMMENT = ["enctools make-rom: a test table", "CRC-32 0badf00d; a second line"]
#: sizes [entries]: tiny, around a hex digit of the address, around the writers' blocks
SIZES = (1, 2, 3, 15, 16, 17, 255, 257, 4095, 4097, 65535, 65536, 65537,
         3 * 65536 + 5, 5 * 65536 - 3)
#: sizes of about a whole block (65536 entries) or more: in the slow tier (make test-slow)
MANY_BLOCKS = (65535, 65536, 65537, 3 * 65536 + 5, 5 * 65536 - 3, 8 * 65536 + 1)


def _sizes(*extra: int) -> list:
    return [pytest.param(n, marks=pytest.mark.slow) if n in MANY_BLOCKS else n
            for n in SIZES + extra]
WIDTHS = (2, 3, 5, 8, 9, 13, 16, 17, 23, 24, 31, 32)


def _values(n: int, width: int, seed: int, runs: bool = False) -> np.ndarray:
    """n signed values of a ``width``-bit word in its smallest dtype, extremes included;
    ``runs``: in runs of equal values (as a table's, whose values change slowly)."""
    lo, hi = -(1 << (width - 1)), (1 << (width - 1)) - 1
    dtype = np.int8 if width <= 8 else np.int16 if width <= 16 else np.int32
    rng = np.random.default_rng(seed)
    v = rng.integers(lo, hi + 1, n, dtype=np.int64)
    if runs:  # the value changes some 20 times in each block of the writers
        v = v[np.cumsum(rng.random(n) < 20 / writers.LINES)]
    v[: min(n, 4)] = [lo, hi, 0, -1][: min(n, 4)]
    return v.astype(dtype)


def _plain(fmt: str, values: np.ndarray, t: rf.Target, comment: list[str]) -> bytes:
    """The file, one line at a time."""
    n, hd, mask = values.size, (t.width + 3) // 4, (1 << t.width) - 1
    ints = values.tolist()  # Python's ints: int() of each numpy scalar was half the time
    words = [f"{v & mask:0{hd}X}" for v in ints]
    if fmt == "mif":
        adig = max(1, -(-(n - 1).bit_length() // 4))
        text = "".join(f"-- {c}\n" for c in comment)
        text += (f"WIDTH={t.width};\nDEPTH={n};\n\nADDRESS_RADIX=HEX;\nDATA_RADIX=HEX;\n\n"
                 "CONTENT BEGIN\n")
        text += "".join(f"\t{k:0{adig}X} : {w};\n" for k, w in enumerate(words)) + "END;\n"
    elif fmt == "coe":
        text = "".join(f"; {c}\n" for c in comment)
        text += "memory_initialization_radix=16;\nmemory_initialization_vector=\n"
        text += ",\n".join(words) + ";\n"
    elif fmt == "mem":
        text = "".join(f"// {c}\n" for c in comment) + "@0\n" + "".join(w + "\n" for w in words)
    elif fmt == "csv":
        text = "address,correction\n" + "".join(f"{k},{v}\n" for k, v in enumerate(ints))
    elif fmt == "ihex":
        return _plain_ihex(values.astype(t.image_dtype).tobytes())
    else:
        return values.astype(t.image_dtype).tobytes()
    return text.encode()


def _plain_ihex(image: bytes) -> bytes:
    """Intel HEX: a type 04 record at each 64 KiB, 16 data bytes a record, then EOF."""
    def record(rtype: int, addr: int, data: bytes) -> str:
        body = bytes([len(data), addr >> 8, addr & 255, rtype]) + data
        return ":" + (body + bytes([-sum(body) & 255])).hex().upper() + "\n"

    lines = []
    for base in range(0, len(image), 1 << 16):
        lines.append(record(4, 0, (base >> 16).to_bytes(2, "big")))
        seg = image[base:base + (1 << 16)]
        lines += [record(0, a, seg[a:a + 16]) for a in range(0, len(seg), 16)]
    return ("".join(lines) + ":00000001FF\n").encode()


def _written(fmt: str, values: np.ndarray, t: rf.Target) -> bytes:
    with tempfile.TemporaryFile() as f:  # a real file: the binary writer writes to its fd
        rf.WRITERS[fmt](f, values, t, COMMENT)
        f.seek(0)
        return f.read()


def _check(fmt: str, values: np.ndarray, t: rf.Target) -> None:
    got, want = _written(fmt, values, t), _plain(fmt, values, t, COMMENT)
    if got != want:
        at = next((i for i, (a, b) in enumerate(zip(got, want, strict=False)) if a != b),
                  min(len(got), len(want)))
        line, near = want[:at].count(b"\n"), slice(max(0, at - 20), at + 20)
        pytest.fail(f"{fmt} of {values.size} {t.width}-bit values differs at byte {at} "
                    f"(line {line + 1}): {got[near]!r} != {want[near]!r}")


@pytest.mark.parametrize("fmt", ("mif", "coe", "mem", "csv", "bin"))
@pytest.mark.parametrize("n", _sizes())
def test_text_tables_line_for_line(fmt, n):
    for i, width in enumerate(WIDTHS):
        if n > 4097 and i % 3:  # the big sizes at a third of the widths each
            continue
        for runs in (False, True):
            _check(fmt, _values(n, width, n + width, runs), rf.Target(fmt, width))


@pytest.mark.heavy
@pytest.mark.parametrize("n", _sizes(8 * 65536 + 1, 32768 + 3))
@pytest.mark.parametrize("endian", ("little", "big"))
def test_intel_hex_record_for_record(n, endian):
    """Segments whole, partial, and cut inside a record, for words of 1, 2 and 4 bytes."""
    widths = (3, 8, 12, 16, 20, 32)
    if n > 65537:  # the big sizes: one- and four-byte words little-endian, two- and four- big
        widths = (8, 32) if endian == "little" else (12, 20)
    for width in widths:
        runs = width in (8, 16, 20)  # records repeating, as a table's do, or random ones
        _check("ihex", _values(n, width, n * width, runs), rf.Target("ihex", width, endian))


def test_the_block_boundary_is_where_the_writers_change_block():
    """The sizes above cross the writers' blocks: keep them so if the block size changes."""
    assert max(SIZES) > 2 * writers.LINES


@pytest.mark.heavy
@pytest.mark.parametrize("d", (5, 6, 7, 8, 9))
def test_csv_lines_of_every_address_length(d):
    """Addresses of 5 to 9 digits (2^28 entries reach 9), in blocks of few runs of one value
    (a table's slowly changing values), of few runs of one line length (values changing
    every line, their lengths seldom) and of many (random values), each block starting on
    and off the 100 000 lines whose address digits above the last five agree."""
    rng = np.random.default_rng(d)
    smooth = np.repeat(rng.integers(-32768, 32768, 40), rng.integers(1, 1500, 40))
    lengths = np.where(np.arange(smooth.size) // 5000 % 2, rng.integers(100, 999, smooth.size),
                       rng.integers(-32768, -10000, smooth.size))
    lines = csvtext.CsvLines(d)
    for start in (10 ** (d - 1), 10 ** (d - 1) + 12_345, 10 ** d - smooth.size):
        for v in (smooth, lengths, np.array([-32768, 7]),
                  rng.integers(-32768, 32768, min(writers.LINES, 10 ** d - start))):
            v = v.astype(np.int16)
            want = "".join(f"{start + k},{x}\n" for k, x in enumerate(v.tolist())).encode()
            assert bytes(lines.text(start, v)) == want, (d, start, v.size)
    assert smooth.size <= writers.LINES and 10 ** d - smooth.size > 10 ** (d - 1)


@pytest.mark.heavy
@pytest.mark.parametrize("d", (5, 6, 7, 8, 9))
def test_csv_runs_of_every_address_length(d):
    """Run by run (a table's seldom changing values): runs longer than a buffer of lines,
    runs crossing the 100 000 lines whose address digits above the last five agree, runs
    of one line, values of every length, starting on and off those 100 000 lines and
    ending at the last address of d digits; in the writer's buffer and in one of some
    100 kB, which fills every few thousand lines, runs cut across its writes."""
    rng = np.random.default_rng(d)
    lengths = [1, 70_000, 3, 31_000, 1, 2, 40_000] if d > 5 else [1, 30_000, 3, 21_000, 1, 2, 9]
    words = [-32768, 7, -5, 32767, 0, -1, 123]
    v = np.repeat(np.array(words, np.int16), lengths)
    room = 9 * 10 ** (d - 1) - v.size  # the addresses of d digits
    for size in (None, 100_003):
        lines = csvtext.CsvLines(d)
        if size is not None:
            lines.out = np.empty(size, np.uint8)
        for start in (10 ** (d - 1), 10 ** (d - 1) + int(rng.integers(1, room)),
                      10 ** d - v.size):
            u = v.view(np.uint16)
            change = np.flatnonzero(u[1:] != u[:-1]) + 1
            parts = [bytes(p) for p in lines.runs(start, u, change)]
            want = "".join(f"{start + k},{x}\n" for k, x in enumerate(v.tolist())).encode()
            assert b"".join(parts) == want, (d, start, size)
            assert max(map(len, parts)) <= lines.out.size - 8
            assert len(parts) >= (len(want) // lines.out.size + 1 if size else 1)


@pytest.mark.heavy
def test_csv_spans_run_by_run_and_block_by_block(monkeypatch):
    """A table whose stretches alternate between seldom and often changing values is written
    a span at a time, each span by the way its values suit: the same lines either way."""
    monkeypatch.setattr(csvtext, "SPAN", 50_000)
    rng = np.random.default_rng(5)
    smooth = np.repeat(rng.integers(-32768, 32768, 12), 50_000 // 12 + 1)[:50_000]
    rough = rng.integers(-32768, 32768, 50_000)
    # spans from 10 000 (5 digits) and from 100 000 (6), 50 000 lines each
    values = np.concatenate([np.zeros(csvtext.CSV_SHORT), smooth, rough[:40_000], smooth,
                             rough[:777]])
    runs = []
    real = csvtext.CsvLines.runs

    def counted(self, *args):
        runs.append(args[0])
        return real(self, *args)

    monkeypatch.setattr(csvtext.CsvLines, "runs", counted)
    _check("csv", values.astype(np.int16), rf.Target("csv", 16))
    assert runs == [10_000, 100_000]


@pytest.mark.heavy
@pytest.mark.parametrize("fmt", ("coe", "mem"))
def test_word_lines_span_by_span(fmt, monkeypatch):
    """COE and MEM take a table a span at a time: a span of seldom changing values as its
    runs' repeated text (a run crossing spans, runs longer than the repeated text), a span of
    many values a block at a time, spans of each kind after the other and a short last one;
    every word width's lines the same as the plain formatter's."""
    monkeypatch.setattr(writers, "SPAN", 30_000)
    monkeypatch.setattr(writers, "RUN_LINES", 1000)
    rng = np.random.default_rng(11)
    for width in (5, 16, 24):
        hi = 1 << (width - 1)
        smooth = np.repeat(rng.integers(-hi, hi, 7), [1, 4000, 9999, 2, 11_000, 5, 4993])
        rough = rng.integers(-hi, hi, 30_000)
        values = np.concatenate([smooth, smooth[::-1], rough, smooth, rough[:7001]])
        dtype = np.int16 if width <= 16 else np.int32
        _check(fmt, values.astype(dtype), rf.Target(fmt, width))


@pytest.mark.heavy
def test_csv_of_wide_words_holding_small_values():
    """A 24-bit table whose values fit 16 bits is written from the table of 16-bit values'
    text, one whose values do not by Arrow's writer: the same lines either way."""
    small = _values(70_000, 16, 1, runs=True).astype(np.int32)
    for v in (small, small * 300):
        _check("csv", v, rf.Target("csv", 24))


@pytest.mark.parametrize("fmt", ("coe", "mem", "ihex", "csv"))
def test_writes_that_take_fewer_bytes_than_asked(fmt, monkeypatch):
    """The writers gather their buffers into ``os.writev`` calls of at most a few buffers,
    each ending at a whole page of the file: with every call taking at most 5000 bytes of
    at most 3 buffers, the file is still every byte, in order. The values hold runs longer
    than a run's buffer of lines, exactly as long, and a page's worth of lines."""
    real = blocks.os.writev
    calls = []

    def short(fd, parts):
        calls.append(len(parts))
        return real(fd, [memoryview(p)[:5000] for p in parts[:1]])

    monkeypatch.setattr(blocks.os, "writev", short)
    monkeypatch.setattr(blocks.os, "sysconf", lambda name: 3)
    lengths = (10_000, writers.RUN_LINES, 4096 // 6, 1, writers.RUN_LINES + 1, 70_000)
    values = np.repeat(np.arange(len(lengths)) * 999 - 2000, lengths).astype(np.int16)
    _check(fmt, values, rf.Target(fmt, 16))
    assert max(calls) <= 3 and len(calls) > 10
