"""Correction tables for FPGAs and motion controllers: one call to write a table, read it
back or verify it, whatever its format.

Each format is one record of :mod:`.registry` (:class:`~.record.TableFormat`: its
extensions, family, writer and readers, the settings it takes, its limits), registered
by its module in :mod:`.catalogue`; the calls here read the records and name no format.
A memory's table (bin, ihex, mif, coe, mem, csv) and a controller's addressed table
(acs, siemens) are words, one per address, written by their record's ``write_values``
(:mod:`.writers`, :mod:`.csvtext`) and read back by its ``read_values`` (:mod:`.readers`),
so an export can be checked. Hex words are two's complement in ``width`` bits,
``ceil(width / 4)`` digits.

The motion controls' compensation tables (the control family: LinuxCNC, TwinCAT CNC and
NC, Fanuc's sheet and parameter transfer file, HEIDENHAIN) are point tables over the
turn at the control's resolution (:mod:`.controls` builds them by the rules of their
record's ``control``, their ``write_table`` (:mod:`.controlwriters`) writes them, their
``read_points`` (:mod:`.controlreaders`) reads them back as a
:class:`~.points.PointTable`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from enctools.data.files import format_by_extension, read_bytes
from enctools.errors import CheckFailed, DataError, SettingsError
from enctools.models.romformats import registry
from enctools.models.romformats.record import PointOptions, Reading
from enctools.units import ARCSEC, DEG

if TYPE_CHECKING:  # the registry is read by the commands' help: numpy is imported for work
    import numpy as np

    from enctools.models.romformats.controls import ControlTable
    from enctools.models.romformats.points import PointTable
    from enctools.models.romformats.words import Target


def __getattr__(name: str) -> Any:
    """:class:`~.words.Target`, and the registry's formats as the tables this module once
    held (read at each access: a format registered later is in them): FORMATS (memories
    and controllers), CONTROLS, CONTROLLER, EXTENSIONS, MAX_ENTRIES, WRITERS, READERS."""
    if name == "Target":
        from enctools.models.romformats.words import Target

        return Target
    views: dict[str, Callable[[], Any]] = {
        "FORMATS": lambda: registry.names(registry.MEMORY, registry.CONTROLLER),
        "CONTROLS": lambda: registry.names(registry.CONTROL),
        "CONTROLLER": lambda: registry.names(registry.CONTROLLER),
        "EXTENSIONS": registry.extensions,
        "MAX_ENTRIES": lambda: {r.name: r.max_entries for r in registry.records()
                                if r.family != registry.CONTROL},
        "WRITERS": lambda: {r.name: r.write_values for r in registry.records()
                            if r.write_values is not None},
        "READERS": lambda: {r.name: (r.fast_read, r.read_values) for r in registry.records()
                            if r.read_values is not None}}
    if name in views:
        return views[name]()
    msg = f"module {__name__!r} has no attribute {name!r}"
    raise AttributeError(msg)


def format_for(path: str, fmt: str | None) -> str:
    """The table format: ``fmt`` if given, else from the file's extension."""
    known = registry.names()
    return format_by_extension(path, fmt, known, registry.extensions(), "table format",
                               f"use `target` ({', '.join(known)})")


def check_capacity(target: Target, entries: int) -> None:
    """Refuse (SettingsError, one line) a table the target cannot hold, or settings its
    format refuses (its record's ``check``: names a program cannot take, ...)."""
    fmt = registry.get(target.fmt)
    rows = entries + 1 if fmt.family == registry.CONTROLLER else entries
    limit = target.max_entries if target.max_entries is not None else fmt.max_entries
    if limit is not None and rows > limit:
        msg = (f"{target.fmt}: {rows} table points exceed the {limit} this target holds; use "
               f"fewer `address_bits`, or `max_entries` if your control is configured for more")
        raise SettingsError(msg)
    if fmt.check is not None:
        fmt.check(target, entries)


def write_table(path: str, values: np.ndarray, target: Target, force: bool = False,
                comment: list[str] | None = None, backlash: int | None = None) -> int:
    """Write ``values`` [LSB] to ``path`` atomically (temporary file, then rename), with
    the ``backlash`` machine datum [LSB] in its own file beside it where one is given
    (:func:`backlash_path`; both or neither written).

    Returns the file's size [byte].
    """
    check_capacity(target, values.size)
    if backlash is not None:
        return _write_with_backlash(path, values, target, force, comment or [], backlash)
    from dataclasses import replace

    from enctools.data.csvio import sidecar_path
    from enctools.data.files import OutputGroup, check_new_file, write_atomic
    from enctools.models.romformats import headers

    check_new_file(path, force)
    lines = comment or []
    layout = headers.from_comment("\n".join(lines[:1]))
    fmt = registry.get(target.fmt)
    writer = fmt.write_values
    if writer is None:
        msg = f"{target.fmt} is not written as words (a control's table)"
        raise ValueError(msg)
    if fmt.layout_in != "sidecar" or layout is None:
        write_atomic(path, lambda f: writer(f, values, target, lines))
        return Path(path).stat().st_size
    # no place in the file for its layout: a sidecar beside it, written with it or not at all
    side = sidecar_path(path)
    check_new_file(side, force)
    layout = replace(layout, endian=target.endian if fmt.binary else None)
    with OutputGroup() as group:
        group.write(path, lambda f: writer(f, values, target, lines), force=force)
        group.write(side, headers.sidecar(layout, target.fmt, Path(path).name, lines),
                    force=force)
    return Path(path).stat().st_size


