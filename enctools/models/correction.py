"""Correction tables applied as the hardware applies them: one :class:`Correction` per
table family.

A correction is what an FPGA or a motion controller adds to the encoder's indicated
angle; it is the negative of the error model's deviation (indicated minus true). Each
family applies it its own way:

- :class:`MemoryTable` (the memory family: bin, ihex, mif, coe, mem, csv; a ``rom``
  stream): the FPGA looks
  the code c up by its top m bits, ``address = c >> (n - m)``, and adds the stored
  signed integer times ``lsb`` counts: ``c + table[address] * lsb`` (seed 001 sec. 4.2).
  No interpolation, no other rounding than the table's own.
- :class:`ControlTable` (the controller and control families: acs, siemens, linuxcnc,
  twincat, fanuc, heidenhain): the control interpolates linearly between points at given
  positions of its axis, modulo 360 deg where it wraps; a bidirectional table holds one correction
  per direction. Read by its format record's own reader (``read_points``).
- :class:`ModelCorrection` (a model stream of enc fit-rbf, a deviations curve): minus
  the model at the indicated angle, unquantised: what a perfect table would add.

A new format is a record of :mod:`enctools.models.romformats.registry`: a control's
reader (``read_points``) returns a :class:`~enctools.models.romformats.points.PointTable`,
applied here as a :class:`ControlTable`, a memory's words a :class:`MemoryTable`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from enctools.errors import DataError, SettingsError
from enctools.models import romformats
from enctools.models.rom import LSB_COUNTS, MAX_ADDRESS_BITS
from enctools.models.romformats import headers, registry
from enctools.models.romformats.points import PointTable
from enctools.units import ARCSEC, DEG, TWO_PI, factor

#: the first comment line enc make-rom writes in a text table (mif, coe, mem, acs, siemens)
COMMENT = headers.COMMENT
#: bits of the code a table may be built for (enc make-rom's ``code_bits``)
MAX_CODE_BITS = 40


class Correction(Protocol):
    """What a table adds to an indicated angle, as the hardware that holds it would."""

    def correction_rad(self, indicated_rad: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """The correction [rad] added to each indicated angle [rad], approached in
        ``direction`` (+1 or -1 a reading)."""
        ...

    def describe(self) -> dict[str, Any]:
        """The table's layout for a summary (units as key suffixes)."""
        ...


@dataclass(frozen=True)
class MemoryTable:
    """A ROM over the top ``address_bits`` m of an n-bit code.

    values : signed corrections [LSB], one per address (2**m of them).
    code_bits : n, bits of the code (counts per turn = 2**n).
    lsb : counts of the code per LSB of a value.
    """

    values: np.ndarray
    code_bits: int
    lsb: float
    fmt: str = "bin"
    width: int | None = None
    stated: dict[str, Any] | None = None  # sample, endian, where the layout came from

    @property
    def address_bits(self) -> int:
        return int(self.values.size).bit_length() - 1

    def correction_counts(self, code: np.ndarray) -> np.ndarray:
        """The correction [count] an FPGA adds to each code (integers mod 2**n):
        ``table[code >> (n - m)] * lsb``."""
        c = np.mod(np.asarray(code, dtype=np.int64), np.int64(1) << self.code_bits)
        return self.values[c >> (self.code_bits - self.address_bits)] * self.lsb

    def code_of(self, indicated_rad: np.ndarray) -> np.ndarray:
        """The code [count] of an indicated angle [rad]: the nearest one, mod 2**n."""
        counts = np.rint(np.asarray(indicated_rad, dtype=np.float64) * (2.0 ** self.code_bits
                                                                         / TWO_PI))
        return np.mod(counts, 2.0 ** self.code_bits).astype(np.int64)

    def correction_rad(self, indicated_rad: np.ndarray, direction: np.ndarray) -> np.ndarray:
        count_rad = TWO_PI / 2.0 ** self.code_bits
        return self.correction_counts(self.code_of(indicated_rad)) * count_rad

    def describe(self) -> dict[str, Any]:
        count_arcsec = TWO_PI / 2.0 ** self.code_bits * factor("rad", "arcsec")
        out: dict[str, Any] = {"family": "memory", "format": self.fmt,
                               "entries": int(self.values.size), "code_bits": self.code_bits,
                               "address_bits": self.address_bits}
        if self.width is not None:
            out["width_bits"] = self.width
        return out | {"lsb_arcsec": self.lsb * count_arcsec,
                      "min_lsb": int(self.values.min()), "max_lsb": int(self.values.max())
                      } | (self.stated or {})


