"""The uncertainty budget of a points section (GUM; enc-report(1), UNCERTAINTY BUDGET).

Points from a polygon step run (``enc points``) carry what their run says about its
own repeatability (metadata ``polygon_run``) and the rig's Type B declarations
(``rig.uncertainty``, enc-rig(5)). From both this module builds the budget of a point
(:func:`enctools.methods.budget.polygon_run_budget`): the repeatability of the
readings (Type A), the quantisation of the heads, the polygon's face errors and the
autocollimator's scale error, combined with Welch-Satterthwaite and expanded with
Student's k. Values in arcsec.

Metadata are data from elsewhere: every value is checked and a bad one is one
DataError line naming it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from enctools.data.polygon import certificate_evaluation, points_face_uncertainty
from enctools.data.uncertainty import Declaration, declarations
from enctools.errors import DataError
from enctools.methods.budget import (
    POLYGON_RUN_QUANTITIES,
    POLYGON_RUNS_QUANTITIES,
    SELFCAL_QUANTITIES,
    Budget,
    PolygonRun,
    comparison_budget,
    polygon_run_budget,
    polygon_runs_budget,
    probe_interpolation_budget,
    reference_quantity,
    resolution,
    selfcal_budget,
    step_run_budget,
)
from enctools.methods.polygon_terms import not_declared
from enctools.report.numbers import fmt_dof, fmt_u
from enctools.units import factor

#: polygon_run metadata key -> (least, greatest, whole number, may be null)
_RUN_KEYS: dict[str, tuple[float, float, bool, bool]] = {
    "s_arcsec": (0.0, 3600.0, False, True), "dof": (0, 1e9, True, False),
    "readings": (1, 1e9, True, False), "span_arcsec": (0.0, 3600.0, False, False),
    "lsb_arcsec": (1e-9, 3600.0, False, False), "heads": (1, 64, True, False),
    "head_s_arcsec": (0.0, 3600.0, False, True)}


def polygon_run(meta: Any, source: str) -> PolygonRun | None:
    """The checked ``polygon_run`` metadata of points (None: a Type A needs readings
    repeated at a position: a run of one reading per position has none)."""
    if not isinstance(meta, dict):
        msg = f"{source}: polygon_run metadata must be a table, not {meta!r}"
        raise DataError(msg)
    values: dict[str, Any] = {}
    for key, (lo, hi, whole, nullable) in _RUN_KEYS.items():
        v = meta.get(key)
        if v is None and nullable:
            return None
        if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                and lo <= v <= hi and (not whole or float(v).is_integer())):
            msg = f"{source}: polygon_run.{key} must be a number {lo:g}..{hi:g}, not {v!r}"
            raise DataError(msg)
        values[key] = int(v) if whole else float(v)
    if values["dof"] == 0:
        return None
    return PolygonRun(values["s_arcsec"], values["dof"], values["readings"],
                      values["span_arcsec"], values["lsb_arcsec"], values["heads"],
                      values["head_s_arcsec"], **_span(meta, source))


#: optional polygon_run keys (what the Type A spans) -> (least, greatest, whole number)
_SPAN_KEYS: dict[str, tuple[float, float, bool]] = {
    "interval_s": (0.0, 1e6, False), "runs": (1, 1e9, True), "directions": (1, 2, True),
    "closing_arcsec": (-3600.0, 3600.0, False)}


def _span(meta: dict[str, Any], source: str) -> dict[str, Any]:
    """The optional ``polygon_run`` keys that say what the Type A spans (absent: not
    stated, as in points made before); DataError naming one out of its range."""
    out: dict[str, Any] = {}
    for key, (lo, hi, whole) in _SPAN_KEYS.items():
        v = meta.get(key)
        if v is None:
            continue
        if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                and lo <= v <= hi and (not whole or float(v).is_integer())):
            msg = f"{source}: polygon_run.{key} must be a number {lo:g}..{hi:g}, not {v!r}"
            raise DataError(msg)
        out[key] = int(v) if whole else float(v)
    return out


def points_budget(meta: dict[str, Any], source: str, one_approach: bool,
                  face: Declaration | None = None,
                  type_a: tuple[float, float, float] | None = None
                  ) -> tuple[Budget | None, list[str]]:
    """The budget of the points of a section and the notes saying what it holds.

    ``one_approach``: the points are of one run in one direction (a closing 360 deg
    is the 0 deg target again): the model's datum is then the run's first position.
    Else ``type_a``: the Type A u of a target's mean over its approaches [arcsec] (rms
    along the curve), its degrees of freedom and the stops' scatter [arcsec]
    (:func:`stop_scatter`; None: the approaches give no Type A).
    ``face``: the polygon's face uncertainty from elsewhere (None: from the polygon
    certificate the points were corrected with, else the rig's declaration).
    """
    if "polygon_run" not in meta:
        return None, []
    rig = meta.get("rig")
    tables = rig.get("uncertainty") if isinstance(rig, dict) else None
    if not tables:
        return None, ["no uncertainty budget: the rig declares no [uncertainty] "
                      "(enc-rig(5))"]
    declared = declarations(tables, f"{source}: rig uncertainty")
    if not one_approach:
        return _polygon_runs(meta, source, declared, face, type_a)
    run = polygon_run(meta["polygon_run"], source)
    if run is None:
        return None, ["no uncertainty budget: one reading per position gives no Type A"]
    face = face if face is not None else certificate_face(meta)
    closed = run.closing_arcsec is not None     # the closing reading's row holds the drift
    notes = face_notes(face, declared, closed) + [ONE_RUN_CLOSED if closed else ONE_RUN_TYPE_A]
    notes += unused(declared, POLYGON_RUN_QUANTITIES, "a polygon run's")
    budget = polygon_run_budget(declared, run, face)
    notes.append(f"U per point: the budget's U = {budget.k:.3g} u_c (nu_eff "
                 f"{fmt_dof(budget.nu_eff)}), of each point against the run's first position")
    return budget, notes


def _polygon_runs(meta: dict[str, Any], source: str, declared: dict[str, Declaration],
                  face: Declaration | None, type_a: tuple[float, float, float] | None
                  ) -> tuple[Budget | None, list[str]]:
    """The budget of a target of a polygon step run of several runs or directions."""
    if type_a is None:
        return None, ["no uncertainty budget: a direction misses a target, or one approach "
                      "per target and direction gives no Type A"]
    raw = meta["polygon_run"]
    # its Type A is the approaches'; the heads' rounding is the run's resolution, dithered
    # by the stops' scatter between approaches (a table that stops within a count reads
    # the same counts each time: q / sqrt 12 a head, not in the Type A; one that stops
    # over several counts rounds each approach anew, which the Type A holds)
    filled = {**raw, "dof": 1, "s_arcsec": raw.get("s_arcsec") or 0.0,
              "head_s_arcsec": type_a[2]} if isinstance(raw, dict) else raw
    run = polygon_run(filled, source)
    if run is None:
        return None, ["no uncertainty budget: the points do not state their run"]
    face = face if face is not None else certificate_face(meta)
    notes = face_notes(face, declared)
    notes += unused(declared, POLYGON_RUNS_QUANTITIES, "a polygon step run's")
    budget = polygon_runs_budget(declared, run, type_a[0], type_a[1], face)
    notes.append(f"U per target: k sqrt(u_A(target)^2 + u_B^2), u_A over the approaches, "
                 f"u_B the budget's Type B rows, k = {budget.k:.3g} (nu_eff "
                 f"{fmt_dof(budget.nu_eff)})")
    return budget, notes


#: what the Type A of one run's readings spans
ONE_RUN_TYPE_A = ("the Type A is the scatter of the readings at each stop: it does not hold "
                  "re-setting, zero drift over the run or a closing reading at 360 deg")
#: ... and of one run closed by a reading at 360 deg (its drift row)
ONE_RUN_CLOSED = ("the Type A is the scatter of the readings at each stop: it does not hold "
                  "re-setting; the drift over the run is bounded by the closing reading at "
                  "360 deg (its row)")


def face_notes(face: Declaration | None, declared: dict[str, Declaration],
               closed: bool = False) -> list[str]:
    """What the polygon model leaves out (:func:`enctools.methods.polygon_terms.
    not_declared`; ``closed``: a closing reading bounds the drift), and what its polygon
    rows are: a certificate's u of corrected faces (no more), the rig's declaration of
    faces not corrected, or none."""
    left_out = not_declared(declared, closed)
    if face is not None:
        return [left_out]
    if "polygon" not in declared:
        return [left_out, "the rig declares no polygon face uncertainty: U leaves it out"]
    return [left_out,
            "the polygon's certified face errors are not applied to these points: its "
            "rows are the declared spread of the uncorrected faces, not a certificate's u "
            "of corrected faces (the GUM: a correction applied leaves its own u)"]


#: how the note of :func:`unused` starts: the laboratory's (its rig file's quantities by
#: their keys), left out of a certificate (report/document.py)
UNUSED_NOTE = "declared but not in "


def unused(declared: dict[str, Declaration], model: tuple[str, ...], what: str) -> list[str]:
    """The note naming the declarations a model does not use (none: no note)."""
    other = sorted(set(declared) - set(model))
    return [f"{UNUSED_NOTE}{what} model: {', '.join(other)}"] if other else []


def stop_scatter(pos_deg: np.ndarray, target_rad: np.ndarray) -> float:
    """The pooled standard deviation [arcsec] of the indicated positions of the stops at a
    target about their target's mean: how far the stops move between approaches, which
    dithers the heads' rounding from approach to approach (each position taken at the
    nearest target)."""
    target_deg = np.asarray(target_rad) * factor("rad", "deg")
    d = (pos_deg[:, None] - target_deg[None, :] + 180.0) % 360.0 - 180.0
    index = np.argmin(np.abs(d), axis=1)
    x = d[np.arange(pos_deg.size), index] * factor("deg", "arcsec")
    n = np.bincount(index, minlength=target_deg.size)
    dof = int(np.sum(np.maximum(n - 1, 0)))
    if dof == 0:
        return 0.0
    mean = np.bincount(index, weights=x, minlength=target_deg.size) / np.maximum(n, 1)
    return math.sqrt(float(np.sum((x - mean[index]) ** 2)) / dof)


def points_budget_into(s: Any, one_approach: bool, pos_deg: np.ndarray,
                       dev: np.ndarray | None = None) -> None:
    """The budget of a points section ``s`` (a ``sections.Section``) given to its curve:
    of one approach, every point's u is the budget's u_c (and, given ``dev``, the
    points' covariance statement from the same model through GTC:
    :mod:`enctools.report.covariance`); of several runs or directions, each target's u
    is sqrt(u_A(target)^2 + u_B^2); its U the budget's k u.
    ``pos_deg``: the points' indicated positions [deg] (of several approaches: how far
    their stops scatter, :func:`stop_scatter`), ``dev`` their deviations [arcsec], in the
    stream's order."""
    curve = s.curves[-1]
    type_a = None
    if not one_approach and curve.u is not None and curve.dof:
        type_a = (float(np.sqrt(np.mean(np.square(curve.u)))), float(curve.dof),
                  stop_scatter(pos_deg, curve.angle))
    budget, notes = points_budget(s.meta, s.source, one_approach, type_a=type_a)
    s.notes += notes
    if budget is None:
        return
    s.budget = budget
    if one_approach:
        curve.u = np.full(curve.values.shape, budget.u_c)
        if dev is not None:
            _covariance_into(s, pos_deg, dev)
    else:
        _add_type_b(curve, budget)
    curve.k = budget.k


