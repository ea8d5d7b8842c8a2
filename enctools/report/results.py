"""The results of a certificate per calibrated position: target, deviation, U with k.

An accredited certificate of an angle standard lists every calibrated position with
its deviation and expanded uncertainty (EURAMET cg-23; ISO/IEC 17025:2017 7.8.2.1 and
7.8.4.1): not only the summary figures. :func:`results` turns a report section into
such tables, one per calibrated curve:

- points and step runs: one row per target (its position [deg]), the mean deviation
  of each direction approached and, with two, their mean (x_i of ISO 230-2), and U = k u
  of that mean with its k;
- a curve over a revolution on a dense grid (self-calibration, comparison): the curve
  at every :data:`STEP_DEG` (the grid's angle nearest each), with U there; an
  interpolation error within one signal period: at every :data:`PHASE_STEP_DEG` of
  the phase.

Radial motion, models and correction tables are no calibrated positions of the item:
they get none. Values are in the section's unit (the unit the report is read in),
rounded to its resolution (:func:`enctools.report.display.fmt`), so the text, the
JSON, the HTML and the PDF print the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from enctools.models.correction_u import CorrectionU
from enctools.report.display import DECIMALS, label
from enctools.report.longcurves import MARK_DEG
from enctools.report.numbers import decimals, fmt, fmt_u, group
from enctools.report.sections import Curve, Section
from enctools.units import DEG

#: a dense curve over a revolution is listed at every STEP_DEG [deg]
STEP_DEG = 10.0
#: an interpolation error within a signal period at every PHASE_STEP_DEG of phase [deg]
PHASE_STEP_DEG = 30.0
#: a curve of at most this many values is listed value by value (its targets)
MAX_TARGETS = 400
#: a results target within this of a model's fitted point [deg] is that point
SAME_TARGET_DEG = 1e-3
#: the curves of these roles are calibrated positions of the item
ROLES = ("points", "positioning", "deviation")


@dataclass
class Results:
    """The results of one curve at its calibrated positions, in ``unit``.

    ``target``: position [deg] (or phase within a signal period [deg]); ``up`` and
    ``down``: the mean deviation of each direction (None: not approached so); ``mean``:
    the deviation (the mean of both directions where there are two); ``U``: its
    expanded uncertainty (None: the result states none) with coverage factor ``k``.
    """

    curve: str
    unit: str
    target: np.ndarray
    mean: np.ndarray
    up: np.ndarray | None = None
    down: np.ndarray | None = None
    U: np.ndarray | None = None
    k: float | None = None
    phase: bool = False
    sampled: float | None = None       # the step [deg] a dense curve is listed at
    after: np.ndarray | None = None    # the deviation less the correction shipped with it
    held_out: bool = False             # ``after`` of a model refitted without each target
    #: the uncertainty of the correction at any angle (the model's and its table's)
    correction: CorrectionU | None = None

    def rows(self) -> list[dict[str, Any]]:
        """One dict per row: ``target_deg``, ``deviation_up``, ``deviation_down``,
        ``deviation``, ``U``, ``k`` (None where the table has no such column), each
        number rounded by the one rule (:func:`enctools.report.display.decimals`): a row's
        deviations to the decade of its U given to two significant digits, U to two
        significant digits; without a U, the curve's deviations to four significant
        digits of the largest of them."""
        plain = group([a for a in (self.mean, self.up, self.down, self.after)
                       if a is not None], self.unit)
        out = []
        for i, t in enumerate(self.target):
            U = None if self.U is None else float(self.U[i])
            d = plain if U is None or not U > 0 else decimals(self.unit, u=U)
            out.append({
                "target_deg": round(float(t), 4),
                "deviation_up": None if self.up is None else round(float(self.up[i]), d),
                "deviation_down": None if self.down is None else round(float(self.down[i]), d),
                "deviation": round(float(self.mean[i]), d),
                "after": None if self.after is None else round(float(self.after[i]), d),
                "U": None if U is None else round(U, d), "decimals": d,
                "k": None if self.k is None else round(self.k, 2)})
        return out

    def header(self) -> list[str]:
        """The column heads of the table (unit in brackets)."""
        u = label(self.unit)
        cols = ["phase [deg]" if self.phase else "target [deg]"]
        if self.up is not None and self.down is not None:
            cols += [f"deviation ↑ [{u}]", f"deviation ↓ [{u}]", f"mean [{u}]"]
        else:
            cols.append(f"deviation [{u}]")
        cols += [f"U [{u}]", "k"]
        return cols + ([f"after correction [{u}]"] if self.after is not None else [])

    def cells(self) -> list[list[str]]:
        """The rows as the documents print them (the same numbers as :meth:`rows`)."""
        both = self.up is not None and self.down is not None
        out = []
        for r in self.rows():
            row = [f"{r['target_deg']:.3f}"]
            d = r["decimals"]
            if both:
                row += [fmt(r["deviation_up"], self.unit, d),
                        fmt(r["deviation_down"], self.unit, d)]
            row += [fmt(r["deviation"], self.unit, d), fmt_u(r["U"], self.unit),
                    "–" if r["k"] is None else f"{r['k']:.2f}"]
            if self.after is not None:
                row.append(fmt(r["after"], self.unit, d))
            out.append(row)
        return out

    def note(self) -> str:
        """What the table lists, in words."""
        if self.sampled is not None:
            what = "phase within the signal period" if self.phase else "angle"
            return (f"The {what} every {self.sampled:g}° (the curve's nearest grid point); "
                    "the figures and the plot cover the whole curve.")
        after = "" if self.after is None else (
            " After correction: the deviation less the error model shipped with the item "
            "(its correction table) at the target, "
            + ("the model fitted without that target where it was fitted to it "
               "(leave-one-out): a held-out residual." if self.held_out else
               "a model fitted to these points leaves its residuals here, not an "
               "independent check."))
        after += self.correction_words()
        if self.up is not None and self.down is not None:
            return ("Mean deviation per direction (↑ increasing, ↓ decreasing angle) and "
                    "their mean; U is the mean's." + after)
        return "One row per calibrated position." + after

    def correction_words(self) -> str:
        """" U of the correction at any angle: …" with its terms ("" without a model or
        where the model states none)."""
        if self.after is None:
            return ""
        c, u = self.correction, self.unit
        if c is None or u != "arcsec":
            return " U of the correction at any angle: – (the model states none)."
        none = "(not included: no table among the inputs)"
        terms = "; ".join(f"{name} {none if v is None else fmt(v, u)}" for name, v in c.terms())
        return (f" U of the correction at any angle: {fmt_u(c.U, u)} {label(u)} "
                f"(k = {c.k:g}; standard uncertainties: {terms}).")

    def correction_dict(self) -> dict[str, Any] | None:
        """For JSON: the correction's U [arcsec], k and each term (None: none stated)."""
        c = self.correction
        if self.after is None or c is None or self.unit != "arcsec":
            return None
        d = DECIMALS.get(self.unit, 3)
        return {"expanded_u_arcsec": round(c.U, d), "coverage_k": c.k,
                "standard_u_arcsec": round(c.u_c, d),
                "terms": [{"term": n, "standard_u_arcsec": None if v is None else round(v, d)}
                          for n, v in c.terms()]}

    def to_dict(self) -> dict[str, Any]:
        """For JSON: the unit as the keys' suffix."""
        u = self.unit
        rows = []
        for r in self.rows():
            row: dict[str, Any] = {"phase_deg" if self.phase else "target_deg": r["target_deg"]}
            if r["deviation_up"] is not None:
                row[f"deviation_up_{u}"] = r["deviation_up"]
            if r["deviation_down"] is not None:
                row[f"deviation_down_{u}"] = r["deviation_down"]
            row[f"deviation_{u}"] = r["deviation"]
            row[f"expanded_u_{u}"] = r["U"]
            row["coverage_k"] = r["k"]
            if r["after"] is not None:
                row[f"deviation_after_correction_{u}"] = r["after"]
            rows.append(row)
        out: dict[str, Any] = {"curve": self.curve, "unit": u,
                               "listed_every_deg": self.sampled, "rows": rows}
        correction = self.correction_dict()
        if correction is not None:
            out["correction_at_any_angle"] = correction
        return out