@dataclass(frozen=True)
class ControlTable:
    """A motion control's table (:class:`~enctools.models.romformats.points.PointTable`,
    read by the control's own reader: corrections [rad] at positions [rad], its sign
    resolved, interpolated linearly, wrapped modulo its period) as a :class:`Correction`.
    """

    table: PointTable
    fmt: str = "siemens"

    def correction_rad(self, indicated_rad: np.ndarray, direction: np.ndarray) -> np.ndarray:
        return np.asarray(self.table.correction(indicated_rad, direction), dtype=np.float64)

    def describe(self) -> dict[str, Any]:
        p = np.asarray(self.table.positions_rad)
        step = np.diff(p) / DEG
        bidirectional = self.table.backward_rad is not None or self.table.backlash_rad is not None
        lash = self.table.backlash_rad
        return {"family": "points", "format": self.fmt, "entries": int(p.size),
                "bidirectional": bidirectional,
                "step_deg": float(step.mean()) if step.size else 360.0} \
            | ({} if lash is None else {"backlash_arcsec": lash / ARCSEC})


@dataclass(frozen=True)
class ModelCorrection:
    """Minus an error model (angles [deg] -> deviation [arcsec]), unquantised."""

    model: Callable[[np.ndarray], np.ndarray]
    kind: str = "model"

    def correction_rad(self, indicated_rad: np.ndarray, direction: np.ndarray) -> np.ndarray:
        deg = np.mod(np.asarray(indicated_rad, dtype=np.float64) / DEG, 360.0)
        return -np.asarray(self.model(deg), dtype=np.float64) * ARCSEC

    def describe(self) -> dict[str, Any]:
        return {"family": "model", "format": self.kind}


@dataclass(frozen=True)
class TableSettings:
    """How to read a table file, as enc make-rom names its options; None: what the file
    states (enc make-rom writes its layout in a comment of mif, coe, mem, acs and siemens
    tables, in a sidecar of csv and ihex tables), else the default.

    fmt : a format of :mod:`enctools.models.romformats.registry` (None: from the
        extension, else the content).
    code_bits : n, bits of the code (None: stated by the file, else the rig's code of the
        stream corrected; a raw image states none).
    address_bits : m, the code's top bits addressing the table (default: from its size).
    width : word width [bit] (default 16): bin and ihex need it to split words.
    lsb : counts of the code per LSB (default 1).
    endian : bin and ihex byte order (default little).
    array_name : acs: the REAL array holding the map.
    sign : acs, fanuc, heidenhain: whether the file stores the correction or the error.
    comp_type : linuxcnc: COMP_FILE_TYPE (0 or 1).
    axis : heidenhain: the table's column; fanuc-param: the axis number.
    detection_unit_deg : fanuc-param: the axis's detection unit [deg].
    options_given : which of ``sign`` and :data:`~.romformats.registry.READ_SETTINGS` were given
        (not defaults): each is refused for a table whose format's reader is not told it.
    """

    fmt: str | None = None
    code_bits: int | None = None
    address_bits: int | None = None
    width: int | None = None
    lsb: float | None = None
    endian: str | None = None
    array_name: str = "ENC_COMP"
    sign: str | None = None
    comp_type: int = 0
    axis: str | None = None
    detection_unit_deg: float = 1e-3
    options_given: frozenset[str] = frozenset()

    def __post_init__(self) -> None:
        if not (0 < self.detection_unit_deg <= 1 and np.isfinite(self.detection_unit_deg)):
            msg = f"`detection_unit_deg` must be in (0, 1] deg, not {self.detection_unit_deg}"
            raise SettingsError(msg)
        if self.code_bits is not None and not 1 <= self.code_bits <= MAX_CODE_BITS:
            msg = f"`code_bits` must be 1..{MAX_CODE_BITS}, not {self.code_bits}"
            raise SettingsError(msg)
        if self.address_bits is not None and not 1 <= self.address_bits <= MAX_ADDRESS_BITS:
            msg = f"`address_bits` must be 1..{MAX_ADDRESS_BITS}, not {self.address_bits}"
            raise SettingsError(msg)
        if self.width is not None and not 2 <= self.width <= 32:
            msg = f"`width` must be 2..32 bits, not {self.width}"
            raise SettingsError(msg)
        if self.lsb is not None and not LSB_COUNTS[0] <= self.lsb <= LSB_COUNTS[1]:
            msg = f"`lsb` must be a positive number of counts, 1e-06..1099511627776, not {self.lsb}"
            raise SettingsError(msg)

    def given(self) -> dict[str, Any]:
        """The layout settings given, by field between backticks (as a message names them)."""
        return {k: v for k, v in (("`code_bits`", self.code_bits),
                                  ("`address_bits`", self.address_bits),
                                  ("`width`", self.width), ("`lsb`", self.lsb),
                                  ("`endian`", self.endian)) if v is not None}