def backlash_path(path: str, target: str) -> str | None:
    """The machine data file written beside a controller's table ``path`` with its
    backlash (SINUMERIK: the table's stem + ``_tea.ini``, in the case of its extension),
    or None where the format writes none."""
    lash = registry.get(target).backlash_file
    if lash is None:
        return None
    p = Path(path)
    suffix = lash.suffix.upper() if p.suffix.isupper() else lash.suffix
    return str(p.with_name(p.stem + suffix))


def _write_with_backlash(path: str, values: np.ndarray, target: Target, force: bool,
                         comment: list[str], backlash: int) -> int:
    """The table and its backlash machine datum file, as one output."""
    from enctools.data.files import OutputGroup, check_new_file

    fmt = registry.get(target.fmt)
    side = backlash_path(path, target.fmt)
    if fmt.backlash_file is None or side is None or fmt.write_values is None:
        msg = f"{target.fmt}: no backlash machine datum is written beside its table"
        raise SettingsError(msg)
    write_values, write_lash = fmt.write_values, fmt.backlash_file.write
    check_new_file(path, force)
    check_new_file(side, force)
    with OutputGroup() as group:
        group.write(path, lambda f: write_values(f, values, target, comment), force=force)
        group.write(side, lambda f: write_lash(f, target, backlash, comment), force=force)
    return Path(path).stat().st_size


def read_table(path: str, target: Target, code_bits: int | None = None) -> np.ndarray:
    """The signed values [LSB] of a table file (DataError, one line, when it is malformed).

    The entries it claims are checked first (:func:`.blockread.check_entries`: against the
    2^``code_bits`` addresses of its code, when given, and the largest table). A file in
    a layout this project writes is read a block at a time into words of the table's size
    (:func:`.blockread.read_words`); any other, whole: the format's fast reader is tried
    first; what it does not take, the general reader reads or refuses.
    """
    from enctools.models.romformats import blockread

    fmt = registry.get(target.fmt)
    fast, general = fmt.fast_read, fmt.read_values
    if general is None:
        msg = f"{target.fmt} is not read as words (a control's table)"
        raise ValueError(msg)
    blockread.check_entries(path, target, code_bits)
    words = blockread.read_words(path, target, code_bits)
    if words is not None:  # a layout this project writes: a block at a time
        return words
    data = read_bytes(path)
    try:
        values = fast(data, target, str(path)) if fast is not None else None
        return general(data, target, str(path)) if values is None else values
    except (ValueError, OverflowError, IndexError, KeyError) as exc:
        # a malformed word the general readers meet one at a time
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        msg = f"{path}: not a readable {target.fmt} table ({why})"
        raise DataError(msg) from None


def verify_table(path: str, values: np.ndarray, target: Target) -> None:
    """Read a written table back: CheckFailed unless it equals ``values`` [LSB] (an array,
    or a table that gives its words a slice at a time: :class:`~.words.Words`),
    compared a block at a time where the file is in a layout this project writes."""
    import numpy as np

    from enctools.models.romformats import blockread

    same = blockread.same_words(path, target, values)
    if same is None:  # a layout read whole
        same = bool(np.array_equal(read_table(path, target), np.asarray(values)))
    if not same:
        msg = f"{path}: the table read back differs from the table built"
        raise CheckFailed(msg)


def write_control_table(path: str, table: ControlTable, force: bool = False,
                        comment: list[str] | None = None) -> int:
    """Write a control's table to ``path`` atomically, with its companion file where the
    control needs one (:func:`companion_path`; both or neither written); returns the
    table file's size [byte]."""
    from enctools.data.files import OutputGroup, check_new_file

    fmt = registry.get(table.settings.target)
    writer = fmt.write_table
    if writer is None:
        msg = f"{table.settings.target} is not a control's table"
        raise ValueError(msg)
    companion = companion_path(path, table.settings.target)
    check_new_file(path, force)
    if companion is not None:
        check_new_file(companion, force)
    with OutputGroup() as outputs:
        outputs.write(path, lambda f: writer(f, table, comment or []), force=force)
        if companion is not None and fmt.companion is not None:
            write = fmt.companion.write
            outputs.write(companion, lambda f: write(f, table, Path(path).name), force=force)
    return Path(path).stat().st_size


