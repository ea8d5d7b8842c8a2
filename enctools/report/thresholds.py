"""Thresholds for cron: a check per field of :class:`Thresholds`; exceeding any is exit
status 1.

Each check names the figure, the curve and the input at fault, and the threshold by its
field between backticks, e.g.
``p-p of deviation in before.parquet is 5.46 arcsec > `max_pp` 3``, which
:func:`in_words` renders with the caller's words for it (a command: its option).
Figures in arcsec apply to deviation, points and positioning curves; radial
motion [nm] has its own threshold; ROM corrections [count] and model curves (a fit,
not a measurement) are not checked.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from enctools.data.statistics import Figures
from enctools.errors import CheckFailed, SettingsError
from enctools.report.vdi3441 import AXIS_FIGURES

if TYPE_CHECKING:  # a report's sections load its inputs' rigs: not needed by enc correct
    from enctools.report.summary import Report

ISO_FIGURES = ("A", "R", "E", "B", "M", "A_up", "A_down", "R_up", "R_down", "E_up", "E_down")
#: the figures of each standard a threshold may name, by field
FIGURES = {"max_iso": ("ISO 230-2", ISO_FIGURES), "max_vdi": ("VDI/DGQ 3441", AXIS_FIGURES)}


@dataclass
class Thresholds:
    """Limits to check (None: not checked). Units: arcsec, nm."""

    max_pp: float | None = None
    max_std: float | None = None
    max_abs: float | None = None
    max_u: float | None = None
    max_radial_pp: float | None = None
    max_harmonic: dict[int, float] = field(default_factory=dict)
    max_iso: dict[str, float] = field(default_factory=dict)
    max_vdi: dict[str, float] = field(default_factory=dict)

    @property
    def any(self) -> bool:
        return any(v is not None for v in (self.max_pp, self.max_std, self.max_abs,
                                           self.max_u, self.max_radial_pp)) \
            or bool(self.max_harmonic) or bool(self.max_iso) or bool(self.max_vdi)

    def to_dict(self) -> dict[str, object]:
        return {k: v for k, v in self.__dict__.items() if v not in (None, {}, [])}


def parse_pairs(values: tuple[str, ...], name: str, key_type: type) -> dict:
    """``N:VALUE`` pairs of the threshold ``name`` (a field: ``max_harmonic``), given
    several times -> {key: value}; SettingsError naming the field otherwise."""
    option = f"`{name}`"
    out = {}
    for v in values:
        key, sep, limit = v.partition(":")
        try:
            k = key_type(key.strip())
            lim = float(limit)
        except ValueError:
            k, lim = None, math.nan
        if not sep or k is None or not math.isfinite(lim) or lim < 0:
            msg = f"{option} wants KEY:VALUE with VALUE >= 0 (e.g. {option} 2:0.5), not {v!r}"
            raise SettingsError(msg)
        if key_type is str and k not in FIGURES[name][1]:
            standard, known = FIGURES[name]
            msg = f"{option}: unknown {standard} figure {k!r} (figures: {', '.join(known)})"
            raise SettingsError(msg)
        if key_type is int and k < 1:
            msg = f"{option}: harmonic order must be >= 1, not {k}"
            raise SettingsError(msg)
        out[k] = lim
    return out


def _arcsec_curves(report: Report):
    for s, c in report.curves("arcsec"):
        if c.role != "model":
            yield s, c


def exceeded(value: float | None, limit: float | None, what: str, where: str, name: str,
             unit: str = "arcsec") -> list[str]:
    """The line naming a figure over its limit (``value > limit``), or none; ``name``: the
    threshold's field, and the key of a pair threshold (``max_harmonic 2:``)."""
    if limit is None or value is None or not value > limit:
        return []
    field, _, key = name.partition(" ")
    return [f"{what} of {where} is {value:.4g} {unit} > `{field}` {key}{limit:g}"]


def in_words(lines: Sequence[str], words: Callable[[str], str] | None) -> list[str]:
    """Lines of :func:`check` with each threshold's field named by ``words(field)``
    (None: the field itself)."""
    return [CheckFailed(line).render(words or (lambda field: field)) for line in lines]


def figure_limits(f: Figures, limits: Thresholds, where: str) -> list[str]:
    """max_pp, max_std and max_abs over the figures [arcsec] of one set of values."""
    return (exceeded(f.pp, limits.max_pp, "p-p", where, "max_pp")
            + exceeded(f.std, limits.max_std, "s (Bessel)", where, "max_std")
            + exceeded(f.max_abs, limits.max_abs, "max |deviation|", where, "max_abs"))


def check(report: Report, limits: Thresholds) -> list[str]:
    """Every threshold exceeded, one line each (empty: all within limits)."""
    bad: list[str] = []

    def over(value: float | None, limit: float | None, what: str, where: str, option: str,
             unit: str = "arcsec") -> None:
        bad.extend(exceeded(value, limit, what, where, option, unit))

    for s, c in _arcsec_curves(report):
        where = f"{c.name} in {s.source}"
        bad.extend(figure_limits(c.figures, limits, where))
        over(c.U_max, limits.max_u, f"U (k={c.k:.3g})", where, "max_u")
        if limits.max_u is not None and c.U_max is None:  # a limit no figure can show met
            bad.append(f"{where} states no U (no u and no budget, or a budget lacking a "
                       f"declaration): `max_u` {limits.max_u:g} cannot be checked")
    for s, c in report.curves("nm"):
        over(c.figures.pp, limits.max_radial_pp, "p-p", f"{c.name} in {s.source}",
             "max_radial_pp", "nm")
    if limits.max_harmonic:
        for s, c in _arcsec_curves(report):
            h = c.harmonics
            if h is None:
                continue
            for n, lim in sorted(limits.max_harmonic.items()):
                over(h.amplitude_of(n), lim, f"harmonic {n}", f"{c.name} in {s.source}",
                     f"max_harmonic {n}:")
        for s in report.sections:
            for sp in s.spectra:
                for n, lim in sorted(limits.max_harmonic.items()):
                    hit = np.flatnonzero(sp.n == n)
                    if hit.size:
                        over(float(sp.amplitude[hit[0]]), lim, f"harmonic {n}",
                             f"{sp.curve} in {s.source}", f"max_harmonic {n}:")
    return bad + positioning_limits(report, limits)


def positioning_limits(report: Report, limits: Thresholds) -> list[str]:
    """max_iso and max_vdi over the ISO 230-2 / VDI 3441 axis figures [arcsec]; a linear
    axis's figures are um, against which an arcsec limit is one line, never a check."""
    bad: list[str] = []
    for s in report.sections:
        if s.info.get("axis") == "linear":
            if limits.max_iso or limits.max_vdi:
                bad.append(f"{s.source}: a linear axis's figures are in um; `max_iso`/"
                           "`max_vdi` limits are arcsec and cannot be checked against them")
            continue
        if s.iso is not None:
            axis = s.iso.axis()
            for key, lim in limits.max_iso.items():
                bad += exceeded(axis.get(key), lim, f"ISO 230-2 {key}", s.source,
                                f"max_iso {key}:")
        if s.vdi is not None:
            axis = s.vdi.axis()
            for key, lim in limits.max_vdi.items():
                bad += exceeded(axis[key], lim, f"VDI/DGQ 3441 {key}", s.source,
                                f"max_vdi {key}:")
    return bad