@dataclass(frozen=True)
class Layout:
    """A table's layout as resolved: code bits n, word width [bit], lsb [counts], byte
    order, and what stated it (``comment``, ``sidecar``, ``options``, ``rig``)."""

    code_bits: int | None
    width: int
    lsb: float
    endian: str = "little"
    stated_by: str = "options"
    sample: str | None = None

    def describe(self) -> dict[str, Any]:
        """What a summary says of the layout beyond the table's size and words."""
        out: dict[str, Any] = {"layout_from": self.stated_by}
        return out | ({"sample": self.sample} if self.sample else {})


def file_layout(path: str, data: bytes, settings: TableSettings, fmt: str,
                rig_bits: int | None = None) -> Layout:
    """The layout of a table file: what it states (its sidecar, else its make-rom comment),
    else the options given, else the code's bits ``rig_bits`` of the rig of the stream
    corrected and the defaults; SettingsError when a setting contradicts what it states."""
    stated, where = None, "its sidecar"
    if headers.has_sidecar(fmt):
        stated = headers.from_sidecar(path)
    if stated is None:
        stated, where = headers.from_comment(data[:4096].decode("utf-8", "replace")), \
            "its comment"
    if stated is None:
        bits, by = (settings.code_bits, "options") if settings.code_bits is not None or \
            rig_bits is None else (rig_bits, "rig")
        return Layout(bits, settings.width or 16, settings.lsb or 1.0,
                      settings.endian or "little", by)
    check_given(settings, {"`code_bits`": stated.code_bits, "`width`": stated.width,
                           "`lsb`": stated.lsb, "`address_bits`": stated.address_bits,
                           "`endian`": stated.endian}, path, where)
    return Layout(stated.code_bits, stated.width, stated.lsb,
                  stated.endian or settings.endian or "little", where.split()[1],
                  stated.sample)


def check_given(settings: TableSettings, found: dict[str, Any], path: str, where: str) -> None:
    """SettingsError when a setting given contradicts what the table itself states."""
    for option, value in settings.given().items():
        stated = found.get(option)
        if stated is None:
            continue
        if isinstance(value, str) or isinstance(stated, str):
            same = value == stated
        else:
            same = bool(np.isclose(value, stated, rtol=1e-9, atol=0))
        if not same:
            shown = stated if isinstance(stated, str) else f"{stated:.10g}"
            given = value if isinstance(value, str) else f"{value:.10g}"
            msg = (f"{path}: {where} says the table was made with {option} "
                   f"{shown}, not {given}; leave {option} out")
            raise SettingsError(msg)


def _read_values(path: str, settings: TableSettings, fmt: str, layout: Layout,
                 count_deg: float) -> np.ndarray:
    """The signed values [LSB] of a table file, read by :func:`romformats.read_table` (in
    the table's word size), once the entries it claims fit the code's addresses."""
    target = romformats.Target(fmt, layout.width, layout.endian, count_deg=count_deg,
                               name=settings.array_name)
    # its entries held to the code's addresses before anything of their size is allocated
    return romformats.read_table(path, target, layout.code_bits)


#: what a table's error adds about the options of a file without a stated layout
LAYOUT_OPTIONS = ("give `code_bits` N (the code's bits), and `width`, `lsb`, `endian` as "
                  "make-rom was given them when not 16, 1, little")


def memory_table(path: str, data: bytes, settings: TableSettings, fmt: str,
                 rig_bits: int | None = None) -> MemoryTable:
    """A memory table (bin, ihex, mif, coe, mem, csv) and its layout, its size checked."""
    layout = file_layout(path, data, settings, fmt, rig_bits)
    if layout.code_bits is None:
        place = registry.get(fmt).layout_in
        where = "a raw image has no place for its layout" if place is None else \
            f"a {fmt} table without its make-rom {place}"
        msg = f"{path}: {where}, and the input names no 2^n-count code; {LAYOUT_OPTIONS}"
        raise SettingsError(msg)
    values = _read_values(path, settings, fmt, layout, 1.0)
    binary = registry.get(fmt).binary
    stated = layout.describe() | ({"endian": layout.endian} if binary else {})
    return checked_memory(values, layout.code_bits, settings.address_bits, layout.lsb, path,
                          fmt, layout.width, stated)