def _covariance_into(s: Any, pos_deg: np.ndarray, dev: np.ndarray) -> None:
    """The covariance statement of one run's points (:mod:`enctools.report.covariance`)."""
    from enctools.report.covariance import statement

    run = polygon_run(s.meta["polygon_run"], s.source)
    if run is None:
        return
    st, note = statement(s.meta, rig_declarations(s.meta, s.source), run, pos_deg, dev,
                         s.source)
    s.covariance = st
    if note:
        s.notes.append(note)


def _add_type_b(curve: Any, budget: Budget) -> None:
    """A curve's Type A u per point with the budget's Type B rows added in quadrature."""
    u_b2 = math.fsum(c.u_arcsec ** 2 for c in budget.contributions if c.kind == "B")
    curve.u = np.sqrt(np.square(curve.u) + u_b2)


def step_run_into(s: Any, lsb_arcsec: float, heads: int, encoder: str,
                  reference: bool) -> None:
    """The budget of a step run's positioning deviation (its section ``s``'s last curve,
    a mean per target with its Type A u over the approaches): the rounding of the
    ``heads`` heads of ``encoder`` (1 count = ``lsb_arcsec``), and, when that encoder is a
    reference instrument (``reference``: not the axis' feedback), its accuracy as read
    (enc report applies no calibrated curve to a step run's readings:
    ``reference_encoder_uncorrected``) and alignment as the rig declares them
    (enc-rig(5)). Each target's U is then k sqrt(u_A(target)^2 + u_B^2) with the
    budget's k; without the reference's declaration no U at all (:func:`refuse`)."""
    curve = s.curves[-1]
    if curve.u is None or not curve.dof:
        return
    declared = rig_declarations(s.meta, s.source)
    quantity = reference_quantity(corrected=False)
    if reference and (quantity not in declared or not _of_encoder(declared[quantity],
                                                                   encoder)):
        refuse(s, [curve], quantity, f"encoder {encoder} is read without its calibrated "
                                     "curve", declared.get(quantity))
        return
    u_a = float(np.sqrt(np.mean(np.square(curve.u))))
    budget = step_run_budget(u_a, float(curve.dof),
                             resolution(lsb_arcsec, heads, f"encoder {encoder}"),
                             declared, reference)
    _add_type_b(curve, budget)
    curve.k = budget.k
    s.budget = budget
    used = ((quantity, "alignment") if reference else ()) + ("temperature",)
    s.notes += unused(declared, used, "a step run's")
    if "temperature" in declared:
        s.notes.append("temperature: no row; a uniform temperature leaves the angles of a "
                       "circular scale and of the axis unchanged")
    s.notes.append(f"U per target: k sqrt(u_A(target)^2 + u_B^2), u_A over the approaches, "
                   f"u_B the budget's Type B rows, k = {budget.k:.3g} (nu_eff "
                   f"{fmt_dof(budget.nu_eff)})")


