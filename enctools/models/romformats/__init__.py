"""Correction tables for FPGAs and motion controllers: which formats, and one call to
write a table, read it back or verify it.

Every writer (:mod:`.writers`) takes the signed table values (one per address) and
writes one file; every reader (:mod:`.readers`) gives the values back, so an export
can be checked.

========  ==================================================================
bin       raw two's-complement words, little or big endian, 1/2/4 bytes each
ihex      Intel HEX: the raw image, 16 data bytes a record, type 04 extended
          linear address records (32-bit byte addresses: at most 4 GiB)
mif       Altera/Intel Memory Initialization File (WIDTH, DEPTH, HEX radix)
coe       Xilinx coefficient file (memory_initialization_radix=16;
          memory_initialization_vector=...;)
mem       Verilog ``$readmemh`` text: one hex word a line, // comments
csv       ``address,correction`` in decimal, header line first, no comments
acs       ACS SPiiPlus ACSPL+ program: a REAL array filled element by
          element, then ``ERRORMAP1D axis, zone, base, step, array`` and
          ``ERRORMAPON``; values in degrees
siemens   SINUMERIK interpolatory compensation (``$AA_ENC_COMP``) for a
          rotary axis with modulo: points 0..k, 0 deg and 360 deg both present
          with the same value, no gaps, ``$AA_ENC_COMP_STEP/MIN/MAX/IS_MODULO``;
          values in degrees
========  ==================================================================

Hex words are two's complement in ``width`` bits, ``ceil(width / 4)`` digits.

The motion controls' compensation tables of :data:`CONTROLS` (LinuxCNC, TwinCAT CNC,
Fanuc, HEIDENHAIN) are point tables over the turn at the control's resolution
(:mod:`.controls` builds them, :mod:`.controlwriters` writes them,
:mod:`.controlreaders` reads them back as a :class:`~.points.PointTable`).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import IO, TYPE_CHECKING

import numpy as np

from enctools.data.csvio import sidecar_path
from enctools.data.files import format_by_extension, read_bytes
from enctools.errors import CheckFailed, DataError, SettingsError
from enctools.models.romformats import csvtext, headers, readers, writers
from enctools.models.romformats.words import Target
from enctools.units import ARCSEC, DEG

if TYPE_CHECKING:  # the controls' modules are imported for a control's table alone
    from enctools.models.romformats.controls import ControlTable
    from enctools.models.romformats.points import PointTable

FORMATS = ("bin", "ihex", "mif", "coe", "mem", "csv", "acs", "siemens")
EXTENSIONS = {".bin": "bin", ".rom": "bin", ".hex": "ihex", ".ihex": "ihex", ".mif": "mif",
              ".coe": "coe", ".mem": "mem", ".csv": "csv", ".prg": "acs", ".acs": "acs",
              ".spf": "siemens", ".mpf": "siemens", ".ini": "siemens",
              ".lis": "twincat", ".com": "heidenhain"}
#: formats whose table is a controller's interpolation-point table (0 and 360 deg)
CONTROLLER = ("acs", "siemens")
#: the motion controls whose point tables :mod:`.controls` builds
CONTROLS = ("linuxcnc", "twincat", "fanuc", "heidenhain")
#: entries a target accepts at most (None: only the 2^28 of enctools.models.rom).
#: Intel HEX: 32-bit byte addresses. The controllers' tables are sized by the
#: control's configuration (SINUMERIK MD38000 MM_ENC_COMP_MAX_POINTS, the ACS
#: controller's user memory): conservative defaults, raised with --max-entries.
MAX_ENTRIES: dict[str, int | None] = {"bin": None, "ihex": None, "mif": None, "coe": None,
                                      "mem": None, "csv": None, "acs": 100_000, "siemens": 5_000}
IHEX_MAX_BYTES = 1 << 32

Writer = Callable[[IO[bytes], np.ndarray, Target, list[str]], None]
#: a reader: (file's bytes, target, file's name) -> values; a fast one may give None
Reader = Callable[[bytes, Target, str], np.ndarray]
FastReader = Callable[[bytes, Target, str], np.ndarray | None]

WRITERS: dict[str, Writer] = {
    "bin": writers.write_bin, "ihex": writers.write_ihex, "mif": writers.write_mif,
    "coe": writers.write_coe, "mem": writers.write_mem, "csv": csvtext.write_csv,
    "acs": writers.write_acs, "siemens": writers.write_siemens}
#: format -> (fast reader of the files written here or None, general reader)
READERS: dict[str, tuple[FastReader | None, Reader]] = {
    "bin": (None, readers.read_bin), "ihex": (readers.fast_ihex, readers.read_ihex),
    "mif": (readers.fast_mif, readers.read_mif), "coe": (readers.fast_coe, readers.read_coe),
    "mem": (readers.fast_mem, readers.read_mem), "csv": (None, readers.read_csv),
    "acs": (None, readers.read_acs), "siemens": (None, readers.read_siemens)}


def format_for(path: str, fmt: str | None) -> str:
    """The table format: ``fmt`` if given, else from the file's extension."""
    return format_by_extension(path, fmt, FORMATS + CONTROLS, EXTENSIONS, "table format",
                               f"use `target` ({', '.join(FORMATS + CONTROLS)})")


