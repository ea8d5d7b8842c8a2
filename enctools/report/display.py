"""The report in the angle unit a person asked for (enc report's ``unit``), and the one
number format of its text, HTML and PDF (:mod:`enctools.report.numbers`, re-exported:
:func:`fmt`, :func:`decimals`; enc-report(1) NUMBERS).

Streams and the JSON summary keep their documented units (angle errors in arcsec); the
text, HTML and PDF a person reads show every angle error in the unit chosen (``unit``:
arcsec, urad, mrad, deg, rad). :func:`in_unit` returns a copy of a
report whose angle errors (curves, uncertainties, figures, harmonic amplitudes,
spectra, ISO 230-2 figures, the nightly history) are in that unit, each converted
by :func:`enctools.units.factor`; radial motion stays nm, correction tables count,
and positions and phases are shown in degrees by the renderers.
"""

from __future__ import annotations

import copy
import dataclasses
from typing import Any

import numpy as np

from enctools.report.iso230 import DirectionFigures, Iso230
from enctools.report.numbers import DECIMALS, fmt, significant  # noqa: F401  (re-exported)
from enctools.report.sections import Curve, Section
from enctools.report.summary import Report
from enctools.units import ANGLE_UNITS, DEG, factor, symbol

#: the unit angle errors have in a report as built (that of the streams)
STORED = "arcsec"
_FIGURES = ("mean", "minimum", "maximum", "pp", "plus_minus", "std", "rms")


def mark(unit: str) -> str:
    """How a value in ``unit`` is followed in plain text: ``"`` for arcsec, else a space
    and the unit's ASCII name (``0.12 urad``)."""
    return '"' if unit == "arcsec" else f" {unit}"


def in_length(c: Curve) -> bool:
    """Whether ``c`` is a linear scale's interpolation error [nm] within its signal period
    (enc-interp-check(1), LINEAR SCALES), not an angle's."""
    return c.domain == "period" and c.unit == "nm"


def phase_text(c: Curve, phase_rad: float, degree: str = " deg") -> str:
    """A harmonic's phase [rad] as printed: whole degrees with ``degree`` (" deg", "°"),
    or a linear scale's (:func:`in_length`) in rad to 2 decimals, never an angle's deg."""
    return f"{phase_rad:.2f} rad" if in_length(c) else f"{phase_rad / DEG:.0f}{degree}"


def label(unit: str) -> str:
    """The unit as a figure or a web page names it: ``arcsec``, ``µrad``, ``deg``."""
    return "arcsec" if unit == "arcsec" else ("deg" if unit == "deg" else symbol(unit))


def in_unit(report: Report, unit: str) -> Report:
    """A copy of ``report`` with every angle error in ``unit`` (the input is unchanged)."""
    k = factor(STORED, unit)
    out = Report(sections=[_section(s, unit, k) for s in report.sections],
                 history=None if report.history is None else _history(report.history, unit, k),
                 settings=dict(report.settings) | {"unit": unit})
    return out


def _section(s: Section, unit: str, k: float) -> Section:
    if s.unit != STORED and s.unit not in ANGLE_UNITS:     # a linear axis's um: no angle
        return s
    new = copy.copy(s)
    new.unit = unit
    new.curves = [_curve(c, unit, k) if c.unit == STORED else c for c in s.curves]
    new.spectra = [dataclasses.replace(sp, amplitude=sp.amplitude * k,
                                       u=None if sp.u is None else sp.u * k, unit=unit)
                   for sp in s.spectra]
    new.iso = None if s.iso is None else _iso(s.iso, unit, k)
    new.vdi = None if s.vdi is None else s.vdi.scaled(k, unit)
    return new


def _curve(c: Curve, unit: str, k: float) -> Curve:
    figures = dataclasses.replace(c.figures, **{f: getattr(c.figures, f) * k for f in _FIGURES})
    harmonics = None if c.harmonics is None else dataclasses.replace(
        c.harmonics, amplitude=c.harmonics.amplitude * k)
    extra = dict(c.extra)
    return dataclasses.replace(c, unit=unit, values=c.values * k,
                               u=None if c.u is None else c.u * k, figures=figures,
                               harmonics=harmonics, extra=extra,
                               directions={d: v * k for d, v in c.directions.items()},
                               digest=None if c.digest is None else c.digest.scaled(k))


def _direction(d: DirectionFigures | None, k: float) -> DirectionFigures | None:
    if d is None:
        return None
    return dataclasses.replace(d, mean=d.mean * k, s=d.s * k, R_i=d.R_i * k, R=d.R * k,
                               E=d.E * k, A=d.A * k)


def _iso(iso: Iso230, unit: str, k: float) -> Iso230:
    bidirectional: dict[str, Any] = {key: (np.asarray(v) * k if isinstance(v, np.ndarray)
                                           else float(v) * k)
                                     for key, v in iso.bidirectional.items()}
    return dataclasses.replace(iso, up=_direction(iso.up, k), down=_direction(iso.down, k),
                               bidirectional=bidirectional, unit=unit)


def _history(history: Any, unit: str, k: float) -> Any:
    """The history with its columns in arcsec (by their field metadata) in ``unit``: its
    batches are converted as they are read."""
    return dataclasses.replace(history, unit=unit, scale=history.scale * k)