def refuse(s: Any, curves: list[Any], quantity: str, how: str,
           other: Declaration | None = None) -> None:
    """No expanded uncertainty for ``curves`` of section ``s`` (their u dropped, no
    budget) when the reference encoder's row, ``quantity``, is not declared, or is
    declared for another encoder (``other``): a U without it would leave the reference's
    error out, and another declaration (the smaller calibration's U for an uncorrected
    reference, another encoder's row) never stands in for it. One note says why
    (enc-report(1), UNCERTAINTY BUDGET)."""
    for c in curves:
        c.u = None
    s.budget = None
    declares = f"declares [uncertainty.{quantity}] for encoder {other.encoder} only" \
        if other is not None else f"declares no [uncertainty.{quantity}]"
    s.notes.append(f"no expanded uncertainty U is stated: {how}, and the rig {declares} "
                   f"(enc-rig(5)), without which U would leave the reference's error out")


def comparison(meta: dict[str, Any], source: str, u_a_arcsec: float, dof: float
               ) -> tuple[Budget | None, str | None, Declaration | None]:
    """The budget of a comparison's curve (enc compare against a reference encoder's
    heads): ``u_a_arcsec`` the curve's Type A u (its rms along the curve) on ``dof``
    degrees of freedom and the reference encoder's row as the rig declares it
    (enc-rig(5)): ``reference_encoder`` when the comparison applied the reference's
    calibrated curve (its settings record ``ref_curve``), else
    ``reference_encoder_uncorrected``, of the reference's encoder (``ref_encoder``) when the
    declaration names one. (budget, quantity, the quantity's declaration); (None, None,
    None) for a curve not of enc compare; (None, quantity, its declaration or None) when
    that quantity is not declared, or declared for another encoder."""
    history = meta.get("history") or []
    settings = meta.get("settings")
    if not history or ": enc compare " not in str(history[-1]) \
            or not isinstance(settings, dict):
        return None, None, None
    quantity = reference_quantity(corrected=settings.get("ref_curve") is not None)
    row = rig_declarations(meta, source).get(quantity)
    if row is None or not _of_encoder(row, settings.get("ref_encoder")):
        return None, quantity, row
    return comparison_budget(u_a_arcsec, dof, row), quantity, row


