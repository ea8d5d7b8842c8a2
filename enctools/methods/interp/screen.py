"""Faults of a head's raw quadrature signals, found before the Heydemann fit (signals mode).

Three faults make an ellipse fit of sampled (I, Q) [V] wrong without the fit saying so:

- clipping: samples on the rails of the ADC (or of an amplifier before it) lie on the
  flat tops of a clipped sine, inside the ellipse; 43 % of them pull the fitted offsets
  and ratio far off while the fit's residual stays small;
- radius outliers: spikes (a dropped bit, a glitch, dirt on the scale) whose Lissajous
  radius, the fitted faults removed, is far from the amplitude;
- a missing quadrant: the phase does not go round the circle (a gap of more than a
  quarter of it), and the ellipse through the rest is ill-conditioned.

:func:`screened_fit` finds the clipped samples (against the rails a signal column
declares, ``rail_low_v``/``rail_high_v`` field metadata, or ``rails_v``; else the
extreme value of a channel held by samples spread over an arc of the phase: a flat
top), fits the ellipse to the others, drops the radius outliers and fits again until
they no longer change, and refuses (DataError) when more than ``allow_excluded_pct`` of
the samples are left out or the samples kept leave a quadrant of the phase empty.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from statistics import NormalDist
from typing import TYPE_CHECKING, Any

import numpy as np

from enctools.errors import DataError
from enctools.units import DEG, TWO_PI

if TYPE_CHECKING:
    from enctools.methods.heydemann import EllipseFit

#: declared rails: a sample within this fraction of the span between the rails of one
#: of them is on it (clipped)
RAIL_MARGIN = 0.002
#: undeclared rails: the samples holding a channel's extreme value form a flat top when
#: they spread over more than this arc of the phase [deg] ...
FLAT_TOP_DEG = 1.0
#: ... are at least this many ...
FLAT_TOP_SAMPLES = 5
#: ... and at least this fraction of the samples
FLAT_TOP_FRACTION = 0.002
#: radius outliers: a normalised radius further from the median than this many robust
#: standard deviations (1.4826 MAD), or than a Gaussian sample of that size exceeds by
#: chance in :data:`RADIUS_CHANCE` of records (more for a long record) ...
RADIUS_SIGMAS = 5.0
RADIUS_CHANCE = 0.01
#: ... and further than this fraction of the amplitude
RADIUS_FLOOR = 0.01
#: the fit is refused when more than this share [%] of the samples is excluded (--allow-excluded)
ALLOW_EXCLUDED_PCT = 20.0
#: the fit is refused when the samples kept cover less of the phase [deg] (--min-arc): a
#: gap of more than a quarter of the circle is a missing quadrant
MIN_ARC_DEG = 270.0
#: the shortest arc [deg] --min-arc may accept
LEAST_ARC_DEG = 10.0
#: fits at most, dropping the radius outliers of the previous one
OUTLIER_PASSES = 6


@dataclass(frozen=True)
class Screen:
    """What the screening found in the finite samples of one head.

    ``clipped`` and ``outliers``: one flag per finite sample; ``channels``: per signal
    channel its rails (``low_v``, ``high_v`` [V], None when none was found), where they
    came from (``declared``, ``option``, ``detected`` or ``none``) and its samples on
    them; ``arc``: the part of the phase [rad] the samples kept cover.
    """

    clipped: np.ndarray
    outliers: np.ndarray
    channels: dict[str, dict[str, Any]]
    arc: float

    @property
    def kept(self) -> np.ndarray:
        """Flags of the samples the fit uses."""
        return ~(self.clipped | self.outliers)

    def faults(self) -> list[str]:
        """The faults found, named: clipping, radius outliers, missing quadrant."""
        out = []
        if self.clipped.any():
            out.append("clipping")
        if self.outliers.any():
            out.append("radius outliers")
        if self.arc < MIN_ARC_DEG * DEG:
            out.append("missing quadrant")
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-able: counts, shares [%] of the finite samples, rails, arc [deg]."""
        n = max(self.clipped.size, 1)
        return {"faults": self.faults(), "n_samples": int(self.clipped.size),
                "n_fitted": int(self.kept.sum()),
                "clipped_percent": 100.0 * float(self.clipped.sum()) / n,
                "outliers_percent": 100.0 * float(self.outliers.sum()) / n,
                "excluded_percent": 100.0 * float((~self.kept).sum()) / n,
                "arc_deg": self.arc / DEG, "channels": self.channels}