def results(s: Section, model: Curve | None = None) -> list[Results]:
    """The results tables of a section (none for radial motion, models, tables);
    ``model``: the error model shipped with the item as its correction (a report's model
    section's curve, :func:`correction_of`), which gives points a column after it."""
    out = []
    for c in s.curves:
        if c.role not in ROLES or c.unit in ("nm", "count") or c.values.size == 0:
            continue
        res = _curve_results(s, c)
        if model is not None and c.role == "points" and model.unit == c.unit:
            res.after = res.mean - _correction(model, res.target)
            res.held_out = model.held_out is not None
            res.correction = model.correction_u
        out.append(res)
    return out


def _correction(model: Curve, target: np.ndarray) -> np.ndarray:
    """The correction [the model's unit] at each ``target`` [deg]: the model's own, or, at a
    target it was fitted to (within :data:`SAME_TARGET_DEG`), its prediction refitted
    without that target (``model.held_out``), so that the column after it is a held-out
    residual, not a residual of the fit."""
    grid = np.mod(np.asarray(model.angle, np.float64) / DEG, 360.0)
    out = np.interp(target, grid, model.values, period=360.0)
    if model.held_out is None:
        return out
    fitted, prediction = model.held_out
    gap = np.abs(((np.mod(fitted, 360.0)[None, :] - target[:, None]) + 180.0) % 360.0 - 180.0)
    near = np.argmin(gap, axis=1)
    same = gap[np.arange(target.size), near] <= SAME_TARGET_DEG
    out[same] = prediction[near[same]]
    return out