def _of_encoder(declared: Declaration, reference: Any) -> bool:
    """Whether a reference encoder's row is of the reference encoder named ``reference``:
    the row names no encoder, or that one (a curve made before enctools recorded its
    reference's encoder, ``settings.ref_encoder``, takes the row as declared)."""
    return not declared.encoder or not isinstance(reference, str) or \
        reference == declared.encoder


def curve_budget_into(s: Any, curve: Any, dof: float) -> None:
    """The budget of a deviation curve with its u column: a self-calibration's
    (:func:`selfcal_into`) or a comparison's (:func:`comparison_into`)."""
    history = s.meta.get("history") or []
    if history and ": enc selfcal " in str(history[-1]):
        selfcal_into(s, curve, dof)
    else:
        comparison_into(s, curve, dof)


def selfcal_into(s: Any, curve: Any, dof: float) -> None:
    """A self-calibration's budget given to its section ``s``: its u column (enc selfcal:
    u = sqrt(s_mean^2 + b^2) per point, the dof Welch-Satterthwaite of both over the
    curve) split into the Type A over the R revolutions and the method's bound b, with
    the harmonics its heads cannot see (metadata ``blind``) bounded by their neighbours
    and the rig's declared head mounting (through the run's sensitivity, metadata
    ``mounting_arcsec_per_rad``) and temperature; each point's U is then
    k sqrt(u(point)^2 + u_B^2) with the budget's k and u_B of the rows added here."""
    settings = s.meta.get("settings")
    r = settings.get("revolutions") if isinstance(settings, dict) else None
    if curve.u is None or not isinstance(r, int) or r < 2 or not dof > 0:
        return
    total = float(np.mean(np.square(curve.u)))      # = var_a + b^2 (enc-selfcal(1))
    var_a = total if math.isinf(dof) else min(total, total * math.sqrt((r - 1) / dof))
    blind, notes = _blind(s.meta.get("blind"), curve)
    declared = rig_declarations(s.meta, s.source)
    mounting, note = _mounting(s.meta.get("mounting_arcsec_per_rad"), declared, s.source)
    notes += note
    budget = selfcal_budget(math.sqrt(var_a), r, math.sqrt(max(total - var_a, 0.0)), blind,
                            declared, mounting)
    added = math.fsum(c.u_arcsec ** 2 for c in budget.contributions[2:])
    curve.u = np.square(curve.u) + added
    row = next((c for c in budget.contributions if c.quantity == "head_mounting"), None)
    shape = _mounting_shape(s.meta.get("mounting_coefficients_arcsec_per_rad"), curve.angle,
                            mounting) if row is not None else None
    # the mounting's u at each point, not its rms (a long curve's stand-in of two values,
    # longcurves.budget, takes the rms: its envelope has no points to hold it at)
    if row is not None and shape is not None and shape.size == curve.u.size:
        curve.u += row.u_arcsec ** 2 * (np.square(shape) - 1.0)
        notes.append("head mounting: each point's U holds the mounting's u at that point "
                     "(the row gives its rms along the curve)")
    curve.u = np.sqrt(curve.u)
    curve.k = budget.k
    s.budget = budget
    if "temperature" not in declared:
        notes.append("temperature: not declared (enc-rig(5)); a uniform temperature leaves "
                     "the scale's angles unchanged")
    notes += unused(declared, SELFCAL_QUANTITIES, "a self-calibration's")
    s.notes += notes


