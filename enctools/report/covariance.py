"""The covariance statement of a polygon run's points (enc-report(1), UNCERTAINTY BUDGET).

The points of one polygon run share their datum (the run's first position): its
repeatability, its heads' quantisation and its face enter every point, and so does the
autocollimator's scale error. :mod:`enctools.methods.polygon_gum` propagates the model
through GTC; this module gathers its inputs from the points' metadata and states what
follows: the correlation between points, the U of a difference of two points, of p-p
(the difference of the two extreme points) and of the harmonics' amplitudes, as text
lines, JSON and the document's sentences. Values in arcsec.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from enctools.data.polygon import certificate_evaluation, points_face_uncertainty
from enctools.data.uncertainty import Declaration
from enctools.errors import DataError
from enctools.methods.budget import PolygonRun
from enctools.methods.polygon_gum import Faces, Figure, PointsModel, propagate
from enctools.report.numbers import fmt_u
from enctools.units import factor

#: the most points whose covariance matrix GTC forms (n^2/2 covariances of ~6n inputs)
MAX_POINTS = 120
#: the most points whose correlation matrix the JSON lists
MAX_JSON_MATRIX = 60


@dataclass(frozen=True)
class Statement:
    """The model's results with the points' positions [deg] and deviations [arcsec], in
    the points stream's order (the datum first)."""

    model: PointsModel
    pos_deg: np.ndarray
    x_arcsec: np.ndarray


def _faces(meta: dict[str, Any], declared: dict[str, Declaration], face: np.ndarray
           ) -> Faces:
    """The faces' u [arcsec] from the datum's: the applied certificate's (each face's,
    from the face at the datum), else the rig's declaration for every face, else 0."""
    u = points_face_uncertainty(meta)
    if u is not None:
        cert = meta["polygon_certificate"]
        start = int(cert.get("first_face", 0) or 0) - int(cert.get("first_face_number", 0) or 0)
        _, dof = certificate_evaluation(cert)
        return Faces(np.roll(u, -start), dof)
    settings = meta.get("settings")
    count = settings.get("faces") if isinstance(settings, dict) else None
    count = count if isinstance(count, int) and count > int(face.max()) else int(face.max()) + 1
    d = declared.get("polygon")
    return Faces(np.full(count, d.standard if d is not None else 0.0),
                 d.dof if d is not None else math.inf)


def _check(ac: list[Any], face: list[Any], source: str) -> None:
    """DataError (one line) unless every a_j - a_0 is a number within +-3600 arcsec and
    every face a whole number 0..719, the datum's 0 (metadata are data from elsewhere)."""
    if not all(isinstance(a, int | float) and not isinstance(a, bool) and abs(a) <= 3600.0
               for a in ac):
        msg = f"{source}: polygon_run.ac_arcsec must be numbers within +-3600 arcsec"
        raise DataError(msg)
    if not (all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v < 720 for v in face)
            and face[0] == 0):
        msg = f"{source}: polygon_run.face must be whole numbers 0..719, the first 0"
        raise DataError(msg)


def statement(meta: dict[str, Any], declared: dict[str, Declaration], run: PolygonRun,
              pos_deg: np.ndarray, x_arcsec: np.ndarray, source: str = "points"
              ) -> tuple[Statement | None, str]:
    """The statement of one run's points (stream order, the datum first) and a note
    (why there is none, or "")."""
    raw = meta.get("polygon_run") or {}
    ac, face = raw.get("ac_arcsec"), raw.get("face")
    n = x_arcsec.size
    if not (isinstance(ac, list) and isinstance(face, list) and len(ac) == len(face) == n):
        return None, ("no covariance statement: the points do not record each point's "
                      "autocollimator offset and face (made before enc points recorded them)")
    if n > MAX_POINTS:
        return None, f"no covariance statement: {n} points, at most {MAX_POINTS} are modelled"
    _check(ac, face, source)
    f = np.asarray(face, np.int64)
    model = propagate(x_arcsec, np.asarray(ac, float), f, run, _faces(meta, declared, f),
                      declared.get("autocollimator"), terms=declared)
    return Statement(model, np.asarray(pos_deg, float), np.asarray(x_arcsec, float)), ""


