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
from enctools.models.romformats import registry
from enctools.units import factor

if TYPE_CHECKING:
    from enctools.methods.targets import MeasuredRange
    from enctools.models.romformats.record import Control, TableFormat

ARCSEC_PER_DEG = factor("deg", "arcsec")
#: grid spacings that are whole multiples of 0.0001 deg divide this many steps of a turn
TURN_STEPS = 3_600_000
#: an incremental table's detection unit when none is given [deg] (Fanuc's IS-B)
DEFAULT_DETECTION_UNIT_DEG = 1e-3
#: an incremental table's (Fanuc's parameter 3623) largest magnification
MAX_MAGNIFICATION = 100
#: a step run's targets within this of m equal steps over the turn [deg] are taken as
#: those steps (measured positions scatter about the commanded ones)
SPACED_DEG = 0.01


@dataclass(frozen=True)
class ControlSettings:
    """How a control's table is built, checked when made.

    target : a format of the control family (:mod:`~enctools.models.romformats.registry`).
    bidirectional : separate forward and backward tables (the source must have both
        directions; the control must take them).
    sign : ``correction`` or ``error`` where the control's convention is not confirmed
        (the format's record says none); elsewhere None or the control's own.
    comp_type : LinuxCNC COMP_FILE_TYPE, 0 or 1.
    points : points of the grid including both ends (None: chosen).
    max_entries : points the control is configured for (None: the documented default).
    axis : the axis as the file names it (checked by the format's record).
    detection_unit_deg : an incremental table's detection unit of the axis [deg].
    home_point : an incremental table's compensation point number of the home
        (reference) position.
    increment_system : an incremental table's increment system by its control's name
        (Fanuc: IS-A, IS-B, IS-C), which sets ``detection_unit_deg`` (None: that unit as
        given).
    tnc : a HEIDENHAIN control's generation, whose rules the table follows (``407``: TNC
        407/415/425; ``620``: MANUALplus 620 and its generation), by its record's check.
    backlash : write the step run's mean reversal value as the control's backlash
        parameter (where its record's control keeps one), with the table of the positive
        direction (the reference position return's) instead of the mean of both.
    """

    target: str
    bidirectional: bool = False
    sign: str | None = None
    comp_type: int = 0
    points: int | None = None
    max_entries: int | None = None
    axis: str | None = None
    detection_unit_deg: float = DEFAULT_DETECTION_UNIT_DEG
    home_point: int = 0
    increment_system: str | None = None
    tnc: str | None = None
    backlash: bool = False

    def __post_init__(self) -> None:
        fmt, spec = self.format, self.spec
        self._increment_system()
        self._check_backlash()
        if self.bidirectional and not spec.bidirectional:
            msg = f"{self.target}: `bidirectional`: {spec.no_bidirectional}"
            raise SettingsError(msg)
        if fmt.sign is None and self.sign is None:
            msg = (f"{self.target}: the sign of a stored value (correction added, or error "
                   "measured) is not confirmed from the control's documentation; give "
                   "`sign` correction or `sign` error as your control's manual says")
            raise SettingsError(msg)
        if fmt.sign is not None and self.sign is not None:
            unsure = ", ".join(r.name for r in registry.records(registry.CONTROL)
                               if r.sign is None).rsplit(", ", 1)
            msg = (f"`sign` applies to the {' and '.join(unsure)} targets, not {self.target} "
                   "(whose convention is documented)")
            raise SettingsError(msg)
        self._check_ranges()
        if fmt.check is not None:
            fmt.check(self, None)
        if self.points is not None:  # before any work
            why = self.allows(self.points - 1) if self.points >= 3 else "fewer than 3"
            if why:
                msg = f"`points` {self.points}: {self.target}: {why}"
                raise SettingsError(msg)

    def _increment_system(self) -> None:
        """The detection unit of the increment system named, if one is: refused for a
        control that names none, a name it does not have, or a different unit given."""
        if self.increment_system is None:
            return
        systems = dict(self.spec.increment_systems)
        if not systems:
            takes = [r.name for r in registry.records(registry.CONTROL)
                     if r.control is not None and r.control.increment_systems]
            msg = f"`increment_system` applies to {', '.join(takes)}, not {self.target}"
            raise SettingsError(msg)
        if self.increment_system not in systems:
            msg = (f"`increment_system` must be one of {', '.join(systems)} for {self.target}, "
                   f"not {self.increment_system!r}")
            raise SettingsError(msg)
        unit = systems[self.increment_system]
        given = self.detection_unit_deg
        if given != DEFAULT_DETECTION_UNIT_DEG and abs(given - unit) > 1e-12 * unit:
            msg = (f"`increment_system` {self.increment_system} has a detection unit of "
                   f"{unit!r} deg, not the `detection_unit_deg` {given!r} given")
            raise SettingsError(msg)
        object.__setattr__(self, "detection_unit_deg", unit)  # frozen: set once, here

    def _check_backlash(self) -> None:
        """Refuse a backlash value for a control that does not keep one apart from its
        table (its record says why), or beside a table per direction."""
        if not self.backlash:
            return
        if self.spec.backlash_range is None:
            msg = f"`backlash`: {self.target}: {self.spec.no_backlash}"
            raise SettingsError(msg)
        if self.bidirectional:
            msg = ("give `backlash` or `bidirectional`, not both (a table per direction "
                   "holds the reversal already)")
            raise SettingsError(msg)

    @property
    def backlash_unit_deg(self) -> float:
        """The step of a backlash value [deg]: an incremental table's detection unit, else
        the control's resolution."""
        return self.detection_unit_deg if self.spec.incremental else self.spec.resolution_deg

    def _check_ranges(self) -> None:
        if self.comp_type not in (0, 1):
            msg = f"`comp_type` must be 0 or 1, not {self.comp_type}"
            raise SettingsError(msg)
        if not (0 < self.detection_unit_deg <= 1 and np.isfinite(self.detection_unit_deg)):
            msg = f"`detection_unit_deg` must be in (0, 1] deg, not {self.detection_unit_deg}"
            raise SettingsError(msg)
        if self.max_entries is not None and not 3 <= self.max_entries <= 1 << 28:
            msg = f"`max_entries` must be 3..{1 << 28}, not {self.max_entries}"
            raise SettingsError(msg)

    @property
    def format(self) -> TableFormat:
        """The format's record."""
        fmt = registry.get(self.target)
        if fmt.control is None:
            msg = f"{self.target} is not a control's table (`target`)"
            raise SettingsError(msg)
        return fmt

    @property
    def spec(self) -> Control:
        control = self.format.control
        assert control is not None  # checked by format
        return control

    @property
    def stored_sign(self) -> float:
        """+1 if a stored value is the correction, -1 if it is minus the correction."""
        sign = self.sign if self.format.sign is None else self.format.sign
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
        rule = self.spec.grid_rule
        return None if rule is None else rule(self, sections)


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
    #: the backlash value written [steps of ``settings.backlash_unit_deg``], or None
    backlash: int | None = None
    #: the reversal value it stands for, before rounding [rad]
    intended_backlash_rad: float | None = None

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
    if (settings.bidirectional or settings.backlash) and source.backward is None:
        what = "bidirectional" if settings.bidirectional else "backlash"
        msg = (f"`{what}` needs a step run with both directions "
               "(a points stream with direction +1 and -1)")
        raise DataError(msg)
    k = choose_sections(settings, source)
    grid = np.arange(k + 1) * (360.0 / k)
    grid[-1] = 360.0
    fwd = -np.asarray(source.forward(grid), dtype=np.float64)  # correction [arcsec]
    bwd = None if source.backward is None else -np.asarray(source.backward(grid), np.float64)
    if settings.backlash:  # the positive direction's table, the reversal apart
        bwd = None
    elif not settings.bidirectional and bwd is not None:
        fwd, bwd = (fwd + bwd) / 2.0, None  # the mean bidirectional deviation
    if not np.all(np.isfinite(fwd)) or (bwd is not None and not np.all(np.isfinite(bwd))):
        msg = "the source gives NaN or infinite deviations"
        raise DataError(msg)
    offset = 0.0
    if settings.spec.incremental:  # the compensation is 0 at the home position
        offset = float(fwd[0])
        fwd = fwd - offset
    table = _quantise(settings, grid, fwd, bwd)
    if settings.backlash:
        _backlash(table, source)
    table.summary = _summary(table, source, fwd, bwd, offset)
    return table