def _mounting_shape(meta: Any, angle: np.ndarray, rms: float | None) -> np.ndarray | None:
    """The mounting's u at each point of a curve at ``angle`` [rad] over its rms along the
    curve: sqrt(sum_k c_k(theta)^2) / ``rms`` from each head's coefficients [arcsec per
    rad] (None: the run states none, or they do not match ``rms``)."""
    from enctools.data.truth import Series

    if not isinstance(meta, dict) or not meta or not rms:
        return None
    total = np.zeros(np.shape(angle))
    try:
        for c in meta.values():
            re, im = np.asarray(c["re"], np.float64), np.asarray(c["im"], np.float64)
            n = np.arange(re.size, dtype=np.float64)
            total += np.square(Series(n, re, -im)(np.asarray(angle, np.float64)))
    except (TypeError, KeyError, ValueError):
        return None
    shape = np.sqrt(total) / rms
    ok = np.all(np.isfinite(shape)) and abs(float(np.mean(np.square(shape))) - 1.0) < 0.05
    return shape if ok else None


def _mounting(meta: Any, declared: dict[str, Declaration], source: str
              ) -> tuple[float | None, list[str]]:
    """The run's sensitivity to the heads' mounting [arcsec per rad, root-sum-square over
    its heads] and the note when the rig declares no mounting or the run states none."""
    if "head_mounting" not in declared:
        return None, ["head mounting: not declared (enc-rig(5) [uncertainty.head_mounting]):"
                      " U leaves it out"]
    if not isinstance(meta, dict) or not meta:
        return None, ["head_mounting is declared but the self-calibration states no "
                      "sensitivity to it (made before it did): U leaves it out"]
    values = list(meta.values())
    if not all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
               and v >= 0 for v in values):
        msg = f"{source}: mounting_arcsec_per_rad must map heads to numbers >= 0"
        raise DataError(msg)
    return math.sqrt(math.fsum(float(v) ** 2 for v in values)), []