def check_capacity(target: Target, entries: int) -> None:
    """Refuse (SettingsError, one line) a table the target cannot hold, or names it cannot
    take (:func:`check_names`)."""
    rows = entries + 1 if target.fmt in CONTROLLER else entries
    limit = target.max_entries if target.max_entries is not None else MAX_ENTRIES[target.fmt]
    if limit is not None and rows > limit:
        msg = (f"{target.fmt}: {rows} table points exceed the {limit} this target holds; use "
               f"fewer `address_bits`, or `max_entries` if your control is configured for more")
        raise SettingsError(msg)
    if target.fmt == "ihex" and entries * target.storage_bytes > IHEX_MAX_BYTES:
        msg = (f"ihex: {entries * target.storage_bytes} bytes exceed the 4 GiB of "
               "32-bit Intel HEX addresses")
        raise SettingsError(msg)
    if target.fmt == "bin" and target.endian not in ("little", "big"):
        msg = f"`endian` must be little or big, not {target.endian!r}"
        raise SettingsError(msg)
    check_names(target)


#: SINUMERIK axis names: a letter, then letters, digits or _; at most 8 characters
#: (Siemens programming manual: axis identifiers up to 8 characters, e.g. AX1, C1)
SIEMENS_AXIS = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,7}")
#: ACSPL+ user variable names, the conservative common subset: a letter, then letters,
#: digits or _; at most 32 characters
ACS_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}")
#: ACS axis indices accepted: 0..ACS_MAX_AXIS
ACS_MAX_AXIS = 127
#: the words of the ACS program written here: no array may take one of their names
ACS_WORDS = frozenset({"AXIS_NO", "GLOBAL", "REAL", "INT", "STOP", "ERRORMAP1D",
                       "ERRORUNMAP", "ERRORMAPON"})


def check_names(target: Target) -> None:
    """Refuse (SettingsError, one line naming the setting and the rule) an axis, array name or
    zone that a controller's program cannot take as a name or number: nothing but a name
    or a number ever lands in program text."""
    if target.fmt not in CONTROLLER:
        return
    if isinstance(target.zone, bool) or not isinstance(target.zone, int) or target.zone < 0:
        msg = f"`zone` must be a whole number >= 0, not {target.zone!r}"
        raise SettingsError(msg)
    if target.fmt == "siemens" and not SIEMENS_AXIS.fullmatch(target.axis):
        msg = (f"`axis` must be a SINUMERIK axis name (a letter, then letters, digits or _, "
               f"at most 8 characters, e.g. AX1 or C1), not {target.axis!r}")
        raise SettingsError(msg)
    if target.fmt != "acs":
        return
    if not (re.fullmatch(r"[0-9]{1,3}", target.axis) and int(target.axis) <= ACS_MAX_AXIS):
        msg = f"`axis` must be an ACS axis number 0..{ACS_MAX_AXIS}, not {target.axis!r}"
        raise SettingsError(msg)
    if not ACS_NAME.fullmatch(target.name):
        msg = (f"`array_name` must be an ACSPL+ name (a letter, then letters, digits or _, at most "
               f"32 characters), not {target.name!r}")
        raise SettingsError(msg)
    if target.name.upper() in ACS_WORDS:
        msg = (f"`array_name` {target.name!r} is a word of the program written "
               f"({', '.join(sorted(ACS_WORDS))}); choose another name")
        raise SettingsError(msg)


def write_table(path: str, values: np.ndarray, target: Target, force: bool = False,
                comment: list[str] | None = None) -> int:
    """Write ``values`` [LSB] to ``path`` atomically (temporary file, then rename).

    Returns the file's size [byte].
    """
    check_capacity(target, values.size)
    from enctools.data.files import OutputGroup, check_new_file, write_atomic

    check_new_file(path, force)
    lines = comment or []
    layout = headers.from_comment("\n".join(lines[:1]))
    if target.fmt not in headers.SIDECAR_FORMATS or layout is None:
        write_atomic(path, lambda f: WRITERS[target.fmt](f, values, target, lines))
        return Path(path).stat().st_size
    # no place in the file for its layout: a sidecar beside it, written with it or not at all
    side = sidecar_path(path)
    check_new_file(side, force)
    layout = replace(layout, endian=target.endian if target.fmt == "ihex" else None)
    with OutputGroup() as group:
        group.write(path, lambda f: WRITERS[target.fmt](f, values, target, lines), force=force)
        group.write(side, headers.sidecar(layout, target.fmt, Path(path).name, lines),
                    force=force)
    return Path(path).stat().st_size