def _backlash(table: ControlTable, source: Source) -> None:
    """The step run's mean reversal mean(B_i) in the deviation's sign (mean up - mean
    down of the deviation, indicated - true: ISO 230-2's B_mean negated) as the control's
    backlash value: B is what the control adds to the positive
    direction's correction when it moves the other way [steps of the backlash unit];
    DataError (one line) beyond the control's range."""
    s = table.settings
    assert source.reversal_arcsec is not None and s.spec.backlash_range is not None
    b_arcsec = float(np.mean(source.reversal_arcsec))
    unit = s.backlash_unit_deg
    steps = int(np.rint(b_arcsec / (unit * ARCSEC_PER_DEG)))
    lo, hi = s.spec.backlash_range
    if not lo <= steps <= hi:
        msg = (f"{s.target}: a backlash of {steps} x {unit!r} deg ({b_arcsec:.4g} arcsec) is "
               f"beyond the control's range {lo}..{hi}")
        raise DataError(msg)
    table.backlash = steps
    table.intended_backlash_rad = b_arcsec * factor("arcsec", "rad")


def _quantise(settings: ControlSettings, grid: np.ndarray, fwd: np.ndarray,
              bwd: np.ndarray | None) -> ControlTable:
    """Stored values of intended corrections [arcsec] at the control's resolution."""
    spec = settings.spec
    sign = settings.stored_sign
    magnification = 1
    resolution = spec.resolution_deg
    if spec.incremental:
        magnification, resolution = _magnification(settings, fwd)
    step_arcsec = resolution * ARCSEC_PER_DEG

    def stored(corr: np.ndarray) -> np.ndarray:
        q = np.rint(sign * corr / step_arcsec)
        values = np.diff(q) if spec.incremental else q
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