def _blind(blind: Any, curve: Any) -> tuple[tuple[tuple[int, ...], float] | None, list[str]]:
    """The blind orders of the band (the method set them to 0) and the root-sum-square of
    a bound on each: the largest amplitude of the curve's orders n +- 1, n +- 2 that are
    not blind [arcsec]; a note when none is blind or an order lies past the harmonics."""
    orders = sorted(int(n) for n in blind if isinstance(n, int) and n > 0) \
        if isinstance(blind, list) else []
    if not orders:
        return None, ["the harmonics of the band are all seen by the heads (no order "
                      "with W(n) = 0): no row for blind harmonics"]
    h = curve.harmonics
    if h is None or max(orders) + 2 > int(h.n.max()):
        return None, [f"blind harmonics n = {', '.join(map(str, orders))}: beyond the "
                      "report's harmonics, not bounded: U leaves them out"]
    amp = dict(zip(h.n.tolist(), h.amplitude.tolist(), strict=True))
    bound = [max(amp.get(n + d, 0.0) for d in (-2, -1, 1, 2) if n + d not in orders)
             for n in orders]
    return (tuple(orders), math.sqrt(math.fsum(b * b for b in bound))), []


def comparison_into(s: Any, curve: Any, dof: float) -> None:
    """A comparison's budget given to its section ``s`` (a ``sections.Section``): the
    curve's U from its Type A u and the reference encoder's declared u, with the
    budget's k (nothing when the curve has no u; no U at all when the rig does not
    declare the reference's row, :func:`refuse`)."""
    if curve.u is None or not np.all(np.isfinite(curve.u)) or dof <= 0:
        return
    u_a = float(np.sqrt(np.mean(np.square(curve.u))))
    budget, quantity, row = comparison(s.meta, s.source, u_a, dof)
    if quantity is None:
        return
    if budget is None:
        settings = s.meta["settings"]
        how = ("the reference encoder's calibrated curve was applied" if quantity ==
               "reference_encoder" else "the reference encoder is used without its "
               "calibrated curve")
        if settings.get("ref_encoder"):
            how = f"{how} (the reference's heads are of encoder {settings['ref_encoder']})"
        refuse(s, [curve], quantity, how, row)
        return
    u_ref = budget.contributions[1].u_arcsec
    s.budget = budget
    curve.u = np.sqrt(np.square(curve.u) + u_ref * u_ref)
    curve.k = budget.k
    s.notes.append(f"U per point: sqrt(u_A(point)^2 + u_ref^2) with the budget's k = "
                   f"{budget.k:.3g} (nu_eff {fmt_dof(budget.nu_eff)})")


