"""The report as JSON for machines (enc report's JSON summary; the nightly history).

The figures have the keys every command's JSON summary gives them
(:mod:`enctools.data.summaries`, enc-streams(5) SUMMARIES): each number's key ends in
its unit (``pp_arcsec``, ``pp_nm`` for radial motion); NaN becomes null.
"""

from __future__ import annotations

from typing import Any

from enctools.data import summaries
from enctools.data.summaries import clean, figure_dict
from enctools.report import historydigest
from enctools.report.budget import budget_dict
from enctools.report.display import in_length
from enctools.report.historydigest import LISTED
from enctools.report.results import correction_of, results
from enctools.report.sections import Curve, Section, SpectrumRows
from enctools.report.summary import Report
from enctools.report.vdi3441 import Vdi3441


def curve_dict(c: Curve, top: int = 5) -> dict[str, Any]:
    u = c.unit
    d: dict[str, Any] = {"name": c.name, "unit": u, "role": c.role}
    d |= figure_dict(c.figures, u)
    d["std_convention"] = ("Bessel, n-1, over the n values, one per position modulo "
                           "360 deg") if not in_length(c) else (
        "Bessel, n-1, over the n values, one per phase within the signal period")
    for k, v in c.extra.items():  # period_arcsec
        if k != "probes":           # a flag of the budget's, not a figure
            d[k] = v
    if c.head:
        d["head"] = c.head
    if c.u is not None:
        d[f"expanded_u_max_{u}"] = c.U_max
        d["coverage_k"] = c.k
    if c.harmonics is not None:
        h = c.harmonics.largest(top)
        d["harmonics"] = [{"n": int(n), f"amplitude_{u}": float(a), "phase_rad": float(p)}
                          for n, a, p in zip(h.n, h.amplitude, h.phase, strict=True)]
        if c.harmonics.limit is not None:
            d["harmonics_limit_n"] = c.harmonics.limit
            d["harmonics_left_out"] = c.harmonics.left_out
            d["harmonics_positions"] = c.harmonics.positions
            d["harmonics_arc_deg"] = c.harmonics.arc_deg
        if c.harmonics.note():
            d["harmonics_note"] = c.harmonics.note()
    return d


def spectrum_dict(sp: SpectrumRows, top: int) -> dict[str, Any]:
    rows = []
    for i in sp.largest(top):
        r = {"n": int(sp.n[i]), "amplitude_arcsec": float(sp.amplitude[i]),
             "phase_rad": float(sp.phase[i])}
        if sp.u is not None:
            r["expanded_u_arcsec"] = sp.k * float(sp.u[i])
        if sp.transfer is not None:
            r["transfer"] = float(sp.transfer[i])
        rows.append(r)
    out: dict[str, Any] = {"curve": sp.curve, "harmonics": rows}
    if sp.u is not None:
        out["coverage_k"] = sp.k
    return out


def vdi_dict(vdi: Vdi3441) -> dict[str, Any]:
    """VDI/DGQ 3441 in the summary vocabulary: every figure's key ends in its unit."""
    rows = [{k if k.startswith(("position_", "n_")) else f"{k}_{vdi.unit}": v
             for k, v in row.items()} for row in vdi.table()]
    return {"axis": {f"{k}_{vdi.unit}": v for k, v in vdi.axis().items()}, "positions": rows}


def section_dict(s: Section, top: int, model: Curve | None = None) -> dict[str, Any]:
    d: dict[str, Any] = {"source": s.source, "kind": s.kind, "rig": s.rig_name,
                         "domain": s.domain, "info": s.info,
                         "curves": [curve_dict(c, top) for c in s.curves]}
    tables = results(s, model)
    if tables:
        d["results"] = [r.to_dict() for r in tables]
    if s.spectra:
        d["spectra"] = [spectrum_dict(sp, top) for sp in s.spectra]
    if s.iso is not None:
        d["iso230_2"] = {"unit": s.iso.unit, "axis": s.iso.axis(),
                         "positions": s.iso.table(), "warnings": s.iso.warnings}
    if s.vdi is not None:
        d["vdi3441"] = vdi_dict(s.vdi)
    if s.budget is not None:
        d["budget"] = budget_dict(s.budget)
    if s.covariance is not None:
        from enctools.report.covariance import as_dict

        d["covariance"] = as_dict(s.covariance)
    if s.notes:
        d["notes"] = s.notes
    d["history"] = s.history
    return d


def report_dict(report: Report, failures: list[str] | None = None) -> dict[str, Any]:
    top = int(report.settings.get("top_harmonics", 5))
    model = correction_of(report.sections)
    d: dict[str, Any] = {"sections": [section_dict(s, top, model) for s in report.sections],
                         "settings": report.settings}
    if report.history is not None and report.history.runs > LISTED:
        # a long history: the last runs listed and a summary per rig and month
        digest = historydigest.digest(report.history, binned=False)
        d["history"] = digest.last
        d["history_summary"] = digest.to_dict()
    elif report.history is not None:
        d["history"] = report.history.to_records()
    if failures is not None:
        d["thresholds"] = {"exceeded": failures, "ok": not failures}
    return clean(d)


def to_json(report: Report, failures: list[str] | None = None) -> str:
    return summaries.to_json(report_dict(report, failures))