def describe(screen: Mapping[str, Any]) -> str | None:
    """One sentence naming the faults of a screen's :meth:`Screen.to_dict`; None without any."""
    if not screen.get("faults"):
        return None
    parts = []
    if screen["clipped_percent"]:
        rails = sorted({c["rails"] for c in screen["channels"].values() if c["clipped"]})
        parts.append(f"{screen['clipped_percent']:.1f} % of the samples clipped at the "
                     f"rails ({', '.join(rails)})")
    if screen["outliers_percent"]:
        parts.append(f"{screen['outliers_percent']:.1f} % radius outliers")
    text = " and ".join(parts)
    if text:
        text += (f", excluded from the ellipse fit ({screen['n_fitted']} of "
                 f"{screen['n_samples']} samples fitted)")
    if "missing quadrant" in screen["faults"]:
        gap = f"a missing quadrant: the samples cover {screen['arc_deg']:.0f} deg of the phase"
        text = f"{text}; {gap}" if text else gap
    return text


def screen_notes(signals: Mapping[str, Any] | None) -> list[str]:
    """The faults of each head's signals in an interp-check output's ``signals`` metadata."""
    out = []
    for head, meta in (signals or {}).items():
        said = describe(meta.get("screen") or {}) if isinstance(meta, Mapping) else None
        if said:
            out.append(f"{head}: signal faults: {said}")
    return out


def screened_fit(channels: Mapping[str, np.ndarray], i: np.ndarray, q: np.ndarray,
                 rails: Mapping[str, tuple[tuple[float, float], str]],
                 min_arc_deg: float = MIN_ARC_DEG,
                 allow_excluded_pct: float = ALLOW_EXCLUDED_PCT) -> tuple[EllipseFit, Screen]:
    """The Heydemann fit of I, Q [V] without the clipped samples and the radius outliers.

    ``channels``: the raw signal channels [V] (cos and sin, or the four phases) from
    which I and Q come, one value per sample; ``rails``: per channel its (low, high)
    rails [V] and where they come from, when known. Non-finite samples are left out
    first. Raises DataError when more than ``allow_excluded_pct`` [%] of the finite
    samples are clipped or outliers, or when those kept cover less than
    ``min_arc_deg`` [deg] of the phase.
    """
    from enctools.methods import heydemann as hd  # scipy only when fitting

    hd.finite_signals(i, q)  # lengths, sizes and enough finite samples, checked once
    i, q = np.asarray(i, np.float64), np.asarray(q, np.float64)
    finite = np.isfinite(i) & np.isfinite(q)
    i, q = i[finite], q[finite]
    raw = {k: np.asarray(v, np.float64)[finite] for k, v in channels.items()}
    for name, x in raw.items():
        if np.ptp(x) == 0:
            msg = f"signal {name} is constant at {x[0]:.6g} V: the head gives no signal"
            raise DataError(msg)
    clipped, found = clipped_samples(raw, range_phase(i, q), rails)
    outliers = np.zeros_like(clipped)
    _check_excluded(clipped, outliers, allow_excluded_pct)
    fit = _fit_kept(i, q, clipped, min_arc_deg)
    for _ in range(OUTLIER_PASSES):
        new = radius_outliers(fit, i, q) & ~clipped
        if np.array_equal(new, outliers):
            break
        outliers = new
        _check_excluded(clipped, outliers, allow_excluded_pct)
        fit = _fit_kept(i, q, clipped | outliers, min_arc_deg)
    screen = Screen(clipped, outliers, found, fit.arc)
    said = describe(screen.to_dict())
    if said:
        fit.warnings.insert(0, said)
    return fit, screen


