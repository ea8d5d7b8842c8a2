"""Correction tables (ROM): a model evaluated at every address of an encoder code.

Seed 001 sec. 4.2: the error model is evaluated offline and stored in a fast ROM
addressed by the encoder's code, so an FPGA corrects every reading in one clock.
Address k of a table over the top ``address_bits`` m of an n-bit code covers the
codes ``k * 2**(n-m) .. (k+1) * 2**(n-m) - 1``; the model is evaluated at the
centre of those codes (``sample="centre"``: the smallest worst case for a ROM) or
at the first one (``sample="start"``: the interpolation points of a motion
controller's table). Code c stands for the indicated angle ``c * 360 / 2**n`` deg.

The stored value is the correction to *add* to the code: minus the model's
deviation, in LSBs of ``lsb`` counts of the n-bit code, rounded to the nearest
integer (so the quantisation error is at most half an LSB) and checked against
the signed range of the word width.
"""

from __future__ import annotations

import math
import os
import zlib
from collections.abc import Callable, Generator
from contextlib import closing
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
import pyarrow as pa

from enctools.data import streams
from enctools.data.arrays import arrow_array
from enctools.data.header import Header, history_line
from enctools.data.schemas import make_field
from enctools.errors import DataError, SettingsError
from enctools.models import romformats, romquantise
from enctools.models.romformats import registry
from enctools.units import TWO_PI, factor

#: the largest table this module builds (2**28 entries, 512 MiB of int16)
MAX_ADDRESS_BITS = 28
#: ``lsb`` [counts of the code per LSB]: finer makes every correction a number of
#: hundreds of digits, coarser than 2^40 counts rounds every correction to 0
LSB_COUNTS = (1e-6, float(1 << 40))
#: ``zone``: a controller's zone or measuring-system index is a 32-bit integer
MAX_ZONE = (1 << 31) - 1
#: addresses evaluated, quantised and handed to the writers at once: a few MB of float64
#: in flight on THREADS threads, whatever the table's size (from 2^20 entries on, every
#: table runs at this steady state), and a multiple of the Fourier grid's row
#: (:data:`~enctools.models.fourier.GRID_ROW`), so that each address is evaluated by
#: the same arithmetic whatever the block (the same words)
CHUNK = 1 << 18
#: ``resolution_deg`` [deg]: the controllers' resolutions enctools writes (powers of ten)
RESOLUTION_DEG = (1e-9, 0.1)
#: threads quantising chunks at once (at most 2: the evaluation itself may use BLAS threads)
THREADS = min(2, os.cpu_count() or 1)


