"""One correction-table format as a record: :class:`TableFormat`.

A format is what enc make-rom writes and enc correct reads: its name, the file
extensions that name it, its family (how the table is built and applied), its writer
and readers, the settings it accepts, its resolution and limits, and its one-line help.
The records live in :mod:`.registry`; the formats of enctools are the modules of
:mod:`.catalogue`, one a format. Nothing else names a format: the library and the
command line read the records.

The three families:

- ``memory`` (:data:`MEMORY`): an FPGA's memory, one signed word per address of the
  code's top bits, looked up without interpolation. ``write_values`` and ``read_values``
  (with an optional ``fast_read``) take the words.
- ``controller`` (:data:`CONTROLLER`): a controller's interpolation points at every
  address of the code and the turn's end (0 and 360 deg both present): built as a
  memory's table is, at the addresses' starts, and printed at the control's resolution
  (``resolution_deg`` given), read back as words for the check and as points
  (``read_points``) to be applied.
- ``control`` (:data:`CONTROL`): a motion control's table over a grid of the turn that
  its rules (``control``: a :class:`~.controls.Control`) allow, built by
  :func:`.controls.build`, written by ``write_table``, read back as points.
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import IO, TYPE_CHECKING, Any, Protocol, TypeAlias

from enctools.errors import SettingsError

if TYPE_CHECKING:  # a record is read by --help: it imports no numpy
    import numpy as np

#: what the writers and readers take, named here without importing them (the modules
#: that define them import the registry): ``words.Target``, ``controls.ControlSettings``,
#: ``controls.ControlTable``, ``points.PointTable``
Target: TypeAlias = Any
ControlSettings: TypeAlias = Any
ControlTable: TypeAlias = Any
PointTable: TypeAlias = Any

MEMORY = "memory"
CONTROLLER = "controller"
CONTROL = "control"
FAMILIES = (MEMORY, CONTROLLER, CONTROL)

#: the settings of enc make-rom that shape a memory's (and a controller's addressed)
#: table: every format of those families takes them, no control's table does (a
#: memory's takes ``lsb`` too, a controller's ``resolution_deg``; ``endian``, ``zone``,
#: ``array_name`` only the formats whose records name them)
ADDRESSED_SETTINGS = frozenset({"code_bits", "address_bits", "width", "sample"})
#: what a reader of a controller's or control's file may be told beyond ``sign`` (enc
#: correct's options): a format takes those its record's ``read_settings`` names
READ_SETTINGS = ("array_name", "comp_type", "axis", "detection_unit_deg")
#: the settings every control's table takes (``backlash``: written where the record's
#: control keeps one, else refused with the record's reason)
GRID_SETTINGS = frozenset({"bidirectional", "points", "backlash"})


class PointOptions(Protocol):
    """What a controller's file does not say and its reader must be told."""

    @property
    def sign(self) -> str | None:
        """``correction`` or ``error``: what a stored value is (None: the format's own)."""
        ...

    @property
    def comp_type(self) -> int:
        """LinuxCNC's COMP_FILE_TYPE (0 positions, 1 trims)."""
        ...

    @property
    def axis(self) -> str | None:
        """The axis as the file names it (a column, a number)."""
        ...

    @property
    def array_name(self) -> str:
        """An ACS program's array holding the map."""
        ...

    @property
    def detection_unit_deg(self) -> float:
        """A Fanuc axis's detection unit [deg], where the file does not state it."""
        ...


@dataclass(frozen=True)
class Reading:
    """:class:`PointOptions` as plain values."""

    sign: str | None = None
    comp_type: int = 0
    axis: str | None = None
    array_name: str = "ENC_COMP"
    detection_unit_deg: float = 1e-3