def companion_path(path: str, target: str) -> str | None:
    """The file written beside a control's table ``path`` (HEIDENHAIN: the .CMA, in the
    case of the table's extension), or None."""
    companion = registry.get(target).companion
    if companion is None:
        return None
    p = Path(path)
    ext = companion.extension.upper() if p.suffix.isupper() else companion.extension
    return str(p.with_suffix(ext)) if p.suffix.lower() != ext.lower() else str(p) + ext


def read_control_table(path: str, target: str, sign: str | None = None, comp_type: int = 0,
                       axis: str | None = None, array_name: str = "ENC_COMP",
                       detection_unit_deg: float = 1e-3) -> PointTable:
    """:func:`read_points` with the options as values."""
    return read_points(path, target, Reading(sign, comp_type, axis, array_name,
                                             detection_unit_deg))


def read_points(path: str, target: str, options: PointOptions) -> PointTable:
    """A controller's table file as its control reads it: the corrections [rad] to add to
    the indicated angle (:class:`PointTable`), by its format's record (a controller's or a
    control's). ``options``: what the file itself does not say (``sign`` where the record
    documents none, ``comp_type``, ``axis``, ``array_name``). DataError (one line) when
    the control would refuse or misread it."""
    fmt = registry.get(target)
    if fmt.read_points is None:
        msg = (f"{target} is not a control's table "
               f"({', '.join(registry.names(registry.CONTROL, registry.CONTROLLER))})")
        raise SettingsError(msg)
    data = read_bytes(path)
    if fmt.sign is None and options.sign not in ("correction", "error"):
        msg = (f"{target}: the file does not say the sign of its values; give `sign` "
               "correction or `sign` error, as make-rom was given it")
        raise SettingsError(msg)
    try:
        table = fmt.read_points(data, path, options)
    except (ValueError, OverflowError, IndexError, KeyError) as exc:
        why = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        msg = f"{path}: not a readable {target} table ({why})"
        raise DataError(msg) from None
    side = backlash_path(path, target)
    if fmt.backlash_file is None or side is None or not Path(side).is_file():
        return table
    from dataclasses import replace

    return replace(table, backlash_rad=fmt.backlash_file.read(read_bytes(side), side, data) * DEG)


def _verify_companion(path: str, target: str, axis: str | None) -> None:
    """CheckFailed unless the table's companion (if the control has one) makes this table
    file the axis's active one, as the control reads it."""
    companion = registry.get(target).companion
    where = companion_path(path, target)
    if companion is None or where is None:
        return
    named = companion.read(read_bytes(where), where, axis or registry.get(target).default_axis)
    if named != Path(path).name:
        msg = f"{where}: names {named!r} for the axis, not {Path(path).name!r}"
        raise CheckFailed(msg)


def _verify_backlash(path: str, table: ControlTable, read: PointTable) -> None:
    """CheckFailed unless the backlash value read back (if one was written) is within half
    its unit of the reversal value it stands for."""
    if table.intended_backlash_rad is None:
        return
    half = table.settings.backlash_unit_deg * DEG / 2.0
    got = read.backlash_rad
    if got is None or abs(got - table.intended_backlash_rad) > half * (1 + 1e-6):
        shown = "none" if got is None else f"{got / ARCSEC:.6g} arcsec"
        msg = (f"{path}: the backlash read back ({shown}) is not within half its unit of "
               f"{table.intended_backlash_rad / ARCSEC:.6g} arcsec")
        raise CheckFailed(msg)


def verify_backlash(path: str, target: str, intended_arcsec: float, unit_deg: float) -> None:
    """CheckFailed unless the backlash machine datum read back with the controller's table
    ``path`` (:func:`read_points`) is within half its unit [deg] of ``intended_arcsec``."""
    got = read_points(path, target, Reading()).backlash_rad
    if got is None or abs(got - intended_arcsec * ARCSEC) > unit_deg * DEG / 2 * (1 + 1e-6):
        shown = "none" if got is None else f"{got / ARCSEC:.6g} arcsec"
        msg = (f"{backlash_path(path, target)}: the backlash read back ({shown}) is not within "
               f"half its unit of {intended_arcsec:.6g} arcsec")
        raise CheckFailed(msg)


def verify_control_table(path: str, table: ControlTable) -> float:
    """Read a written control table back with its control's reader: CheckFailed unless every
    point's correction (each direction) is within half the control's resolution of the
    correction intended there. Returns the largest difference [rad]."""
    import numpy as np

    s = table.settings
    read = read_points(path, s.target, Reading(s.sign, s.comp_type, s.axis,
                                               detection_unit_deg=s.detection_unit_deg))
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
    _verify_companion(path, s.target, s.axis)
    _verify_backlash(path, table, read)
    half = table.resolution_deg * DEG / 2.0
    if worst > half * (1 + 1e-6):
        msg = (f"{path}: a correction read back differs from the intended by "
               f"{worst / ARCSEC:.6g} arcsec, more than half the resolution")
        raise CheckFailed(msg)
    return worst
