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

import os
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from enctools.errors import DataError, UsageError

#: the largest table this module builds (2**28 entries, 512 MiB of int16)
MAX_ADDRESS_BITS = 28
CHUNK = 1 << 20
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
        return 1_296_000.0 / 2.0 ** self.code_bits

    @property
    def lsb_arcsec(self) -> float:
        """One step of a table entry [arcsec]: ``lsb`` encoder counts of count_arcsec."""
        return self.count_arcsec * self.lsb

    @property
    def storage_bytes(self) -> int:
        """Bytes per word in binary images: 1, 2 or 4."""
        return 1 if self.width <= 8 else 2 if self.width <= 16 else 4

    def check(self) -> None:
        """Refuse, with one line naming the option, what cannot be built."""
        if not 1 <= self.code_bits <= 40:
            raise UsageError(f"--bits must be 1..40, not {self.code_bits}")
        if not 1 <= self.m <= self.code_bits:
            raise UsageError(f"--address-bits must be 1..{self.code_bits} (--bits), not {self.m}")
        if self.m > MAX_ADDRESS_BITS:
            raise UsageError(
                f"2^{self.m} = {self.entries} entries requested: more than the 2^{MAX_ADDRESS_BITS} "
                f"a table may have; use --address-bits {MAX_ADDRESS_BITS} or fewer (the code's top bits)")
        if not 2 <= self.width <= 32:
            raise UsageError(f"--width must be 2..32 bits, not {self.width}")
        if not (self.lsb > 0 and np.isfinite(self.lsb)):
            raise UsageError(f"--lsb must be a positive number of counts, not {self.lsb}")
        if self.sample not in ("centre", "start"):
            raise UsageError(f"--sample must be centre or start, not {self.sample!r}")

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


@dataclass
class Rom:
    """A built table and its summary."""

    spec: RomSpec
    values: np.ndarray  # signed integers, dtype int8/int16/int32 by width
    max_quantisation_lsb: float
    min_value: int
    max_value: int
    crc32: int = 0
    extra: dict = field(default_factory=dict)

    @property
    def max_quantisation_arcsec(self) -> float:
        return self.max_quantisation_lsb * self.spec.lsb_arcsec

    def summary(self) -> dict:
        s = self.spec
        return {"entries": s.entries, "code_bits": s.code_bits, "address_bits": s.m,
                "width_bits": s.width, "lsb_counts": s.lsb, "lsb_arcsec": s.lsb_arcsec,
                "sample": s.sample, "min_lsb": self.min_value, "max_lsb": self.max_value,
                "max_quantisation_error_lsb": self.max_quantisation_lsb,
                "max_quantisation_error_arcsec": self.max_quantisation_arcsec,
                "crc32": f"{self.crc32:08x}", "crc32_of": f"little-endian int{8 * s.storage_bytes} image",
                "image_bytes": s.entries * s.storage_bytes,
                "sign": "value = correction to add to the code = -deviation"}


def build_rom(deviation: Callable[[np.ndarray], np.ndarray], spec: RomSpec,
              progress: Callable[[int, int], None] | None = None) -> Rom:
    """Evaluate a model at every address and quantise it to signed words.

    Parameters
    ----------
    deviation : model, angles [deg] -> deviation [arcsec] (indicated - true). A model
        with ``on_grid(first_deg, step_deg)`` (returning ``values(start, stop)`` at
        ``first_deg + k * step_deg``) is evaluated through it: the addresses are a
        uniform grid, which RBF and Fourier models evaluate far faster than any angles.
    spec : the table to build.
    progress : called with (entries done, entries) after each chunk of CHUNK entries.

    Chunks are evaluated and quantised on THREADS threads (numpy releases the GIL).

    Returns
    -------
    Rom with ``values`` = round(-deviation / lsb_arcsec), the largest
    quantisation error [LSB] (<= 0.5), the value range and the CRC-32.
    Raises DataError when a value does not fit the word width or is not finite.
    """
    spec.check()
    n = spec.entries
    dtype = {1: np.int8, 2: np.int16, 4: np.int32}[spec.storage_bytes]
    lo, hi = -(1 << (spec.width - 1)), (1 << (spec.width - 1)) - 1
    values = np.empty(n, dtype=dtype)
    scale = -1.0 / spec.lsb_arcsec
    on_grid = getattr(deviation, "on_grid", None)
    if on_grid is not None:  # a model that evaluates a uniform grid faster than any angles
        at = on_grid(*spec.grid_deg())
    else:
        def at(start: int, stop: int) -> np.ndarray:
            return np.asarray(deviation(spec.angles_deg(start, stop)), dtype=np.float64)

    def chunk(start: int) -> tuple[float, float, float]:
        """Quantise addresses start..start+CHUNK-1; (min, max, largest |error|) [LSB]."""
        stop = min(n, start + CHUNK)
        corr = np.multiply(at(start, stop), scale, dtype=np.float64)
        q = np.rint(corr)
        qmin, qmax = float(q.min()), float(q.max())  # NaN or inf if any value is
        if not (np.isfinite(qmin) and np.isfinite(qmax)):
            raise DataError("the model gives NaN or infinite values; check the model stream")
        if qmin < lo or qmax > hi:
            return qmin, qmax, 0.0  # go on for the whole range, to name the width needed
        corr -= q
        err = max(-float(corr.min()), float(corr.max()))
        values[start:stop] = q
        return qmin, qmax, err

    starts = range(0, n, CHUNK)
    parts = []
    if len(starts) > 1 and THREADS > 1:  # numpy releases the GIL: overlap the chunks
        from concurrent.futures import ThreadPoolExecutor
        pool = ThreadPoolExecutor(THREADS)
        try:
            for start, part in zip(starts, pool.map(chunk, starts)):
                parts.append(part)
                if progress:
                    progress(min(n, start + CHUNK), n)
        finally:  # on an error or a signal, drop the chunks not yet started
            pool.shutdown(wait=True, cancel_futures=True)
    else:
        for start in starts:
            parts.append(chunk(start))
            if progress:
                progress(min(n, start + CHUNK), n)
    vmin = min(p[0] for p in parts)
    vmax = max(p[1] for p in parts)
    worst = max(p[2] for p in parts)
    overflow = vmin < lo or vmax > hi
    if overflow:
        need = _bits_needed(vmin, vmax)
        raise DataError(
            f"corrections reach {vmin:.0f}..{vmax:.0f} LSB, beyond the {spec.width}-bit "
            f"range {lo}..{hi}; use --width {need} or more, or a coarser --lsb")
    le = values.astype(values.dtype.newbyteorder("<"), copy=False)
    crc = zlib.crc32(le.tobytes() if not le.flags.c_contiguous else memoryview(le).cast("B"))
    return Rom(spec, values, worst, int(vmin), int(vmax), crc)


def _bits_needed(lo: float, hi: float) -> int:
    """Smallest signed width holding lo..hi."""
    w = 2
    while -(1 << (w - 1)) > lo or (1 << (w - 1)) - 1 < hi:
        w += 1
    return w