def _fit_kept(i: np.ndarray, q: np.ndarray, excluded: np.ndarray,
              min_arc_deg: float) -> EllipseFit:
    """The ellipse fit of the samples not ``excluded``; DataError for a missing quadrant.

    The arc is judged from the circle through the samples before the fit (a short arc
    can send the fit off) and along the fitted ellipse after it (its ``arc``).
    """
    from enctools.methods import heydemann as hd

    ik, qk = i[~excluded], q[~excluded]
    if ik.size < 8:  # the fit's own line says so
        return hd.fit_ellipse(ik, qk)
    arc = hd.circle_arc(ik, qk)
    if arc >= min_arc_deg * DEG:
        fit = hd.fit_ellipse(ik, qk, min_arc=LEAST_ARC_DEG * DEG)
        if fit.arc >= min_arc_deg * DEG:
            return fit
        arc = fit.arc
    lost = f" ({int(excluded.sum())} clipped or outliers left out)" if excluded.any() else ""
    msg = (f"a missing quadrant: the samples{lost} cover {arc / DEG:.0f} deg of the "
           f"signal phase (`min_arc_deg` {min_arc_deg:g} deg), too little for a "
           f"well-conditioned ellipse fit; record over a whole signal period, or "
           f"accept the partial arc with a smaller `min_arc_deg` (at least {LEAST_ARC_DEG:g})")
    raise DataError(msg)


def _check_excluded(clipped: np.ndarray, outliers: np.ndarray, max_pct: float) -> None:
    """DataError when the clipped samples and the outliers exceed ``max_pct`` [%]."""
    n = max(clipped.size, 1)
    pct = 100.0 * float((clipped | outliers).sum()) / n
    if pct > max_pct:
        msg = (f"{pct:.1f} % of the samples would be excluded from the ellipse fit "
               f"({100.0 * clipped.sum() / n:.1f} % clipped at the rails, "
               f"{100.0 * outliers.sum() / n:.1f} % radius outliers), over `allow_excluded_pct` "
               f"{max_pct:g} %: what is left does not determine the signals' faults; lower "
               f"the gain before the ADC or clean the scale, or raise `allow_excluded_pct`")
        raise DataError(msg)


