"""The one number format of the text, HTML and PDF reports (enc-report(1) NUMBERS).

A figure with its expanded uncertainty U is rounded to the decade of U given to two
significant digits, and U to those two digits (JCGM 100:2008, GUM 7.2.6); a figure
without one to four significant digits of the largest of the figures shown with it;
never coarser than the unit's resolution (without a U) nor finer than the
floating-point noise. :mod:`enctools.report.display` re-exports it; it imports nothing
of the report, so that the budget and the covariance statement print through it too.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

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
#: degrees of freedom above this print as "> 10000": Student's k at 95 % is then the
#: normal quantile's to four digits (1.960), and Welch-Satterthwaite's ten digits of a
#: Type A of few repeats beside an exact Type B (6446655606) say nothing more
LARGE_DOF = 10_000


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


def fmt_each(values: Any, unit: str = "arcsec", missing: str = "–") -> list[str]:
    """Each figure of ``values`` [``unit``], without a U, as :func:`fmt` gives it alone
    (four significant digits of itself, never coarser than the unit's resolution nor finer
    than the floating-point noise; a value that rounds to 0 is ``0.000``), computed over
    the array at once: a history's column of a million runs prints in a second. None,
    NaN and infinity print as ``missing``."""
    v = np.asarray([np.nan if x is None else x for x in np.ravel(values)], np.float64) \
        if not isinstance(values, np.ndarray) else values.astype(np.float64).ravel()
    out = np.full(v.size, missing, dtype=object)
    ok = np.flatnonzero(np.isfinite(v) & (v != 0.0))
    floor = DECIMALS.get(unit, 3)
    d = np.full(v.size, floor, dtype=np.int64)
    if ok.size:
        a = np.abs(v[ok])
        dd = SIGNIFICANT - 1 - np.floor(np.log10(a)).astype(np.int64)
        for k in np.unique(dd):  # 9.9996 to four digits is 10.00: one decade up
            sel = dd == k
            up = np.abs(np.round(a[sel], int(k))) >= 10.0 ** (SIGNIFICANT - int(k))
            dd[np.flatnonzero(sel)[up]] -= 1
        d[ok] = np.minimum(NOISE.get(unit, 9), np.maximum(floor, dd))
    finite = np.flatnonzero(np.isfinite(v))
    for k in np.unique(d[finite]):
        idx = finite[d[finite] == k]
        text = np.char.mod(f"%.{int(k)}f", v[idx])
        zero = np.char.strip(text, "-0.") == ""  # it rounds to 0: 0.000, never -0.000
        text = text.astype(object)
        text[zero] = _fixed(0.0, floor)
        out[idx] = text
    return [str(x) for x in out]


def fmt_dof(nu: float, infinite: str = "inf") -> str:
    """Degrees of freedom as the documents print them: a whole number, ``infinite`` for
    an exact input, "> 10000" above :data:`LARGE_DOF` (the JSON keeps the number)."""
    if math.isinf(nu):
        return infinite
    return f"> {LARGE_DOF}" if nu > LARGE_DOF else f"{nu:.0f}"