def correction_of(sections: list[Section]) -> Curve | None:
    """The curve of the first error model among ``sections`` (the correction a points
    section's results are given after), or None; with a correction table among them too
    (a ``rom``), the model's uncertainty includes that table's quantisation."""
    model = next((c for s in sections if s.kind == "model" for c in s.curves), None)
    if model is None or model.correction_u is None:
        return model
    lsb = next((s.meta["rom"].get("lsb_arcsec") for s in sections
                if s.kind == "rom" and isinstance(s.meta.get("rom"), dict)), None)
    if not isinstance(lsb, (int, float)) or not lsb > 0:
        return model
    return replace(model, correction_u=model.correction_u.with_lsb(float(lsb)))


def _curve_results(s: Section, c: Curve) -> Results:
    phase = c.domain == "period"
    U = None if c.u is None else c.k * np.asarray(c.u, np.float64)
    k = None if c.u is None else float(c.k)
    angle = np.mod(np.asarray(c.angle, np.float64) / DEG, 360.0)
    if c.values.size <= MAX_TARGETS and c.role != "deviation":
        res = Results(c.name, c.unit, angle, c.values, U=U, k=k, phase=phase)
        if set(c.directions) == {1, -1}:
            res.up, res.down = c.directions[1], c.directions[-1]
        else:
            _directions(s, res)
        return res
    step = PHASE_STEP_DEG if phase else STEP_DEG
    wanted = np.arange(0.0, 360.0, step)
    if c.digest is not None:    # a long curve: its grid points nearest every MARK_DEG
        marks = np.arange(0.0, 360.0, MARK_DEG)
        pick = np.flatnonzero(np.isin(marks, wanted))
        d = c.digest
        return Results(c.name, c.unit, np.mod(d.angle[pick] / DEG, 360.0), d.values[pick],
                       U=None if d.u is None else c.k * d.u[pick], k=k, phase=phase,
                       sampled=step)
    gap = np.abs(((angle[None, :] - wanted[:, None]) + 180.0) % 360.0 - 180.0)
    near = np.argmin(gap, axis=1)
    return Results(c.name, c.unit, angle[near], c.values[near],
                   U=None if U is None else U[near], k=k, phase=phase, sampled=step)


def _directions(s: Section, res: Results) -> None:
    """Each direction's mean per target from the section's ISO 230-2 figures, when the
    run approached the targets from both sides."""
    iso = s.iso
    if iso is None or not iso.is_bidirectional or iso.up is None or iso.down is None:
        return
    pos = np.asarray(iso.positions, np.float64)
    gap = np.abs(((pos[None, :] - res.target[:, None]) + 180.0) % 360.0 - 180.0)
    near = np.argmin(gap, axis=1)
    if pos.size != res.target.size or np.max(gap[np.arange(near.size), near]) > 1e-6:
        return
    # ISO 230-2's x is -deviation of a points stream (x_sign): back to the curve's sign
    res.up = iso.x_sign * np.asarray(iso.up.mean, np.float64)[near]
    res.down = iso.x_sign * np.asarray(iso.down.mean, np.float64)[near]