def interpolation_into(s: Any) -> None:
    """The budget of a section's interpolation errors measured against the probes
    (their field metadata ``reference`` = probes) when the rig declares any of the
    probe's quantities (enc-rig(5)): one budget for its curves, at the largest of their
    magnitudes; each curve's U is then k sqrt(u(point)^2 + u_B^2)."""
    curves = [c for c in s.curves if c.domain == "period" and c.u is not None
              and c.extra.get("probes") == 1.0]
    rig = s.meta.get("rig")
    tables = rig.get("uncertainty") if isinstance(rig, dict) else None
    if not curves or not tables:
        return
    declared = declarations(tables, f"{s.source}: rig uncertainty")
    probes = rig.get("probes") or [{}]
    arm_mm = probes[0].get("arm_mm") if isinstance(probes[0], dict) else None
    if not isinstance(arm_mm, int | float) or not arm_mm > 0 or not any(
            q in declared for q in ("probe", "probe_arm", "temperature")):
        return
    u_a = float(np.sqrt(np.mean(np.concatenate([np.square(c.u) for c in curves]))))
    psi = max(float(np.max(np.abs(c.values))) for c in curves)
    budget = probe_interpolation_budget(u_a, math.inf, psi, arm_mm * 1e-3, declared)
    u_b2 = sum(r.u_arcsec ** 2 for r in budget.contributions[1:])
    for c in curves:
        c.u = np.sqrt(np.square(c.u) + u_b2)
        c.k = budget.k
    s.budget = budget
    s.notes.append(f"U per point of the curves against the probes: k sqrt(u_A(point)^2 + "
                   f"u_B^2), k = {budget.k:.3g}; the probes' rows at the largest |deviation| "
                   f"{psi:.3g} arcsec")


def rig_declarations(meta: dict[str, Any], source: str) -> dict[str, Declaration]:
    """The checked Type B declarations of the rig a stream's metadata records (none: {})."""
    rig = meta.get("rig")
    tables = rig.get("uncertainty") if isinstance(rig, dict) else None
    return declarations(tables, f"{source}: rig uncertainty") if tables else {}


def stated_dof(field_meta: dict[str, Any]) -> float:
    """The degrees of freedom an uncertainty column's field metadata state (``dof``;
    infinite when they state none)."""
    dof = field_meta.get("dof")
    return math.inf if dof is None or dof == "inf" else float(dof)


def certificate_face(meta: dict[str, Any]) -> Declaration | None:
    """The polygon's face uncertainty from the certificate the points were corrected with
    (enc points' polygon certificate; GUM 3.2.4: the certified errors applied, their u
    remains): its largest standard uncertainty [arcsec], Type A on the certificate's dof
    where it states one (enc closure's), else B (None: no certificate applied)."""
    u = points_face_uncertainty(meta)
    if u is None:
        return None
    cert = meta["polygon_certificate"]
    number = cert.get("certificate")
    source = f"polygon certificate {number}" if isinstance(number, str) and number else \
        "polygon certificate"
    kind, dof = certificate_evaluation(cert)
    return Declaration("polygon", float(u.max()), "arcsec", "normal", dof=dof, source=source,
                       kind=kind)


def budget_dict(budget: Budget) -> dict[str, Any]:
    """The budget for JSON: each uncertainty's key ends in _arcsec; a value in its unit."""
    rows = [{"name": c.name, "source": c.source, "type": c.kind, "distribution": c.distribution,
             "value": c.value, "unit": c.unit, "divisor": c.divisor,
             "sensitivity_arcsec_per_unit": c.sensitivity, "u_arcsec": c.u_arcsec,
             "dof": None if math.isinf(c.dof) else c.dof} for c in budget.contributions]
    return {"contributions": rows, "u_c_arcsec": budget.u_c,
            "nu_eff": None if math.isinf(budget.nu_eff) else budget.nu_eff,
            "k": budget.k, "U_arcsec": budget.U, "coverage": budget.coverage}


def budget_lines(budget: Budget, unit: str = "arcsec") -> list[str]:
    """The budget as text lines: u, u_c and U in ``unit`` (the unit the report is read in), each
    declared value in its own unit."""
    f = factor("arcsec", unit)
    lines = [f"  uncertainty budget (GUM) [{unit}]: u_c {fmt_u(budget.u_c * f, unit)}  nu_eff "
             f"{fmt_dof(budget.nu_eff)}  k {budget.k:.3f}  U {fmt_u(budget.U * f, unit)} "
             f"({budget.coverage:.0%})"]
    for c in budget.contributions:
        lines.append(f"    {c.kind} {c.name}: {c.value:.4g} {c.unit} {c.distribution} "
                     f"/{c.divisor:.4g} x c {c.sensitivity:.4g} -> u {fmt_u(c.u_arcsec * f, unit)}"
                     f" (dof {fmt_dof(c.dof)}){'; ' + c.source if c.source else ''}")
    return lines
