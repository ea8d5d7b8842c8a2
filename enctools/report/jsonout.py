"""The report as JSON for machines (``enc report --json``; the nightly history).

Numbers are plain floats in the units named by the keys' ``unit`` fields (arcsec,
nm, count, deg); NaN becomes null.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from enctools.report.sections import Curve, Section, SpectrumRows
from enctools.report.summary import Report


def _clean(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, np.ndarray):
        return _clean(x.tolist())
    if isinstance(x, (np.floating, float)):
        return None if not math.isfinite(float(x)) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


def curve_dict(c: Curve, top: int = 5) -> dict[str, Any]:
    d: dict[str, Any] = {"name": c.name, "unit": c.unit, "role": c.role}
    d |= c.figures.to_dict()
    d["std_convention"] = "Bessel, n-1, over the n values as given (seed 001 eq. 8)"
    d |= c.extra
    if c.head:
        d["head"] = c.head
    if c.u is not None:
        d["U_max"] = c.U_max
        d["k"] = 2
    if c.harmonics is not None:
        d["harmonics"] = c.harmonics.largest(top).rows()
    return d


def spectrum_dict(sp: SpectrumRows, top: int) -> dict[str, Any]:
    rows = []
    for i in sp.largest(top):
        r = {"n": int(sp.n[i]), "amplitude": float(sp.amplitude[i]), "phase": float(sp.phase[i])}
        if sp.u is not None:
            r["U"] = 2.0 * float(sp.u[i])
        if sp.transfer is not None:
            r["transfer"] = float(sp.transfer[i])
        rows.append(r)
    return {"curve": sp.curve, "harmonics": rows}


def section_dict(s: Section, top: int) -> dict[str, Any]:
    d: dict[str, Any] = {"source": s.source, "kind": s.kind, "rig": s.rig_name,
                         "domain": s.domain, "info": s.info,
                         "curves": [curve_dict(c, top) for c in s.curves]}
    if s.spectra:
        d["spectra"] = [spectrum_dict(sp, top) for sp in s.spectra]
    if s.iso is not None:
        d["iso230_2"] = {"axis": s.iso.axis(), "positions": s.iso.table(),
                         "warnings": s.iso.warnings}
    if s.notes:
        d["notes"] = s.notes
    d["history"] = s.history
    return d


def report_dict(report: Report, failures: list[str] | None = None) -> dict[str, Any]:
    top = int(report.settings.get("top_harmonics", 5))
    d: dict[str, Any] = {"sections": [section_dict(s, top) for s in report.sections],
                         "settings": report.settings}
    if report.history is not None:
        d["history"] = report.history.to_records()
    if failures is not None:
        d["thresholds"] = {"exceeded": failures, "ok": not failures}
    return _clean(d)


def to_json(report: Report, failures: list[str] | None = None) -> str:
    return json.dumps(report_dict(report, failures), indent=1, allow_nan=False)