@dataclass(frozen=True)
class RomSpec:
    """What table to build.

    code_bits : n, bits of the encoder code (counts per turn = 2**n).
    address_bits : m <= n, bits of the address (the code's top bits).
    width : word width [bit] of a signed correction (2..32).
    lsb : counts of the n-bit code per LSB of the stored value.
    sample : ``centre`` or ``start`` of each address's range of codes.
    """

    code_bits: int
    address_bits: int | None = None
    width: int = 16
    lsb: float = 1.0
    sample: str = "centre"

    @property
    def m(self) -> int:
        return self.code_bits if self.address_bits is None else self.address_bits

    @property
    def entries(self) -> int:
        return 1 << self.m

    @property
    def count_arcsec(self) -> float:
        """One count of the n-bit code [arcsec] (seed 001 eq. 3: 360 deg / 2**n)."""
        return TWO_PI * factor("rad", "arcsec") / 2.0 ** self.code_bits

    @property
    def lsb_arcsec(self) -> float:
        """One step of a table entry [arcsec]: ``lsb`` encoder counts of count_arcsec."""
        return self.count_arcsec * self.lsb

    @property
    def storage_bytes(self) -> int:
        """Bytes per word in binary images: 1, 2 or 4."""
        return 1 if self.width <= 8 else 2 if self.width <= 16 else 4

    @property
    def word_range(self) -> tuple[int, int]:
        """Smallest and largest signed value [LSB] of a ``width``-bit word."""
        return -(1 << (self.width - 1)), (1 << (self.width - 1)) - 1

    def check(self) -> None:
        """Refuse, with one line naming the setting, what cannot be built."""
        if not 1 <= self.code_bits <= 40:
            msg = f"`code_bits` must be 1..40, not {self.code_bits}"
            raise SettingsError(msg)
        if not 1 <= self.m <= self.code_bits:
            msg = f"`address_bits` must be 1..{self.code_bits} (`code_bits`), not {self.m}"
            raise SettingsError(msg)
        if self.m > MAX_ADDRESS_BITS:
            msg = (f"2^{self.m} = {self.entries} entries requested: more than the "
                   f"2^{MAX_ADDRESS_BITS} a table may have; use `address_bits` "
                   f"{MAX_ADDRESS_BITS} or fewer (the code's top bits)")
            raise SettingsError(msg)
        if not 2 <= self.width <= 32:
            msg = f"`width` must be 2..32 bits, not {self.width}"
            raise SettingsError(msg)
        if not (self.lsb > 0 and np.isfinite(self.lsb)):
            msg = f"`lsb` must be a positive number of counts, not {self.lsb}"
            raise SettingsError(msg)
        if not LSB_COUNTS[0] <= self.lsb <= LSB_COUNTS[1]:
            msg = f"`lsb` must be a positive number of counts, 1e-06..1099511627776, not {self.lsb}"
            raise SettingsError(msg)
        if self.sample not in ("centre", "start"):
            msg = f"`sample` must be centre or start, not {self.sample!r}"
            raise SettingsError(msg)

    def grid_deg(self) -> tuple[float, float]:
        """First angle and step [deg] of the addresses: address k is at first + k * step."""
        shift = self.code_bits - self.m
        offset = (2.0 ** shift - 1) / 2.0 if self.sample == "centre" else 0.0
        count = 360.0 / 2.0 ** self.code_bits
        return offset * count, 2.0 ** shift * count

    def angles_deg(self, start: int, stop: int) -> np.ndarray:
        """Angles [deg] at which addresses start..stop-1 are evaluated."""
        first, step = self.grid_deg()
        return first + np.arange(start, stop, dtype=np.float64) * step


