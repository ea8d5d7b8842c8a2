"""The report in the angle unit a person asked for (enc report's ``unit``).

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
import math
from typing import Any

import numpy as np

from enctools.report.iso230 import DirectionFigures, Iso230
from enctools.report.sections import Curve, Section
from enctools.report.summary import Report
from enctools.units import ANGLE_UNITS, factor, symbol

#: the unit angle errors have in a report as built (that of the streams)
STORED = "arcsec"
_FIGURES = ("mean", "minimum", "maximum", "pp", "plus_minus", "std", "rms")


#: decimals a value is shown with in each unit (its resolution 10**-decimals): 0.001"
#: and about as fine in the other angle units; any other unit (nm, count) 3
DECIMALS = {"arcsec": 3, "urad": 3, "mrad": 6, "deg": 7, "rad": 9}


def fmt(x: float | None, unit: str = "arcsec", decimals: int | None = None,
        missing: str = "–") -> str:
    """A value [``unit``] as text, rounded to the unit's resolution (:data:`DECIMALS`;
    ``decimals`` instead when given): a value below it prints as 0 at that resolution
    (``-5.6e-17`` arcsec is ``0.000``, never ``-0.000``). None, NaN and infinity print
    as ``missing``. The one number format of the text, HTML and PDF reports."""
    if x is None or not math.isfinite(x):
        return missing
    d = DECIMALS.get(unit, 3) if decimals is None else decimals
    text = f"{x:.{d}f}"
    return text.lstrip("-") if float(text) == 0.0 else text


def significant(x: float, digits: int = 4) -> str:
    """A declared value (not a measured one) to ``digits`` significant digits, through
    :func:`fmt`: 0.05 deg is ``0.05000``, 1 is ``1.000``."""
    if not math.isfinite(x) or x == 0.0:
        return fmt(x, decimals=digits - 1)
    return fmt(x, decimals=max(0, digits - 1 - math.floor(math.log10(abs(x)))))


def mark(unit: str) -> str:
    """How a value in ``unit`` is followed in plain text: ``"`` for arcsec, else a space
    and the unit's ASCII name (``0.12 urad``)."""
    return '"' if unit == "arcsec" else f" {unit}"


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