def range_phase(i: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Signal phase [rad] of each sample about the middle of the ranges of I and Q [V],
    each scaled by its half range: rough, but blind to how the channels are clipped."""
    def scaled(x: np.ndarray) -> np.ndarray:
        lo, hi = float(np.min(x, initial=0.0)), float(np.max(x, initial=0.0))
        half = (hi - lo) / 2.0 or 1.0
        return (x - (hi + lo) / 2.0) / half

    return np.arctan2(scaled(q), scaled(i))


def clipped_samples(channels: Mapping[str, np.ndarray], phase: np.ndarray,
                    rails: Mapping[str, tuple[tuple[float, float], str]]
                    ) -> tuple[np.ndarray, dict[str, dict[str, Any]]]:
    """Flags of the samples with any channel [V] on its rails, and per channel what was found.

    A channel with ``rails`` (low, high) [V] is clipped within :data:`RAIL_MARGIN` of
    the span between them; one without has its rails detected by :func:`flat_tops`
    at the signal ``phase`` [rad] of each sample.
    """
    clipped = np.zeros(phase.shape, dtype=bool)
    found: dict[str, dict[str, Any]] = {}
    for name, x in channels.items():
        low: float | None
        high: float | None
        if name in rails:
            (lo, hi), source = rails[name]
            margin = RAIL_MARGIN * (hi - lo)
            on = (x >= hi - margin) | (x <= lo + margin)
            low, high = lo, hi
        else:
            on, low, high = flat_tops(x, phase)
            source = "detected" if on.any() else "none"
        clipped |= on
        found[name] = {"low_v": low, "high_v": high, "rails": source, "clipped": int(on.sum())}
    return clipped, found


def flat_tops(x: np.ndarray, phase: np.ndarray) -> tuple[np.ndarray, float | None, float | None]:
    """Samples of a channel [V] on a flat top at its highest or lowest value, and those values.

    A flat top: the extreme value (to 1e-9 of the channel's range) held by at least
    :data:`FLAT_TOP_SAMPLES` samples and :data:`FLAT_TOP_FRACTION` of them, whose
    ``phase`` [rad] spreads over more than :data:`FLAT_TOP_DEG` and more than twice
    the arc the top code of an unclipped sine quantised as ``x`` is would hold.
    Repeated readings at one position share their phase and make no flat top.
    """
    flags = np.zeros(x.shape, dtype=bool)
    if x.size < FLAT_TOP_SAMPLES:
        return flags, None, None
    lo, hi = float(x.min()), float(x.max())
    tol = 1e-9 * (hi - lo)
    step = _quantum(x, tol)
    half = (hi - lo) / 2.0
    top_code = 2.0 * math.acos(max(1.0 - step / half, -1.0)) if half > 0 else 0.0
    least_arc = max(FLAT_TOP_DEG * DEG, 2.0 * top_code)
    least = max(FLAT_TOP_SAMPLES, FLAT_TOP_FRACTION * x.size)
    ends: list[float | None] = []
    for extreme in (lo, hi):
        at = np.abs(x - extreme) <= tol
        flat = at.sum() >= least and _spread(phase[at]) > least_arc
        if flat:
            flags |= at
        ends.append(extreme if flat else None)
    return flags, ends[0], ends[1]


def _spread(phase: np.ndarray) -> float:
    """The arc [rad] a cluster of phases spans: 2 pi minus the largest gap between them."""
    p = np.sort(np.mod(phase, TWO_PI))
    if p.size < 2:
        return 0.0
    return float(TWO_PI - np.diff(np.append(p, p[0] + TWO_PI)).max())


def _quantum(x: np.ndarray, tol: float) -> float:
    """The step [V] of the grid the distinct values of ``x`` lie on (an ADC's LSB); 0 when
    they lie on none (values computed, or not quantised)."""
    u = np.unique(x)
    d = np.diff(u)
    d = d[d > tol]
    if d.size < 2:
        return 0.0
    step = float(d.min())
    ratio = d / step
    return step if np.all(np.abs(ratio - np.rint(ratio)) < 1e-3) else 0.0


def radius_outliers(fit: EllipseFit, i: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Flags of the samples whose normalised Lissajous radius is an outlier.

    The radius of (I, Q) [V] with the fitted faults removed is 1 for a sample on the
    ellipse; an outlier lies further from the median radius than :data:`RADIUS_SIGMAS`
    robust standard deviations (1.4826 times the median absolute deviation), or than
    the Gaussian noise of as many samples exceeds once in 1 / :data:`RADIUS_CHANCE`
    records, and than :data:`RADIUS_FLOOR` (a fraction of the amplitude).
    """
    u = (i - fit.offset_cos) / fit.amplitude
    w = (q - fit.offset_sin) / (fit.amplitude * fit.ratio)
    v = (w - u * math.sin(fit.phase)) / math.cos(fit.phase)
    rho = np.hypot(u, v)
    med = float(np.median(rho))
    mad = 1.4826 * float(np.median(np.abs(rho - med)))
    sigmas = max(RADIUS_SIGMAS, NormalDist().inv_cdf(1.0 - RADIUS_CHANCE / (2 * max(rho.size, 1))))
    return np.abs(rho - med) > max(sigmas * mad, RADIUS_FLOOR)