@dataclass(frozen=True)
class Settings:
    """What enc make-rom builds and where it goes, checked when made.

    code_bits, address_bits, width, lsb : the table (:class:`RomSpec`).
    sample : ``centre`` or ``start``; None: start for a controller's table (acs,
        siemens), centre for a memory's.
    target : a format of :mod:`enctools.models.romformats`, or ``stream``.
    endian : bin and ihex: byte order of the words.
    axis : acs: axis number 0..127 (None: 0); siemens: machine axis name, a letter then
        letters, digits or _, at most 8 characters (None: AX1).
    zone : acs error-map zone, siemens measuring system index (>= 0).
    array_name : acs: the REAL array holding the map, an ACSPL+ name (a letter, then
        letters, digits or _, at most 32 characters).
    max_entries : acs, siemens: table points the control holds (None: the format's default).
    resolution_deg : acs, siemens: the control's resolution [deg], a power of ten: the
        table is quantised to it (the LSB is set from it) and printed at it.
    sign : acs: ``correction`` or ``error`` (the control's convention is not confirmed).
    backlash : write the step run's mean reversal as the control's backlash machine datum,
        in a file beside the table (where the format's record has one: SINUMERIK's
        MD32450), with the table of the positive direction instead of both directions' mean.
    """

    code_bits: int
    address_bits: int | None = None
    width: int = 16
    lsb: float = 1.0
    sample: str | None = None
    target: str = "stream"
    endian: str = "little"
    axis: str | None = None
    zone: int = 0
    array_name: str = "ENC_COMP"
    max_entries: int | None = None
    resolution_deg: float | None = None
    sign: str | None = None
    backlash: bool = False

    def __post_init__(self) -> None:
        addressed = registry.names(registry.MEMORY, registry.CONTROLLER)
        if self.target != "stream" and self.target not in addressed:
            msg = f"`target` must be one of {', '.join(addressed)} or stream, not {self.target!r}"
            raise SettingsError(msg)
        self._check_controller_options()
        self.spec.check()
        if self.target != "stream":
            romformats.check_capacity(self.table, self.spec.entries)
        if self.backlash:
            lash = registry.get(self.target).backlash_file if self.controller else None
            if lash is None:
                takes = [r.name for r in registry.records() if r.backlash_file is not None]
                msg = f"`backlash` applies to {', '.join(takes)} here, not `target` {self.target}"
                raise SettingsError(msg)
            if lash.check is not None:
                lash.check(self.table)

    def _check_controller_options(self) -> None:
        """``zone`` and ``max_entries`` in their ranges; ``axis`` and ``max_entries`` only where a
        controller's table takes them (elsewhere they would be silently ignored)."""
        if not 0 <= self.zone <= MAX_ZONE:
            msg = f"`zone` must be 0..{MAX_ZONE}, not {self.zone}"
            raise SettingsError(msg)
        if self.max_entries is not None and not 1 <= self.max_entries <= 1 << MAX_ADDRESS_BITS:
            msg = f"`max_entries` must be 1..{1 << MAX_ADDRESS_BITS}, not {self.max_entries}"
            raise SettingsError(msg)
        if not self.controller:
            given = [f for f, v in (("`axis`", self.axis), ("`max_entries`", self.max_entries),
                                    ("`resolution_deg`", self.resolution_deg),
                                    ("`sign`", self.sign))
                     if v is not None]
            if given:
                msg = (f"{given[0]} applies to the controllers' targets, "
                       f"not `target` {self.target}")
                raise SettingsError(msg)
            return
        fmt = registry.get(self.target)
        _check_resolution(fmt, self.resolution_deg)
        if fmt.sign is None and self.sign not in ("correction", "error"):
            msg = (f"{self.target}: the sign of a stored value (correction added, or error "
                   f"measured) is not confirmed from the controller's documentation; give "
                   "`sign` correction or `sign` error as your controller's manual says")
            raise SettingsError(msg)
        if fmt.sign is not None and self.sign is not None:
            unsure = ", ".join(r.name for r in registry.records() if r.points and r.sign is None)
            msg = f"`sign` applies to {' and '.join(unsure.rsplit(', ', 1))}, not " \
                  f"{self.target} (documented)"
            raise SettingsError(msg)

    @property
    def controller(self) -> bool:
        """Whether the target is a controller's addressed table (its points interpolated)."""
        fmt = registry.find(self.target)
        return fmt is not None and fmt.family == registry.CONTROLLER

    @property
    def spec(self) -> RomSpec:
        """The table to build."""
        controller = self.controller
        lsb = self.lsb
        if controller and self.resolution_deg is not None:  # the LSB is the control's step
            lsb = self.resolution_deg / (360.0 / 2.0 ** self.code_bits)
        return RomSpec(self.code_bits, self.address_bits, self.width, lsb,
                       self.sample or ("start" if controller else "centre"))

    @property
    def table(self) -> romformats.Target:
        """How the table file is written (a table format, not ``stream``)."""
        if self.target == "stream":
            msg = "a rom stream is not a table file"
            raise ValueError(msg)
        count_deg = self.spec.lsb_arcsec * factor("arcsec", "deg")
        decimals = None
        if self.controller and self.resolution_deg is not None:
            count_deg = self.resolution_deg
            decimals = round(-math.log10(self.resolution_deg))
        return romformats.Target(self.target, self.width, self.endian, count_deg=count_deg,
                                 axis=self._axis(), zone=self.zone, name=self.array_name,
                                 max_entries=self.max_entries,
                                 sign=-1 if self.sign == "error" else 1, decimals=decimals)

    def _axis(self) -> str:
        """The axis as the program names it: the format's default when none is given; a
        number (leading zeros dropped) where the format numbers its axes; checked by the
        format's record (:func:`romformats.check_capacity`)."""
        fmt = registry.find(self.target)
        default = fmt.default_axis if fmt is not None else ""
        if self.axis is None:
            return default
        if default.isdigit() and self.axis.isascii() and self.axis.isdigit():
            return str(int(self.axis))
        return self.axis

    def to_meta(self) -> dict[str, Any]:
        """The ``settings`` metadata of the output."""
        spec = self.spec
        return {"code_bits": self.code_bits, "address_bits": spec.m, "width": self.width,
                "lsb": self.lsb, "sample": spec.sample, "target": self.target,
                "endian": self.endian}