def _at(st: Statement, i: int) -> str:
    return f"{round(float(st.pos_deg[i]) % 360.0, 3) % 360.0:g} deg"


def lines(st: Statement, unit: str = "arcsec") -> list[str]:
    """The statement as the text report's lines, in ``unit``: each point's U, then the
    document's sentences (:func:`sentences`)."""
    m, f = st.model, factor("arcsec", unit)
    u = m.k[1:] * m.u[1:]
    return [f"  covariance (GTC, the budget's model per point) [{unit}]: U per point "
            f"{_u(u.min() * f, unit)}..{_u(u.max() * f, unit)}, 0 at the datum {_at(st, 0)}"] + [
        f"    {x}" for x in sentences(st, unit, lambda v, _: f"{_u(v, unit)} {unit}")]


def _u(U: float, unit: str) -> str:
    """An expanded uncertainty as every document prints it (two significant digits)."""
    return fmt_u(U, unit)


def _range(lo: float, hi: float) -> str:
    return f"{lo:.2f}" if abs(hi - lo) < 0.005 else f"{lo:.2f}..{hi:.2f}"


def _fig(x: Figure) -> dict[str, Any]:
    return {"u_arcsec": x.u, "dof": None if math.isinf(x.dof) else x.dof, "k": x.k,
            "U_arcsec": x.U}


def as_dict(st: Statement) -> dict[str, Any]:
    """The statement for JSON: per point (stream order) u, dof, k, U; r; the difference,
    p-p and harmonics with u, dof (null: infinite), k and U [arcsec]."""
    m = st.model
    lo, hi = m.r_range()
    out: dict[str, Any] = {
        "method": "GTC (GUM Tree Calculator), the budget's model per point",
        "points": [{"position_deg": float(p), "u_arcsec": float(u),
                    "dof": None if not math.isfinite(d) else float(d), "k": float(k),
                    "U_arcsec": float(k * u)}
                   for p, u, d, k in zip(st.pos_deg, m.u, m.dof, m.k, strict=True)],
        "r_min": lo, "r_max": hi,
        "difference": _fig(m.difference) | {"positions_deg": [float(st.pos_deg[i])
                                                              for i in m.pair]},
        "pp": _fig(m.pp) | {"positions_deg": [float(st.pos_deg[i]) for i in m.extremes],
                            "value_arcsec": float(st.x_arcsec[m.extremes[0]]
                                                  - st.x_arcsec[m.extremes[1]])},
        "harmonics": [{"n": int(n), "amplitude_arcsec": float(a)} | _fig(h) for n, a, h in
                      zip(m.orders, m.amplitude, m.harmonics, strict=True)]}
    if m.corr.shape[0] <= MAX_JSON_MATRIX:
        out["correlation"] = [[round(float(v), 6) for v in row] for row in m.corr]
    return out


def sentences(st: Statement, unit: str, fmt: Any) -> list[str]:
    """The statement as the document's sentences, U in ``unit`` (``fmt`` the document's
    number format: fmt(value, unit))."""
    m, f = st.model, factor("arcsec", unit)
    lo, hi = m.r_range()
    a, b = m.extremes
    out = [f"Correlation: the points share the datum (the first position): its "
           f"repeatability, quantisation and face, and the autocollimator's scale error, "
           f"enter every point, so two points correlate with r = {_range(lo, hi)} "
           f"(propagated through GTC). The difference of two points is known better than an "
           f"independent treatment says: its U is at most {fmt(m.difference.U * f, unit)} "
           f"(k = {m.difference.k:.2f}).",
           f"Peak-to-peak, as the difference of the extreme points ({_at(st, a)} and "
           f"{_at(st, b)}): U = {fmt(m.pp.U * f, unit)} (k = {m.pp.k:.2f}); the extremes "
           f"are picked from the data, which U does not cover."]
    if m.orders.size:
        hu = np.array([h.U for h in m.harmonics])
        out.append(f"Harmonic amplitudes (orders 1 to {int(m.orders[-1])}): U = "
                   f"{fmt(hu.max() * f, unit)} at most (an amplitude below about 3 u "
                   f"is biased upwards).")
    return out