@dataclass(frozen=True)
class Control:
    """The rules of one control's compensation table (a control format's record holds it).

    resolution_deg : step of a stored value [deg] (an incremental table: per detection
        unit, times the magnification chosen).
    max_points : points a table holds at most (before ``max_entries``).
    bidirectional : whether separate forward and backward tables are written.
    value_range : smallest and largest stored value [resolution steps], or None.
    exact_spacing : whether the spacing must be a whole number of 0.0001 deg.
    incremental : whether the table stores increments between points from the home
        point (a magnification chosen so that they fit ``value_range``; the
        correction is 0 at the home position): Fanuc's pitch error compensation.
    grid_rule : why a grid of k sections over the turn is refused beyond the above:
        (settings, k) -> the reason, or None.
    increment_systems : the control's named increment systems and the detection unit
        [deg] each gives (an incremental table's unit: Fanuc's IS-A, IS-B, IS-C), or ().
    backlash_range : smallest and largest backlash value the control keeps apart from
        the table [detection units of an incremental table, else resolution steps], or
        None: no backlash is written (``no_backlash`` says why).
    no_backlash : why a backlash value is not written for this control (one clause).
    """

    resolution_deg: float
    max_points: int
    bidirectional: bool
    value_range: tuple[int, int] | None = None
    exact_spacing: bool = True
    incremental: bool = False
    grid_rule: Callable[[ControlSettings, int], str | None] | None = None
    increment_systems: tuple[tuple[str, float], ...] = ()
    backlash_range: tuple[int, int] | None = None
    no_backlash: str = "its documentation read names no backlash parameter"
    #: why a table per direction is not written, where ``bidirectional`` is False
    no_bidirectional: str = ("the control's backward-direction table is not confirmed "
                             "(enc-make-rom(1), CONTROLS)")


def lazy(module: str, name: str) -> Callable[..., Any]:
    """``module.name``, imported when first called (a record names its writer and readers
    without importing them: the commands' help reads the records). A module named from
    its dot (``.writers``) is one of :mod:`enctools.models.romformats`."""
    if module.startswith("."):
        module = "enctools.models.romformats" + module

    def call(*args: Any, **kwargs: Any) -> Any:
        return getattr(importlib.import_module(module), name)(*args, **kwargs)

    call.__name__ = call.__qualname__ = name
    call.__doc__ = f"{module}.{name}, imported when called."
    return call


def check_axis(settings: Any, pattern: str, what: str) -> None:
    """Refuse an axis the file cannot name: one not matching ``pattern`` (``what`` says
    what it must be)."""
    if settings.axis is not None and not re.fullmatch(pattern, settings.axis):
        msg = f"`axis` must be {what}, not {settings.axis!r}"
        raise SettingsError(msg)


def check_axis_number(settings: Any, entries: int | None = None) -> None:
    """Refuse an axis that is not a number 0..32 (TwinCAT's, Fanuc's)."""
    axis = settings.axis
    if axis is not None and not (re.fullmatch(r"[0-9]{1,2}", axis) and int(axis) <= 32):
        msg = f"`axis` must be an axis number 0..32 for {settings.target}, not {axis!r}"
        raise SettingsError(msg)


#: a companion file written: (file, table, the table file's name as the companion names it)
CompanionWriter = Callable[[IO[bytes], "ControlTable", str], None]
#: a companion read: (bytes, file's name, the axis) -> the table file's name it makes
#: active for the axis
CompanionReader = Callable[[bytes, str, str], str]


@dataclass(frozen=True)
class Companion:
    """A file a control needs beside its table (HEIDENHAIN's .CMA assigning the .COM to
    the axis), written with it as one output and read back with it."""

    #: its extension (lower case, with the dot), in the table file's case
    extension: str
    write: CompanionWriter
    read: CompanionReader


#: a backlash machine datum written: (file, how the table is written, the value [steps of
#: the table's resolution], comment lines)
BacklashWriter = Callable[[IO[bytes], "Target", int, list[str]], None]
#: read back: (its bytes, its name, the table file's bytes) -> the value [deg] for the
#: table's axis and measuring system
BacklashReader = Callable[[bytes, str, bytes], float]


@dataclass(frozen=True)
class BacklashFile:
    """A controller's backlash machine datum (SINUMERIK's MD32450), written as a file of
    its own beside its table with it as one output, and read back with the table."""

    #: the file's name: the table file's stem and this (``_tea.ini``), in its case
    suffix: str
    write: BacklashWriter
    read: BacklashReader
    #: refuses (SettingsError, one line) what the file cannot name: (how the table is written)
    check: Callable[[Any], None] | None = None