def _check_resolution(fmt: registry.TableFormat, resolution_deg: float | None) -> None:
    """Refuse (one line) a controller table without a resolution that is a power of ten
    in RESOLUTION_DEG: the control's step, which is not in any file enctools reads."""
    if resolution_deg is None:
        msg = (f"{fmt.name}: give `resolution_deg`, the control's resolution [deg] (a power of "
               f"ten; {fmt.resolution_source or 'the control'})")
        raise SettingsError(msg)
    d = round(-math.log10(resolution_deg)) if resolution_deg > 0 else 0
    if not (RESOLUTION_DEG[0] <= resolution_deg <= RESOLUTION_DEG[1]
            and abs(10.0 ** -d - resolution_deg) <= 1e-12 * resolution_deg):
        msg = (f"`resolution_deg` must be a power of ten "
               f"{RESOLUTION_DEG[0]!r}..{RESOLUTION_DEG[1]!r} deg, not {resolution_deg!r}")
        raise SettingsError(msg)


@dataclass
class Rom:
    """A built table and its summary."""

    spec: RomSpec
    #: signed integers, dtype int8/int16/int32 by width: an array, or (:func:`scan_rom`)
    #: :class:`~enctools.models.romformats.words.Words` given a block at a time
    values: Any
    max_quantisation_lsb: float
    min_value: int
    max_value: int
    crc32: int = 0
    #: RMS of the exact correction, RMS of (stored - exact), largest |exact correction|,
    #: over every address [LSB]: what the table's quantisation guard weighs
    rms_correction_lsb: float = 0.0
    rms_quantisation_lsb: float = 0.0
    max_abs_correction_lsb: float = 0.0

    @property
    def max_quantisation_arcsec(self) -> float:
        """The largest quantisation error [arcsec]."""
        return self.max_quantisation_lsb * self.spec.lsb_arcsec

    def summary(self) -> dict[str, Any]:
        """The ``rom`` metadata of the table: its layout, value range [LSB], largest
        quantisation error [LSB, arcsec] and CRC-32."""
        s = self.spec
        return {"entries": s.entries, "code_bits": s.code_bits, "address_bits": s.m,
                "width_bits": s.width, "lsb_counts": s.lsb, "lsb_arcsec": s.lsb_arcsec,
                "sample": s.sample, "min_lsb": self.min_value, "max_lsb": self.max_value,
                "max_quantisation_error_lsb": self.max_quantisation_lsb,
                "max_quantisation_error_arcsec": self.max_quantisation_arcsec,
                "crc32": f"{self.crc32:08x}",
                "crc32_of": f"little-endian int{8 * s.storage_bytes} image",
                "image_bytes": s.entries * s.storage_bytes,
                "sign": "value = correction to add to the code = -deviation"}

    def file_comment(self, output: str | None = None) -> list[str]:
        """The comment lines heading a table file: layout, LSB [arcsec], CRC-32, history
        (its paths as the file ``output`` records them: :func:`~enctools.data.header.
        history_line`)."""
        from enctools.models.romformats.headers import Layout, comment_line

        s = self.spec
        return [comment_line(Layout(s.entries, s.code_bits, s.width, s.lsb, s.sample)),
                f"CRC-32 {self.crc32:08x} (little-endian int{8 * s.storage_bytes} image); "
                + history_line(output=output)]


def build_rom(deviation: Callable[[np.ndarray], np.ndarray], spec: RomSpec,
              progress: Callable[[int, int], None] | None = None) -> Rom:
    """Evaluate a model at every address and quantise it to signed words, held whole:
    :func:`scan_rom`'s table with its words in one array."""
    rom = scan_rom(deviation, spec, progress)
    rom.values = np.asarray(rom.values)
    return rom