def checked_memory(values: np.ndarray, code_bits: int, address_bits: int | None, lsb: float,
                   path: str, fmt: str, width: int | None = None,
                   stated: dict[str, Any] | None = None) -> MemoryTable:
    """A memory table once its size is 2**m entries, m <= n (and m = ``address_bits``)."""
    n = values.size
    m = n.bit_length() - 1
    if n == 0 or n != 1 << m or m > code_bits:
        record = registry.find(fmt)  # a rom stream has none
        msg = (f"{path}: {n} entries do not address a {code_bits}-bit code "
               f"(a table holds 2^m entries, m <= {code_bits}); check `code_bits`"
               + (", `width`" if record is not None and record.binary else ""))
        raise DataError(msg)
    if address_bits is not None and address_bits != m:
        msg = (f"{path}: {n} entries = 2^{m}, not the 2^{address_bits} of "
               f"`address_bits` {address_bits}")
        raise DataError(msg)
    return MemoryTable(values, code_bits, lsb, fmt, width, stated)


def control_table(path: str, settings: TableSettings, fmt: str) -> ControlTable:
    """A motion control's table file (enc-make-rom(1), CONTROLS), read as its control
    reads it (:func:`~enctools.models.romformats.read_points`; ``settings`` say what the
    file does not: sign, comp_type, axis, array_name)."""
    return ControlTable(romformats.read_points(path, fmt, settings), fmt)


def read_file(path: str, settings: TableSettings, fmt: str | None = None,
              rig_bits: int | None = None) -> Correction:
    """The correction held by a table file of any format enc make-rom writes (``fmt``:
    its format, None: :func:`source_format`'s); ``rig_bits``: the code's bits of the rig of
    the stream corrected, for a memory table that states none."""
    fmt = fmt or romformats.format_for(path, settings.fmt)
    if registry.get(fmt).points:  # a controller's: its reader reads the file
        return control_table(path, settings, fmt)
    from enctools.models.romformats.blockread import head

    # its layout is in its first 4 KiB: its words are read a block at a time
    return memory_table(path, head(path, 4096), settings, fmt, rig_bits)


def rom_stream(meta: dict[str, Any], address: np.ndarray, values: np.ndarray,
               settings: TableSettings, source: str) -> MemoryTable:
    """A memory table from a ``rom`` stream (enc make-rom without -o): its layout from the
    stream's ``rom`` metadata, the options only where it names none."""
    given = meta.get("rom")
    rom: dict[str, Any] = given if isinstance(given, dict) else {}
    bits = rom.get("code_bits", settings.code_bits)
    lsb = rom.get("lsb_counts", settings.lsb or 1.0)
    if not isinstance(bits, int) or isinstance(bits, bool) or not 1 <= bits <= MAX_CODE_BITS:
        msg = f"{source}: the rom stream names no code_bits 1..{MAX_CODE_BITS}; give `code_bits`"
        raise DataError(msg)
    if isinstance(lsb, bool) or not isinstance(lsb, (int, float)) or \
            not LSB_COUNTS[0] <= lsb <= LSB_COUNTS[1]:
        msg = f"{source}: the rom stream's lsb_counts {lsb!r} is not a valid LSB"
        raise DataError(msg)
    if not np.array_equal(address, np.arange(address.size)):
        msg = f"{source}: addresses are not 0, 1, 2, ... without gaps"
        raise DataError(msg)
    check_given(settings, {"`code_bits`": bits, "`lsb`": lsb, "`width`": rom.get("width_bits"),
                           "`address_bits`": rom.get("address_bits")}, source, "its metadata")
    return checked_memory(np.asarray(values, dtype=np.int64), bits, settings.address_bits,
                          float(lsb), source, "stream", rom.get("width_bits"))


def rig_code_bits(meta: dict[str, Any]) -> int | None:
    """n of the one 2^n-count encoder of a stream's rig (its ``rig`` metadata), else None."""
    from enctools.data.readings import rig_encoders

    try:
        found = {e.counts_per_rev for e in rig_encoders(meta)}
    except (DataError, KeyError, TypeError, ValueError):
        return None
    bits = [c.bit_length() - 1 for c in found if c > 0 and c & (c - 1) == 0]
    return bits[0] if len(bits) == 1 else None


#: what a file is called when it is read as a stream, not a table file
STREAM = "stream"


