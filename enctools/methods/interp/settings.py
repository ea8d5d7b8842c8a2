"""What an interpolation check does (enc interp-check), resolved and checked in one place."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from enctools.errors import SettingsError
from enctools.methods.interp.screen import ALLOW_EXCLUDED_PCT, MIN_ARC_DEG

#: default window of a continuous run [arcsec]: a line per 0.5 deg leaves of the
#: graduation error of sjtu-dual (harmonics up to 180 per turn) 0.004" rms
DEFAULT_WINDOW_ARCSEC = 1800.0
#: the highest harmonic of a signal period a check fits or keeps: an interpolation error
#: lives in the first few; 2 K parameters per window are solved by normal equations
MAX_HARMONICS = 64
#: ``window_arcsec`` [arcsec]: at least one arcsec, at most a turn
WINDOW_ARCSEC = (1.0, 1_296_000.0)
#: ``arm_m`` [m]
ARM_M = (1e-6, 10.0)


def _names(value: Sequence[Any] | None) -> tuple[Any, ...] | None:
    return None if value is None else tuple(value)


@dataclass(frozen=True)
class Settings:
    """The options of an interpolation check (units in the names).

    Reference mode (seed 000 sec. 4): ``heads`` checked (None: every head but the
    reference), one by one or with ``average`` as one device; ``reference``
    "probes" (``probes``, default every probe, on arms ``arm_m`` [m], default each
    probe's) or a head, from ``reference_file`` matched by time when given;
    ``harmonics`` 1..K of the device's period fitted (None: 4, or against an encoder
    of another period the highest kept), ``keep`` those reported (None: all, or 1
    and 2 against another period), ``reference_harmonics`` 1..J of the reference
    encoder's own period fitted alongside; a polynomial of ``trend_degree`` per run,
    or per ``window_arcsec`` [arcsec] of angle (default for a continuous run:
    :data:`DEFAULT_WINDOW_ARCSEC`). Signals mode (``signals``): the Heydemann fit of
    each head's raw signals over at least ``min_arc_deg`` [deg] of the phase, refused
    when more than ``allow_excluded_pct`` [%] of the samples are clipped (on the rails
    ``rails_v`` (low, high) [V] when given) or radius outliers; with ``corrected`` the
    readings re-interpolated from the corrected phase. ``points``: the output curve's
    points per signal period.

    Raises SettingsError, naming the fields, for a combination no check can carry out.
    """

    heads: Sequence[str] | None = None
    average: bool = False
    reference: str = "probes"
    reference_file: str | None = None
    probes: Sequence[str] | None = None
    arm_m: float | None = None
    harmonics: int | None = None
    keep: Sequence[int] | None = None
    reference_harmonics: int = 2
    trend_degree: int = 1
    window_arcsec: float | None = None
    points: int = 256
    signals: bool = False
    min_arc_deg: float = MIN_ARC_DEG
    allow_excluded_pct: float = ALLOW_EXCLUDED_PCT
    rails_v: tuple[float, ...] | None = None
    corrected: bool = False

    def __post_init__(self) -> None:
        # the lists a command line gives, as tuples: the settings do not change
        for name in ("heads", "probes", "keep"):
            object.__setattr__(self, name, _names(getattr(self, name)))
        self.check()

    def check(self) -> None:
        """SettingsError naming the fields when the settings cannot go together."""
        if self.arm_m is not None and not ARM_M[0] <= self.arm_m <= ARM_M[1]:
            msg = f"`arm_m` must be 1e-06..10 m (psi = h / L), not {self.arm_m!r}"
            raise SettingsError(msg)
        self._check_sizes()
        if self.corrected and not self.signals:
            msg = "`corrected` needs `signals`"
            raise SettingsError(msg)
        if self.signals and self.average:
            msg = "`average` does not apply to `signals` (each head has its signals)"
            raise SettingsError(msg)
        if self.signals and self.window_arcsec is not None:
            msg = "`window_arcsec` applies to the reference mode, not `signals`"
            raise SettingsError(msg)
        self._check_signal_limits()

    def _check_signal_limits(self) -> None:
        """``rails_v`` (with ``signals``, low below high) and ``allow_excluded_pct`` (0..100 %)."""
        if self.rails_v is not None:
            object.__setattr__(self, "rails_v", tuple(float(v) for v in self.rails_v))
            if not self.signals:
                msg = "`rails_v` needs `signals`"
                raise SettingsError(msg)
            if not (len(self.rails_v) == 2 and all(map(math.isfinite, self.rails_v))
                    and self.rails_v[0] < self.rails_v[1]):
                msg = f"`rails_v` must be LOW,HIGH [V] with LOW < HIGH, not {self.rails_v!r}"
                raise SettingsError(msg)
        if not 0.0 <= self.allow_excluded_pct <= 100.0:  # also NaN
            msg = f"`allow_excluded_pct` must be 0..100 %, not {self.allow_excluded_pct!r}"
            raise SettingsError(msg)

    def _check_sizes(self) -> None:
        """The orders fitted and kept against MAX_HARMONICS and the output's ``points``."""
        most = min(MAX_HARMONICS, self.points // 2)
        if self.harmonics is not None and not 1 <= self.harmonics <= most:
            msg = (f"`harmonics` must be 1..{most} (at most {MAX_HARMONICS}, and half of "
                   f"`points` {self.points}), not {self.harmonics}")
            raise SettingsError(msg)
        if self.keep is not None and not all(1 <= k <= most for k in self.keep):
            msg = (f"`keep`: harmonic orders must be 1..{most} (at most {MAX_HARMONICS}, and "
                   f"half of `points` {self.points}), not {max(self.keep)}")
            raise SettingsError(msg)
        if not 10.0 <= self.min_arc_deg <= 360.0:  # also NaN, which click's range lets by
            msg = f"`min_arc_deg` must be 10..360 deg, not {self.min_arc_deg!r}"
            raise SettingsError(msg)
        lo, hi = WINDOW_ARCSEC
        if self.window_arcsec is not None and not lo <= self.window_arcsec <= hi:
            msg = f"`window_arcsec` must be 1..1296000 arcsec, not {self.window_arcsec!r}"
            raise SettingsError(msg)

    def trend_window_arcsec(self, continuous: bool) -> float | None:
        """The span of angle [arcsec] with its own trend; None: one trend per run.

        ``continuous``: the input is a continuous run (its header's mode), which has
        windows of :data:`DEFAULT_WINDOW_ARCSEC` unless ``window_arcsec`` says.
        """
        if self.window_arcsec is not None:
            return self.window_arcsec
        return DEFAULT_WINDOW_ARCSEC if continuous else None

    def to_meta(self, continuous: bool) -> dict[str, Any]:
        """The effective settings as the output's metadata records them."""
        out: dict[str, Any] = {
            "heads": _list(self.heads), "average": self.average, "harmonics": self.harmonics,
            "points": self.points, "trend": self.trend_degree}
        if self.signals:
            return out | {"mode": "signals", "min_arc_deg": self.min_arc_deg,
                          "allow_excluded_pct": self.allow_excluded_pct,
                          "rails_v": _list(self.rails_v)}
        return out | {"mode": "reference", "window_arcsec": self.trend_window_arcsec(continuous),
                      "reference": self.reference, "reference_file": self.reference_file,
                      "probes": _list(self.probes), "arm_m": self.arm_m, "keep": _list(self.keep),
                      "reference_harmonics": self.reference_harmonics}


def _list(value: Sequence[Any] | None) -> list[Any] | None:
    return None if value is None else list(value)