def scan_rom(deviation: Callable[[np.ndarray], np.ndarray], spec: RomSpec,
             progress: Callable[[int, int], None] | None = None) -> Rom:
    """Evaluate a model at every address and quantise it to signed words, a block of
    CHUNK addresses at a time, without holding the table.

    Parameters
    ----------
    deviation : model, angles [deg] -> deviation [arcsec] (indicated - true). A model
        with ``on_grid(first_deg, step_deg)`` (returning ``values(start, stop)`` at
        ``first_deg + k * step_deg``) is evaluated through it: the addresses are a
        uniform grid, which RBF and Fourier models evaluate far faster than any angles.
    spec : the table to build.
    progress : called with (entries done, entries) after each chunk of CHUNK entries.

    Chunks are evaluated and quantised on THREADS threads (numpy releases the GIL), each
    one's summary and CRC-32 taken in order, and its words kept run-length coded (a
    table's values change slowly) within :data:`KEPT_BYTES`: the table's ``values`` are
    :class:`~enctools.models.romformats.words.Words`, each block given again from what was
    kept, or evaluated again as it was the first time (the same words).

    Returns
    -------
    Rom with ``values`` = round(-deviation / lsb_arcsec), the largest
    quantisation error [LSB] (<= 0.5), the value range and the CRC-32.
    Raises DataError when a value does not fit the word width or is not finite.
    """
    from enctools.models.romformats.words import Words

    spec.check()
    dtype = np.dtype({1: np.int8, 2: np.int16, 4: np.int32}[spec.storage_bytes])
    at = _on_grid(deviation, spec)
    quantise = partial(_block, romquantise.quantise, at, spec, dtype)
    parts, crc, kept = _scan(quantise, spec.entries, dtype, progress)
    _exact_extremes(parts, partial(_block, romquantise.quantise_exact, at, spec, dtype))
    vmin = min(p[0] for p in parts)
    vmax = max(p[1] for p in parts)
    worst = max(p[2] for p in parts)
    rms_corr, rms_err = (math.sqrt(sum(p[i] for p in parts) / spec.entries) for i in (3, 4))
    largest = max(p[5] for p in parts)
    lo, hi = spec.word_range
    if vmin < lo or vmax > hi:
        msg = (f"corrections reach {vmin:.0f}..{vmax:.0f} LSB, beyond the {spec.width}-bit "
               f"range {lo}..{hi}; use `width` {_bits_needed(vmin, vmax)} or more, or a "
               f"coarser `lsb`")
        raise DataError(msg)

    def chunk(k: int) -> np.ndarray:
        got = kept.get(k)
        if got is None:  # evaluated again: the words of the scan (it found them all in range)
            got = quantise(k * CHUNK)[1]
            assert got is not None
        return got

    values = Words(spec.entries, dtype, CHUNK, chunk, int(vmin), int(vmax))
    return Rom(spec, values, worst, int(vmin), int(vmax), crc, rms_corr, rms_err, largest)


def _block(how: Callable[..., Any], at: Callable[[int, int], np.ndarray], spec: RomSpec,
           dtype: np.dtype, start: int) -> tuple[tuple[float, ...], np.ndarray | None]:
    """Addresses start..start+CHUNK-1 quantised ``how`` (:mod:`.romquantise`)."""
    return how(at, spec, dtype, start, min(spec.entries, start + CHUNK))


def _exact_extremes(parts: list, exact: Callable[[int], Any]) -> None:
    """The blocks' summaries (``parts``, in order) made exact where a block quantised from
    approximate values (its slack > 0) may hold the table's largest quantisation error or
    largest |correction|: each such block evaluated again exactly (``exact(start)``), so
    that both figures are those of the exact evaluation (the others' are below them)."""
    for i in (2, 5):
        floor = max(p[i] - p[6] for p in parts)  # the table's figure is at least this
        for k, p in enumerate(parts):
            if p[6] > 0 and p[i] + p[6] >= floor:
                parts[k] = exact(k * CHUNK)[0]


