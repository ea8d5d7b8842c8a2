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
from enctools.units import factor, symbol

#: the unit angle errors have in a report as built (that of the streams)
STORED = "arcsec"
_FIGURES = ("mean", "minimum", "maximum", "pp", "plus_minus", "std", "rms")


#: decimals of the unit's resolution (10**-decimals: 0.001" and about as fine in the other
#: angle units; any other unit, nm or count, 3): a figure without a U is never shown
#: coarser than this
DECIMALS = {"arcsec": 3, "urad": 3, "mrad": 6, "deg": 7, "rad": 9}
#: decimals of the floating-point noise of an angle error (an angle of up to 2 pi rad
#: holds about 1e-15 rad, 2e-10"): no figure is shown finer than this; any other unit 9
NOISE = {"arcsec": 9, "urad": 9, "mrad": 12, "deg": 13, "rad": 15}
#: significant digits of a figure without a U (of the largest of a group shown together)
SIGNIFICANT = 4
#: significant digits of an expanded uncertainty U (GUM 7.2.6: at most two)
U_DIGITS = 2


def decimals(unit: str = "arcsec", u: float | None = None,
             scale: float | None = None) -> int:
    """The decimals a figure [``unit``] is shown with (the one rule of every document):

    - with its expanded uncertainty ``u`` (finite, > 0): the decade of ``u`` given to
      :data:`U_DIGITS` significant digits (GUM 7.2.6; may be negative: tens, hundreds);
    - else :data:`SIGNIFICANT` significant digits of ``scale`` (the largest magnitude of
      the figures shown together; the figure's own when alone), never fewer decimals
      than the unit's resolution (:data:`DECIMALS`);
    - never more than the floating-point noise (:data:`NOISE`)."""
    noise = NOISE.get(unit, 9)
    if u is not None and math.isfinite(u) and u > 0:
        return min(noise, _decade(u, U_DIGITS))
    d = DECIMALS.get(unit, 3)
    if scale is not None and math.isfinite(scale) and scale != 0.0:
        d = max(d, _decade(abs(scale), SIGNIFICANT))
    return min(noise, d)


def _decade(x: float, digits: int) -> int:
    """Decimals giving ``x`` (> 0) ``digits`` significant digits once rounded (9.96 to two
    digits is 10, not 9.96)."""
    d = digits - 1 - math.floor(math.log10(x))
    if abs(round(x, d)) >= 10.0 ** (digits - d):
        d -= 1
    return d


def group(values: Any, unit: str = "arcsec") -> int:
    """The decimals of figures shown together without a U (a curve's p-p, +/-, mean and s;
    a table's column): :func:`decimals` with the largest finite magnitude among them."""
    arr = np.abs(np.asarray([np.nan if v is None else v for v in np.ravel(values)],
                            np.float64))
    arr = arr[np.isfinite(arr)]
    return decimals(unit, scale=float(arr.max()) if arr.size else None)


def table_decimals(table: list[dict[str, Any]], unit: str = "arcsec") -> int:
    """The decimals of a standard's table (ISO 230-2, VDI/DGQ 3441 per position): :func:`group`
    of every figure in it (not its positions [deg] nor its counts ``n_*``), so that the
    text and the documents, which list different columns, round it alike."""
    return group([v for r in table for k, v in r.items()
                  if k != "position_deg" and not k.startswith("n_")], unit)


def figures(f: Any, unit: str = "arcsec") -> int:
    """The decimals of a curve's figures ``f`` (p-p, +/-, mean, s: shown together wherever
    they are, text line, summary table, comparison): :func:`group` of them."""
    return group([f.pp, f.plus_minus, f.mean, f.std], unit)


def fmt(x: float | None, unit: str = "arcsec", decimals: int | None = None,
        missing: str = "–", u: float | None = None) -> str:
    """A figure [``unit``] as text by the one rule (:func:`decimals`): rounded to the
    decade of its expanded uncertainty ``u`` when given, else to four significant digits
    of itself (``decimals`` instead: those of its group, :func:`group`), never coarser
    than the unit's resolution nor finer than the floating-point noise. A value that
    rounds to 0 prints as 0 (``-5.6e-17`` arcsec is ``0.000``, never ``-0.000`` nor
    noise). None, NaN and infinity print as ``missing``. The one number format of the
    text, HTML and PDF reports."""
    if x is None or not math.isfinite(x):
        return missing
    d = _decimals(unit, u, x) if decimals is None else decimals
    text = _fixed(x, d)
    if float(text) == 0.0:
        return _fixed(0.0, d if decimals is not None or u is not None else
                      DECIMALS.get(unit, 3))
    return text


def _decimals(unit: str, u: float | None, x: float) -> int:
    return decimals(unit, u=u, scale=None if u is not None else x)


def _fixed(x: float, d: int) -> str:
    """``x`` with ``d`` decimals; ``d`` < 0 rounds to tens, hundreds (no decimals)."""
    if d >= 0:
        return f"{x:.{d}f}"
    return f"{round(x, d):.0f}"


def fmt_u(u: float | None, unit: str = "arcsec", missing: str = "–") -> str:
    """An expanded uncertainty [``unit``] to :data:`U_DIGITS` significant digits (GUM
    7.2.6): 0.01234 is ``0.012``, 12.3 is ``12``, 0.996 is ``1.0``."""
    if u is None or not math.isfinite(u):
        return missing
    return fmt(u, unit, u=u) if u > 0 else fmt(u, unit)


def significant(x: float, digits: int = 4) -> str:
    """A declared value (not a measured one) to ``digits`` significant digits: 0.05 deg is
    ``0.05000``, 1 is ``1.000``."""
    if not math.isfinite(x) or x == 0.0:
        return fmt(x, decimals=digits - 1)
    return fmt(x, decimals=max(0, _decade(abs(x), digits)))


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