def read_table(path: str, target: Target) -> np.ndarray:
    """The signed values [LSB] of a table file (DataError, one line, when it is malformed).

    The format's fast reader is tried first; what it does not take, the general reader
    reads or refuses.
    """
    data = read_bytes(path)
    fast, general = READERS[target.fmt]
    try:
        values = fast(data, target, str(path)) if fast is not None else None
        return general(data, target, str(path)) if values is None else values
    except (ValueError, OverflowError, IndexError, KeyError) as exc:
        # a malformed word the general readers meet one at a time
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        msg = f"{path}: not a readable {target.fmt} table ({why})"
        raise DataError(msg) from None


def verify_table(path: str, values: np.ndarray, target: Target) -> None:
    """Read a written table back: CheckFailed unless it equals ``values`` [LSB]."""
    if not np.array_equal(read_table(path, target), values):
        msg = f"{path}: the table read back differs from the table built"
        raise CheckFailed(msg)


def write_control_table(path: str, table: ControlTable, force: bool = False,
                        comment: list[str] | None = None) -> int:
    """Write a control's table to ``path`` atomically; returns the file's size [byte]."""
    from enctools.data.files import check_new_file, write_atomic
    from enctools.models.romformats import controlwriters

    check_new_file(path, force)
    writer = controlwriters.WRITERS[table.settings.target]
    write_atomic(path, lambda f: writer(f, table, comment or []))
    return Path(path).stat().st_size


def read_control_table(path: str, target: str, sign: str | None = None, comp_type: int = 0,
                       axis: str | None = None, array_name: str = "ENC_COMP") -> PointTable:
    """A control's table file as its control reads it: the corrections [rad] to add to the
    indicated angle (:class:`PointTable`), for every controller target (linuxcnc,
    twincat, fanuc, heidenhain, siemens, acs). ``sign`` (acs, fanuc, heidenhain:
    ``correction`` or ``error``), ``comp_type`` (linuxcnc: COMP_FILE_TYPE 0 or 1),
    ``axis`` (heidenhain: the column) and ``array_name`` (acs) are what the file itself
    does not say. DataError (one line) when the control would refuse or misread it."""
    data = read_bytes(path)
    if target in ("acs", "fanuc", "heidenhain") and sign not in ("correction", "error"):
        msg = (f"{target}: the file does not say the sign of its values; give `sign` "
               "correction or `sign` error, as make-rom was given it")
        raise SettingsError(msg)
    try:
        return _read_control(data, path, target, sign, comp_type, axis, array_name)
    except (ValueError, OverflowError, IndexError, KeyError) as exc:
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        msg = f"{path}: not a readable {target} table ({why})"
        raise DataError(msg) from None


def _read_control(data: bytes, path: str, target: str, sign: str | None, comp_type: int,
                  axis: str | None, array_name: str) -> PointTable:
    """:func:`read_control_table` of the file's bytes, by the target's reader."""
    from enctools.models.romformats import controlreaders

    if target == "linuxcnc":
        return controlreaders.read_linuxcnc(data, path, comp_type)
    if target == "twincat":
        return controlreaders.read_twincat(data, path)
    if target == "fanuc":
        return controlreaders.read_fanuc(data, path, str(sign))
    if target == "heidenhain":
        return controlreaders.read_heidenhain(data, path, str(sign), axis or "C")
    if target == "siemens":
        return controlreaders.read_siemens(data, path)
    if target == "acs":
        return controlreaders.read_acs(data, path, str(sign), array_name)
    msg = f"{target} is not a control's table ({', '.join(CONTROLS + CONTROLLER)})"
    raise SettingsError(msg)


def verify_control_table(path: str, table: ControlTable) -> float:
    """Read a written control table back with its control's reader: CheckFailed unless every
    point's correction (each direction) is within half the control's resolution of the
    correction intended there. Returns the largest difference [rad]."""
    s = table.settings
    read = read_control_table(path, s.target, s.sign, s.comp_type, s.axis)
    grid = table.grid_deg * DEG
    worst = 0.0
    pairs = [(read.correction(grid, 1), table.intended_forward_rad)]
    if table.intended_backward_rad is not None:
        pairs.append((read.correction(grid, -1), table.intended_backward_rad))
    for got, intended in pairs:
        if got.shape != intended.shape:
            msg = f"{path}: {got.size} points read back, {intended.size} written"
            raise CheckFailed(msg)
        worst = max(worst, float(np.max(np.abs(got - intended))))
    half = table.resolution_deg * DEG / 2.0
    if worst > half * (1 + 1e-6):
        msg = (f"{path}: a correction read back differs from the intended by "
               f"{worst / ARCSEC:.6g} arcsec, more than half the resolution")
        raise CheckFailed(msg)
    return worst