def _scan(quantise: Callable[[int], Any], n: int, dtype: np.dtype,
          progress: Callable[[int, int], None] | None) -> tuple[list, int, _Kept]:
    """Every chunk's summary, in order, the CRC-32 of the words and the words kept."""
    kept = _Kept(dtype)
    parts = []
    crc = 0
    # closed on any ending: the chunks not yet started are dropped at once
    with closing(_each_chunk(quantise, n, progress)) as chunks:
        for start, (part, words) in chunks:
            parts.append(part)
            if words is not None:
                crc = zlib.crc32(words.astype(words.dtype.newbyteorder("<"), copy=False).data,
                                 crc)
                kept.add(start // CHUNK, words)
    return parts, crc, kept


#: bytes of a table's words kept between its scan and its writing (run-length coded:
#: the table-1 model's 2^26 words, 1680 runs, take 10 KB); a block beyond is evaluated again
KEPT_BYTES = 16 << 20


class _Kept:
    """The blocks of a table kept as runs (starts, words), while they fit KEPT_BYTES."""

    def __init__(self, dtype: np.dtype) -> None:
        self.dtype, self.left = dtype, KEPT_BYTES
        self.blocks: dict[int, tuple[np.ndarray, np.ndarray, int]] = {}

    def add(self, k: int, words: np.ndarray) -> None:
        starts = np.flatnonzero(words[1:] != words[:-1]) + 1
        cost = starts.size * (4 + words.itemsize) + 64
        if cost * 4 <= words.nbytes and cost <= self.left:
            self.left -= cost
            self.blocks[k] = (starts.astype(np.int32), words[np.r_[0, starts]], words.size)

    def get(self, k: int) -> np.ndarray | None:
        if k not in self.blocks:
            return None
        starts, runs, n = self.blocks[k]
        return np.repeat(runs, np.diff(np.r_[0, starts, n]))


def _on_grid(deviation: Callable[[np.ndarray], np.ndarray], spec: RomSpec
             ) -> Callable[[int, int], np.ndarray]:
    """The model [arcsec] at addresses start..stop-1: ``values(start, stop)``."""
    on_grid = getattr(deviation, "on_grid", None)
    if on_grid is not None:  # a model that evaluates a uniform grid faster than any angles
        return on_grid(*spec.grid_deg())

    def at(start: int, stop: int) -> np.ndarray:
        return np.asarray(deviation(spec.angles_deg(start, stop)), dtype=np.float64)

    return at


def _each_chunk(quantise: Callable[[int], Any], n: int,
                progress: Callable[[int, int], None] | None
                ) -> Generator[tuple[int, Any], None, None]:
    """(start, ``quantise(start)``) of every chunk of n entries, in order, on THREADS
    threads, at most THREADS chunks ahead of the one handed out (memory stays flat)."""
    starts = range(0, n, CHUNK)
    if len(starts) > 1 and THREADS > 1:  # numpy releases the GIL: overlap the chunks
        from collections import deque
        from concurrent.futures import ThreadPoolExecutor
        pool = ThreadPoolExecutor(THREADS)
        try:
            ahead: deque = deque()
            todo = iter(starts)
            for start in todo:
                ahead.append((start, pool.submit(quantise, start)))
                if len(ahead) > THREADS:
                    break
            while ahead:
                start, future = ahead.popleft()
                nxt = next(todo, None)
                if nxt is not None:
                    ahead.append((nxt, pool.submit(quantise, nxt)))
                yield start, future.result()
                if progress:
                    progress(min(n, start + CHUNK), n)
        finally:  # on an error or a signal, drop the chunks not yet started
            pool.shutdown(wait=True, cancel_futures=True)
        return
    for start in starts:
        yield start, quantise(start)
        if progress:
            progress(min(n, start + CHUNK), n)


def _bits_needed(lo: float, hi: float) -> int:
    """Smallest signed width holding lo..hi."""
    w = 2
    while -(1 << (w - 1)) > lo or (1 << (w - 1)) - 1 < hi:
        w += 1
    return w


def stream_schema() -> pa.Schema:
    """The columns of a ``rom`` stream: address, correction [count]."""
    return pa.schema([make_field("address", pa.int64(), ""),
                      make_field("correction", pa.int64(), "count")])


def write_stream(output: str | None, header: Header, values: np.ndarray, force: bool,
                 fmt: str | None) -> None:
    """Write a table [LSB] as a ``rom`` stream (address, correction), in batches."""
    schema = stream_schema()
    rows = streams.BATCH_ROWS * 16
    with streams.OutputStream(output, header, force, fmt) as out:
        for start in range(0, values.size, rows):
            v = values[start:start + rows]
            out.write(pa.record_batch([arrow_array(np.arange(start, start + v.size)),
                                       arrow_array(v.astype(np.int64))], schema=schema))
