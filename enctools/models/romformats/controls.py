"""What each motion control's compensation table can hold, and the table built for it.

A control's table is a grid of points over the turn (0 to 360 deg, both ends present
with the same value) holding the compensation at each point in the control's own
resolution, range and sign. :func:`build` chooses the grid (start 0, spacing, count)
within the control's rules, evaluates the intended correction there, rounds it to the
control's resolution and says what this costs: the largest quantisation error and
the interpolation error of the control's linear interpolation between its points
against the source (the step run's targets, or the model on a fine grid).

The sources of each rule are cited in enc-make-rom(1), CONTROLS; what is not
confirmed there is refused (:class:`~enctools.errors.SettingsError`) rather than guessed.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from enctools.errors import DataError, SettingsError
from enctools.units import factor

if TYPE_CHECKING:
    from enctools.methods.targets import MeasuredRange

ARCSEC_PER_DEG = factor("deg", "arcsec")
#: grid spacings that are whole multiples of 0.0001 deg divide this many steps of a turn
TURN_STEPS = 3_600_000
#: Fanuc: pitch error compensation point numbers 0..FANUC_LAST_POINT
FANUC_LAST_POINT = 1023
#: Fanuc: largest |compensation value| of one point, in units of magnification x
#: detection unit (the conservative limit; see enc-make-rom(1))
FANUC_MAX_STEP = 7
FANUC_MAX_MAGNIFICATION = 100
#: a step run's targets within this of m equal steps over the turn [deg] are taken as
#: those steps (measured positions scatter about the commanded ones)
SPACED_DEG = 0.01


@dataclass(frozen=True)
class Control:
    """The rules of one control's compensation table.

    resolution_deg : step of a stored value [deg] (Fanuc: per detection unit, times the
        magnification chosen).
    max_points : points a table holds at most (before ``max_entries``).
    sign : ``correction`` (value added to the indicated angle), ``error`` (value added
        to the command: minus the correction), ``position`` (LinuxCNC type 0) or None:
        not confirmed, ``sign`` must say.
    bidirectional : whether separate forward and backward tables are written.
    value_range : smallest and largest stored value [resolution steps], or None.
    exact_spacing : whether the spacing must be a whole number of 0.0001 deg.
    """

    name: str
    resolution_deg: float
    max_points: int
    sign: str | None
    bidirectional: bool
    value_range: tuple[int, int] | None = None
    exact_spacing: bool = True


SPECS = {
    "linuxcnc": Control("linuxcnc", 1e-6, 256, "error", True, None, exact_spacing=False),
    "twincat": Control("twincat", 1e-4, 1500, "correction", True, (-(1 << 31), (1 << 31) - 1)),
    "fanuc": Control("fanuc", 1e-3, FANUC_LAST_POINT + 1, None, False,
                     (-FANUC_MAX_STEP, FANUC_MAX_STEP)),
    "heidenhain": Control("heidenhain", 1e-4, 256, None, False, None),
}


@dataclass(frozen=True)
class ControlSettings:
    """How a control's table is built, checked when made.

    target : one of :data:`~enctools.models.romformats.CONTROLS`.
    bidirectional : separate forward and backward tables (the source must have both
        directions; the control must take them).
    sign : ``correction`` or ``error`` where the control's convention is not confirmed
        (fanuc, heidenhain); elsewhere None or the control's own.
    comp_type : LinuxCNC COMP_FILE_TYPE, 0 or 1.
    points : points of the grid including both ends (None: chosen).
    max_entries : points the control is configured for (None: the documented default).
    axis : the axis as the file names it (twincat, fanuc: a number; heidenhain: a name).
    detection_unit_deg : Fanuc: the axis's detection unit [deg].
    ref_point : Fanuc: the compensation point number of the reference position.
    """

    target: str
    bidirectional: bool = False
    sign: str | None = None
    comp_type: int = 0
    points: int | None = None
    max_entries: int | None = None
    axis: str | None = None
    detection_unit_deg: float = 1e-3
    ref_point: int = 0

    def __post_init__(self) -> None:
        spec = SPECS[self.target]
        if self.bidirectional and not spec.bidirectional:
            msg = (f"{self.target}: a bidirectional table is not written: the control's "
                   "backward-direction table is not confirmed (enc-make-rom(1), CONTROLS); "
                   "leave out `bidirectional`")
            raise SettingsError(msg)
        if spec.sign is None and self.sign is None:
            msg = (f"{self.target}: the sign of a stored value (correction added, or error "
                   "measured) is not confirmed from the control's documentation; give "
                   "`sign` correction or `sign` error as your control's manual says")
            raise SettingsError(msg)
        if spec.sign is not None and self.sign is not None:
            msg = (f"`sign` applies to the fanuc and heidenhain targets, not {self.target} "
                   "(whose convention is documented)")
            raise SettingsError(msg)
        if self.comp_type not in (0, 1):
            msg = f"`comp_type` must be 0 or 1, not {self.comp_type}"
            raise SettingsError(msg)
        if not (0 < self.detection_unit_deg <= 1 and np.isfinite(self.detection_unit_deg)):
            msg = f"`detection_unit_deg` must be in (0, 1] deg, not {self.detection_unit_deg}"
            raise SettingsError(msg)
        if self.max_entries is not None and not 3 <= self.max_entries <= 1 << 28:
            msg = f"`max_entries` must be 3..{1 << 28}, not {self.max_entries}"
            raise SettingsError(msg)
        if not 0 <= self.ref_point < FANUC_LAST_POINT:
            msg = f"`ref_point` must be 0..{FANUC_LAST_POINT - 1}, not {self.ref_point}"
            raise SettingsError(msg)
        self.check_axis()
        if self.points is not None:  # before any work
            why = self.allows(self.points - 1) if self.points >= 3 else "fewer than 3"
            if why:
                msg = f"`points` {self.points}: {self.target}: {why}"
                raise SettingsError(msg)

    def check_axis(self) -> None:
        """Refuse an axis the file cannot name: twincat and fanuc take a number 0..32,
        heidenhain a name of letters and digits (at most 8); linuxcnc names none (the
        joint's INI section names the file)."""
        import re
        if self.axis is None:
            return
        if self.target == "linuxcnc":
            msg = "`axis`: a LinuxCNC compensation file names no joint ([JOINT_n] COMP_FILE does)"
            raise SettingsError(msg)
        if self.target == "heidenhain":
            if not re.fullmatch(r"[A-Z][A-Z0-9]{0,7}", self.axis):
                msg = (f"`axis` must be a HEIDENHAIN axis name (an upper-case letter, then "
                       f"letters or digits, at most 8), not {self.axis!r}")
                raise SettingsError(msg)
        elif not (re.fullmatch(r"[0-9]{1,2}", self.axis) and int(self.axis) <= 32):
            msg = f"`axis` must be an axis number 0..32 for {self.target}, not {self.axis!r}"
            raise SettingsError(msg)

    @property
    def spec(self) -> Control:
        return SPECS[self.target]

    @property
    def stored_sign(self) -> float:
        """+1 if a stored value is the correction, -1 if it is minus the correction."""
        sign = self.sign if self.spec.sign is None else self.spec.sign
        return 1.0 if sign == "correction" else -1.0

    @property
    def limit(self) -> int:
        """Points the table may have."""
        return self.spec.max_points if self.max_entries is None else self.max_entries

    def allows(self, sections: int) -> str | None:
        """Why a grid of ``sections`` equal sections over the turn is refused, or None."""
        if sections + 1 > self.limit:
            return f"{sections + 1} points exceed the {self.limit} the table holds"
        if self.spec.exact_spacing and TURN_STEPS % sections:
            return (f"a spacing of 360/{sections} deg is not a whole number of "
                    "0.0001 deg")
        if self.target == "fanuc":
            per_turn = round(360.0 / self.detection_unit_deg)
            if abs(per_turn * self.detection_unit_deg - 360.0) > 1e-9 or per_turn % sections:
                return (f"a spacing of 360/{sections} deg is not a whole number of "
                        f"detection units ({self.detection_unit_deg!r} deg)")
            if self.ref_point + sections > FANUC_LAST_POINT:
                return (f"points {self.ref_point}..{self.ref_point + sections} pass the "
                        f"last point number {FANUC_LAST_POINT}")
        return None


@dataclass
class Source:
    """What a table is built from: the deviation (indicated - true) [arcsec] at angles
    [deg] per direction, and the step run's targets [deg] (None for a model)."""

    forward: Callable[[np.ndarray], np.ndarray]
    backward: Callable[[np.ndarray], np.ndarray] | None = None
    targets_deg: np.ndarray | None = None
    reversal_arcsec: np.ndarray | None = None  # B_i = deviation up - down, per target
    measured: MeasuredRange | None = None  # the range the step run's targets measure


@dataclass
class ControlTable:
    """A built table: grid [deg] and stored values [resolution steps, the control's sign]."""

    settings: ControlSettings
    grid_deg: np.ndarray
    forward: np.ndarray
    backward: np.ndarray | None
    resolution_deg: float
    intended_forward_rad: np.ndarray
    intended_backward_rad: np.ndarray | None
    magnification: int = 1
    summary: dict[str, Any] = field(default_factory=dict)

    @property
    def spacing_deg(self) -> float:
        return float(self.grid_deg[1] - self.grid_deg[0])


def choose_sections(settings: ControlSettings, source: Source) -> int:
    """The grid's sections over the turn: ``points`` if given (refused if the control does
    not allow it), else the step run's targets if the control allows them (or the fewest
    multiple of them it does), else the most the control allows."""
    if settings.points is not None:  # checked when the settings were made
        return settings.points - 1
    targets = source.targets_deg
    if targets is not None and _equally_spaced(targets):
        m = targets.size
        for k in range(m, settings.limit, m):
            if settings.allows(k) is None:
                return k
    for k in range(min(settings.limit - 1, 3600), 2, -1):  # spacings of whole 0.0001 deg
        if TURN_STEPS % k == 0 and settings.allows(k) is None:
            return k
    msg = f"{settings.target}: no grid over the turn fits the control's rules"
    raise SettingsError(msg)


def _equally_spaced(targets_deg: np.ndarray) -> bool:
    """Whether targets [deg] are m equally spaced positions over the whole turn from 0."""
    m = targets_deg.size
    expected = np.arange(m) * 360.0 / m
    return m >= 2 and bool(np.all(np.abs(np.sort(targets_deg) - expected) < SPACED_DEG))


def build(settings: ControlSettings, source: Source) -> ControlTable:
    """The control's table from ``source``: grid, intended corrections, stored values.

    DataError (one line) when a value is beyond the control's range, or the source
    lacks the backward direction a bidirectional table needs.
    """
    if settings.bidirectional and source.backward is None:
        msg = ("`bidirectional` needs a step run with both directions "
               "(a points stream with direction +1 and -1)")
        raise DataError(msg)
    k = choose_sections(settings, source)
    grid = np.arange(k + 1) * (360.0 / k)
    grid[-1] = 360.0
    fwd = -np.asarray(source.forward(grid), dtype=np.float64)  # correction [arcsec]
    bwd = None if source.backward is None else -np.asarray(source.backward(grid), np.float64)
    if not settings.bidirectional and bwd is not None:
        fwd, bwd = (fwd + bwd) / 2.0, None  # the mean bidirectional deviation
    if not np.all(np.isfinite(fwd)) or (bwd is not None and not np.all(np.isfinite(bwd))):
        msg = "the source gives NaN or infinite deviations"
        raise DataError(msg)
    offset = 0.0
    if settings.target == "fanuc":  # the compensation is 0 at the reference position
        offset = float(fwd[0])
        fwd = fwd - offset
    table = _quantise(settings, grid, fwd, bwd)
    table.summary = _summary(table, source, fwd, bwd, offset)
    return table


def _quantise(settings: ControlSettings, grid: np.ndarray, fwd: np.ndarray,
              bwd: np.ndarray | None) -> ControlTable:
    """Stored values of intended corrections [arcsec] at the control's resolution."""
    spec = settings.spec
    sign = settings.stored_sign
    magnification = 1
    resolution = spec.resolution_deg
    if settings.target == "fanuc":
        magnification, resolution = _fanuc_magnification(settings, fwd)
    step_arcsec = resolution * ARCSEC_PER_DEG

    def stored(corr: np.ndarray) -> np.ndarray:
        q = np.rint(sign * corr / step_arcsec)
        values = np.diff(q) if settings.target == "fanuc" else q
        if spec.value_range is not None:
            lo, hi = spec.value_range
            if values.min() < lo or values.max() > hi:
                worst = values.min() if values.min() < lo else values.max()
                msg = (f"{settings.target}: a stored value of {worst:.0f} x {resolution!r} deg "
                       f"is beyond the control's range {lo}..{hi}")
                raise DataError(msg)
        return q.astype(np.int64)

    rad = factor("arcsec", "rad")
    return ControlTable(settings, grid, stored(fwd), None if bwd is None else stored(bwd),
                        resolution, fwd * rad,
                        None if bwd is None else bwd * rad, magnification)


def _fanuc_magnification(settings: ControlSettings, fwd: np.ndarray) -> tuple[int, float]:
    """The smallest magnification (parameter 3623) whose increments fit +-FANUC_MAX_STEP,
    and the resolution [deg] it gives (magnification x detection unit)."""
    du = settings.detection_unit_deg
    for mag in range(1, FANUC_MAX_MAGNIFICATION + 1):
        q = np.rint(settings.stored_sign * fwd / (mag * du * ARCSEC_PER_DEG))
        if np.abs(np.diff(q)).max(initial=0) <= FANUC_MAX_STEP:
            return mag, mag * du
    msg = (f"fanuc: the correction changes by more than {FANUC_MAX_STEP} x "
           f"{FANUC_MAX_MAGNIFICATION} x {du!r} deg between points; use more `points`")
    raise DataError(msg)


def _summary(t: ControlTable, source: Source, fwd: np.ndarray, bwd: np.ndarray | None,
             offset: float) -> dict[str, Any]:
    """The grid, resolution, and what rounding and interpolation cost [arcsec]."""
    step = t.resolution_deg * ARCSEC_PER_DEG
    sign = t.settings.stored_sign
    quant = float(np.max(np.abs(sign * t.forward * step - fwd)))
    if t.backward is not None and bwd is not None:
        quant = max(quant, float(np.max(np.abs(sign * t.backward * step - bwd))))
    check = (source.targets_deg if source.targets_deg is not None
             else np.arange(14_400) * (360.0 / 14_400))
    dev_f = source.forward(check)
    if source.backward is None:
        pairs = [(dev_f, fwd)]
    elif bwd is None:  # a unidirectional table of a bidirectional run: against the mean
        pairs = [((dev_f + source.backward(check)) / 2.0, fwd)]
    else:
        pairs = [(dev_f, fwd), (source.backward(check), bwd)]
    err = 0.0
    for dev, corr in pairs:  # deviation of the source [arcsec], the table's correction
        table_corr = np.interp(np.mod(check, 360.0), t.grid_deg, corr)
        err = max(err, float(np.max(np.abs(table_corr + dev + offset))))
    out: dict[str, Any] = {
        "target": t.settings.target, "points": int(t.grid_deg.size), "start_deg": 0.0,
        "spacing_deg": t.spacing_deg, "resolution_arcsec": step,
        "direction": "bidirectional" if t.backward is not None else "unidirectional",
        "max_quantisation_error_arcsec": quant, "interpolation_error_arcsec": err}
    if t.settings.target == "fanuc":
        out |= {"magnification": t.magnification, "offset_removed_arcsec": offset}
    if source.reversal_arcsec is not None:
        b = source.reversal_arcsec
        out |= {"reversal_max_arcsec": float(np.max(np.abs(b))),
                "reversal_mean_arcsec": float(np.mean(b))}
    return out