def source_format(path: str, fmt: str | None) -> str:
    """What ``path`` holds, by the order of authority (enc-streams(5), FORMATS): ``fmt``
    if given; else a known extension (a table format's, or a stream's: .csv is
    a stream when its sidecar is a stream's, else a make-rom table); else the content:
    a stream's unambiguous signature or an Arrow stream's marker, a table format's own
    content (:func:`~enctools.models.romformats.headers.identify`). :data:`STREAM` or a
    table format; SettingsError when nothing says."""
    import os
    from pathlib import Path

    from enctools.data import formats

    if fmt is not None:
        return fmt
    ext = Path(path).suffix.lower()
    if ext == ".csv":
        doc = headers.sidecar_doc(path)
        return STREAM if doc is not None and not headers.is_table_sidecar(doc) else "csv"
    named = registry.by_extension(ext)
    if named is not None:
        return named.name
    doc = headers.sidecar_doc(path)
    if headers.is_table_sidecar(doc) and doc is not None:  # a table's sidecar names it
        stated = doc["enctools"]["table"].get("format")
        return stated if isinstance(stated, str) and headers.has_sidecar(stated) else "csv"
    if formats.by_name(path) is not None or not os.path.isfile(path):
        return STREAM  # a missing file: opening it says so
    try:
        head, tail = formats.path_ends(path, 4096)
    except OSError:
        return STREAM
    found = STREAM if formats.content_format(head, tail[-8:]) else headers.identify(head)
    if found is None:
        msg = (f"{path}: cannot tell the table's format from its name or content; give "
               f"`fmt` ({', '.join(registry.names())})")
        raise SettingsError(msg)
    return found


def check_applies(settings: TableSettings, fmt: str, path: str) -> None:
    """Refuse (SettingsError, one line) a setting given that the table's format does not
    take (its reader would not be told it): ``sign`` and the controllers' read settings
    (:meth:`~.romformats.record.TableFormat.reads`), a memory's layout for a controller's
    table, ``endian`` for a table of text."""
    record = registry.find(fmt)  # None: a stream
    what = f"not the stream {path}" if record is None else f"not the {fmt} table {path}"
    for name in ("sign", *registry.READ_SETTINGS):
        if name in settings.options_given and (record is None or not record.reads(name)):
            takes = ", ".join(r.name for r in registry.records() if r.reads(name))
            msg = f"`{name}` applies to {takes}, {what}"
            raise SettingsError(msg)
    layout = settings.given()
    if record is not None and record.points and layout:
        msg = (f"{next(iter(layout))} describes a memory's table "
               f"({', '.join(registry.names(registry.MEMORY))}), {what}")
        raise SettingsError(msg)
    if settings.endian is not None and (record is None or not record.binary):
        binary = " and ".join(r.name for r in registry.records() if r.binary)
        msg = f"`endian` applies to {binary} (binary images), {what}"
        raise SettingsError(msg)


def load(path: str, settings: TableSettings, curve: str | None = None,
         rig_bits: int | None = None) -> Correction:
    """The correction held by ``path``: a table file of any format enc make-rom writes,
    a ``rom`` stream, a model stream (enc fit-rbf) or a deviations stream (``curve``).
    ``rig_bits``: the bits of the code of the stream corrected (a 2^n-count encoder's n),
    for a memory table that states none (a raw image)."""
    if path == "-":
        msg = "`table_path` must name a file (the input is read from stdin)"
        raise SettingsError(msg)
    fmt = source_format(path, settings.fmt)
    check_applies(settings, fmt, path)
    if fmt != STREAM:
        if curve is not None:
            msg = f"`curve` chooses a curve of a deviations stream; {path} is a table file"
            raise SettingsError(msg)
        return read_file(path, settings, fmt, rig_bits)
    import os

    from enctools.data import formats, streams
    from enctools.models.curve_model import from_stream

    try:
        src = streams.open_input(path, ("rom", "model", "deviations"))
    except DataError as exc:
        if formats.by_name(path) is None and os.path.isfile(path):  # known by its content
            msg = f"{exc}; if it is a table file, give its format with `fmt`"
            raise DataError(msg) from None
        raise
    table = src.read_all()
    if src.header.kind != "rom" and settings.given():
        option = next(iter(settings.given()))
        msg = f"{option} describes a table; {src.source} is a {src.header.kind} stream"
        raise SettingsError(msg)
    if src.header.kind == "rom":
        if table.column("address").null_count or table.column("correction").null_count:
            msg = f"{src.source}: the rom stream has empty addresses or corrections"
            raise DataError(msg)
        return rom_stream(src.header.meta, table.column("address").to_numpy(),
                          table.column("correction").to_numpy(), settings, src.source)
    return ModelCorrection(from_stream(src.header, table, src.source, curve), src.header.kind)