#: a memory's or a controller's words written: (file, words [LSB], how, comment lines)
ValuesWriter = Callable[[IO[bytes], "np.ndarray", "Target", list[str]], None]
#: its words read: (file's bytes, how, file's name) -> words; a fast one may give None
ValuesReader = Callable[[bytes, "Target", str], "np.ndarray"]
FastReader = Callable[[bytes, "Target", str], "np.ndarray | None"]
#: a control's built table written: (file, table, comment lines)
TableWriter = Callable[[IO[bytes], "ControlTable", list[str]], None]
#: a controller's file read as its control reads it: (bytes, file's name, options)
PointReader = Callable[[bytes, str, PointOptions], "PointTable"]


@dataclass(frozen=True)
class TableFormat:
    """One table format and what the library needs to know of it."""

    name: str
    #: what it is, in one line (help texts)
    about: str
    family: str
    #: file extensions (lower case, with the dot) that name it
    extensions: tuple[str, ...] = ()
    write_values: ValuesWriter | None = None
    read_values: ValuesReader | None = None
    fast_read: FastReader | None = None
    write_table: TableWriter | None = None
    read_points: PointReader | None = None
    #: a control's rules: resolution, points, directions, stored range (control family)
    control: Control | None = None
    #: what a stored value is when the format documents it (``correction``, ``error``,
    #: ``position``); None: not confirmed, the user's ``sign`` must say
    sign: str | None = "correction"
    #: the settings of enc make-rom it takes beyond its family's (``comp_type``, ...)
    settings: frozenset[str] = field(default_factory=frozenset)
    #: table points it holds at most by default (None: only the library's limit)
    max_entries: int | None = None
    #: where the control keeps the resolution it is written at (controller family)
    resolution_source: str = ""
    #: the axis written when none is given ("" where the file names none)
    default_axis: str = ""
    #: checks its settings (a :class:`~.words.Target` and the table's entries, or a
    #: :class:`~.controls.ControlSettings` and None): SettingsError, one line naming the
    #: field
    check: Callable[[Any, int | None], None] | None = None
    #: where the file states its layout (code bits, width, LSB) for the reader: in its
    #: ``comment``, a ``sidecar`` beside it, or None (a raw image: nowhere)
    layout_in: str | None = "comment"
    #: words stored as bytes: their width and byte order split them (bin, ihex)
    binary: bool = False
    #: content only this format has, searched for in a file's first 4 KiB to name a file
    #: whose extension does not (None: it has none)
    signature: re.Pattern[bytes] | None = None
    #: where it is listed among the others (lower first; then by name)
    rank: int = 100
    #: a file written beside the table, as one output with it (None: none)
    companion: Companion | None = None
    #: a controller's backlash machine datum, a file beside its table (None: refused)
    backlash_file: BacklashFile | None = None
    #: what its reader is told beyond ``sign`` (of :data:`READ_SETTINGS`; enc correct)
    read_settings: frozenset[str] = field(default_factory=frozenset)

    def __post_init__(self) -> None:
        if self.family not in FAMILIES:
            msg = f"{self.name}: family {self.family!r} is not one of {', '.join(FAMILIES)}"
            raise ValueError(msg)
        needs = {MEMORY: ("write_values", "read_values"),
                 CONTROLLER: ("write_values", "read_values", "read_points"),
                 CONTROL: ("write_table", "read_points", "control")}[self.family]
        missing = [n for n in needs if getattr(self, n) is None]
        if missing:
            msg = f"{self.name}: a {self.family} format needs {', '.join(missing)}"
            raise ValueError(msg)

    @property
    def accepts(self) -> frozenset[str]:
        """The settings of enc make-rom that shape its table (its family's and its own)."""
        base = GRID_SETTINGS if self.family == CONTROL else ADDRESSED_SETTINGS
        extra = {CONTROLLER: frozenset({"resolution_deg"}), MEMORY: frozenset({"lsb"})}
        return base | extra.get(self.family, frozenset()) | self.settings

    def reads(self, name: str) -> bool:
        """Whether its reader is told the setting ``name`` (``sign`` where the format
        documents none; one of :data:`READ_SETTINGS` its record names)."""
        if name == "sign":
            return self.points and self.sign is None
        return name in self.read_settings

    @property
    def points(self) -> bool:
        """Whether a controller interpolates the table between its points (not a memory)."""
        return self.family != MEMORY