def _magnification(settings: ControlSettings, fwd: np.ndarray) -> tuple[int, float]:
    """The smallest magnification (Fanuc: parameter 3623) whose increments fit the
    control's range, and the resolution [deg] it gives (magnification x detection unit)."""
    du = settings.detection_unit_deg
    top = (settings.spec.value_range or (-1, 1))[1]
    for mag in range(1, MAX_MAGNIFICATION + 1):
        q = np.rint(settings.stored_sign * fwd / (mag * du * ARCSEC_PER_DEG))
        if np.abs(np.diff(q)).max(initial=0) <= top:
            return mag, mag * du
    msg = (f"{settings.target}: the correction changes by more than {top} x "
           f"{MAX_MAGNIFICATION} x {du!r} deg between points; use more `points`")
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
    elif t.backlash is not None:  # backward: the positive table and the backlash value
        lash = t.backlash * t.settings.backlash_unit_deg * ARCSEC_PER_DEG
        pairs = [(dev_f, fwd), (source.backward(check), fwd + lash)]
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
    if t.settings.spec.incremental:
        out |= {"magnification": t.magnification, "offset_removed_arcsec": offset,
                "detection_unit_deg": t.settings.detection_unit_deg}
        if t.settings.increment_system is not None:
            out["increment_system"] = t.settings.increment_system
    if source.reversal_arcsec is not None:
        b = source.reversal_arcsec
        # printed in ISO 230-2's sign: its x = actual - target is -deviation, so its
        # B_mean = mean(x up - x down) = -mean(b); the backlash datum keeps the deviation's
        out |= {"reversal_max_arcsec": float(np.max(np.abs(b))),
                "reversal_mean_arcsec": -float(np.mean(b))}
    if t.backlash is not None:
        unit = t.settings.backlash_unit_deg
        out |= {"direction": "positive, backlash apart", "backlash_steps": t.backlash,
                "backlash_unit_deg": unit,
                "backlash_arcsec": t.backlash * unit * ARCSEC_PER_DEG}
    # no figure is -0.0 (printed "-0"): a correction of 0 at the home position negated
    return {k: v + 0.0 if isinstance(v, float) else v for k, v in out.items()}
