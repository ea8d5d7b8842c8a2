"""What the HTML and the PDF report say, as plain data for the one template.

:func:`build` turns a report (its angle errors already in the unit a person reads),
the failed checks, the drawn plots and the laboratory's certificate fields into the
dict the template ``templates/certificate.html.j2`` renders: text, tables (a header
and rows of text), figures (PNG bytes and a caption). Both documents are rendered
from it (:func:`render`), so they say the same thing.

Every number passes through :func:`enctools.report.display.fmt` (the unit's
resolution; no rounding noise); internal citations of the two papers ("seed 001") are
replaced by their reference numbers. Every text, whatever file it comes from, is shown
with the characters that read other than they are escaped (``\u202e``;
:func:`enctools.data.text.escaped`).
"""

from __future__ import annotations

import base64
import datetime as _dt
import functools
import re
import struct
from collections.abc import Sequence
from typing import Any

from enctools import __version__
from enctools.data.header import output_time
from enctools.data.readings import rig_encoders
from enctools.data.text import escaped_all
from enctools.report import budgettable, citations
from enctools.report.budget import UNUSED_NOTE
from enctools.report.certificate import Certificate
from enctools.report.display import in_length, label, phase_text
from enctools.report.drawings import Drawings
from enctools.report.numbers import figures, fmt, fmt_u, group, table_decimals
from enctools.report.results import correction_of, results
from enctools.report.sections import Curve, Section
from enctools.report.summary import Report
from enctools.units import DEG

#: the template of both documents (package data of enctools.report)
TEMPLATE = "certificate.html.j2"
_SEED = re.compile(r"\bseeds? (00[01])\b")


def customer_text(text: Any) -> str:
    """``text`` with the papers' internal names ("seed 001") as reference numbers."""
    return _SEED.sub(lambda m: citations.cite(m.group(1)), str(text))


def table(header: Sequence[str], rows: Sequence[Sequence[Any]], left: int = 1,
          caption: str = "", cite: bool = True) -> dict[str, Any]:
    """A table for the template: text cells, the first ``left`` columns left-aligned,
    relative column widths [%] from the longest cell of each column. ``cite``: the
    data's internal citations become reference numbers (not in the lab's own fields)."""
    cells = [[customer_text(v) if cite else str(v) for v in r] for r in rows]
    head = [str(h) for h in header]
    cols = max([len(head)] + [len(r) for r in cells])
    longest = [max([round(1.4 * len(head[i])) if i < len(head) else 0]   # bold heads
                   + [len(r[i]) for r in cells if i < len(r)]) for i in range(cols)]
    weights = [min(n, 30) + 4 for n in longest]   # characters, and the cell's padding
    total = sum(weights) or 1
    widths = [max(1, round(100 * w / total)) for w in weights]
    return {"header": head, "rows": cells, "left": left, "widths": widths,
            "caption": caption}


#: the widest and the tallest a figure is laid out on an A4 page [pt]: the text's width
#: (180 mm), and a square plot (polar, Lissajous) no taller than 105 mm
FIGURE_WIDTH_PT, FIGURE_HEIGHT_PT = 510, 300


def _figure(png: bytes, caption: str) -> dict[str, Any]:
    """A plot for the template: its data URI, caption and laid-out width [pt]."""
    wide, high = struct.unpack(">II", png[16:24])     # the PNG's IHDR: width, height [px]
    width = min(FIGURE_WIDTH_PT, round(FIGURE_HEIGHT_PT * wide / max(high, 1)))
    return {"src": "data:image/png;base64," + base64.b64encode(png).decode(),
            "caption": caption, "width": width, "percent": round(100 * width / FIGURE_WIDTH_PT)}


# ------------------------------------------------------------------ the parts


def _identity(cert: Certificate | None, report: Report, now: _dt.datetime
              ) -> list[list[str]]:
    """Rows (label, value) of who and what: only what the certificate file gives."""
    rows: list[list[str]] = []
    if cert is not None:
        for key, name in (("name", "Customer"), ("address", "Customer address"),
                          ("order", "Order")):
            _add(rows, name, cert.get("customer", key))
        item = cert.table("item")
        _add(rows, "Item", item.get("description"))
        maker = " / ".join(str(item[k]) for k in ("manufacturer", "model") if item.get(k))
        _add(rows, "Manufacturer / model", maker)
        _add(rows, "Serial number", item.get("serial"))
        _add(rows, "Condition on receipt", item.get("condition"))
        _add(rows, "Date received", item.get("received"))
    calibrated = (cert.get("calibration", "date") if cert else None) or _data_date(report)
    _add(rows, "Date of calibration", calibrated)
    issued = (cert.get("certificate", "issued") if cert else None) or now.date()
    _add(rows, "Date of issue", issued)
    if cert is not None:
        _add(rows, "Location", cert.get("calibration", "location"))
        _add(rows, "Procedure", cert.get("calibration", "procedure"))
        _add(rows, "Operator", cert.get("calibration", "operator"))
    return rows


def _add(rows: list[list[str]], name: str, value: Any) -> None:
    if value not in (None, ""):
        rows.append([name, value.isoformat() if isinstance(value, _dt.date) else str(value)])


def _data_date(report: Report) -> str | None:
    """The day of the earliest recording the inputs' history names (UTC), or None."""
    days = sorted(line[:10] for s in report.sections for line in s.history[:1]
                  if re.match(r"\d{4}-\d\d-\d\d", line))
    return f"{days[0]} (as recorded in the data)" if days else None


def _environment(cert: Certificate | None) -> list[list[str]]:
    env = cert.table("environment") if cert else {}
    rows = []
    for key, name, unit in (("air_temperature_c", "Air temperature", "°C"),
                            ("material_temperature_c", "Temperature of the item", "°C"),
                            ("humidity_percent", "Relative humidity", "%")):
        if key in env:
            rows.append([name, f"{fmt(env[key], decimals=1)} {unit}"])
    if env.get("remarks"):
        rows.append(["Remarks", env["remarks"]])
    return rows


def _references(cert: Certificate | None) -> dict[str, Any] | None:
    if cert is None or not cert.references:
        return None
    keys = ("name", "serial", "certificate", "due", "traceability")
    rows = [[_shown(r.get(k)) for k in keys] for r in cert.references]
    return table(["reference standard", "serial", "certificate", "due", "traceability"],
                 rows, left=5, cite=False)


def _shown(value: Any) -> str:
    if value is None:
        return "–"
    return value.isoformat() if isinstance(value, _dt.date) else str(value)


def _summary(report: Report) -> dict[str, Any] | None:
    if not report.sections:
        return None
    rows = []
    for s, c in report.curves():
        f, u = c.figures, c.unit
        d = figures(f, u)     # as the text report's line
        rows.append([_name(s.source), c.name, label(u), f.n, fmt(f.pp, u, d),
                     fmt(f.plus_minus, u, d), fmt(f.mean, u, d), fmt(f.std, u, d),
                     fmt_u(c.U_max, u),
                     fmt(c.k, decimals=2) if c.u is not None else "–"])
    if not rows and all(s.info.get("axis") == "linear" for s in report.sections):
        return None     # a linear axis's section: its figures, no curve (report/linear.py)
    return table(["result" if report.sections[0].source.startswith("Result ") else "input",
                  "curve", "unit", "n", "p-p", "±", "mean", "s", "U max", "k"], rows, left=3)


def _results(report: Report) -> list[dict[str, Any]]:
    """The results per calibrated position of every input (:mod:`enctools.report.
    results`): a table each, the same numbers as the text and the JSON."""
    out = []
    model = correction_of(report.sections)
    for s in report.sections:
        for res in results(s, model):
            out.append({"heading": f"{_name(s.source)}: {res.curve}",
                        "table": table(res.header(), res.cells(), left=0,
                                       caption=res.note())})
    return out


#: each threshold's field in a specification's words, and its unit
LIMIT_WORDS = {"max_pp": ("peak-to-peak deviation", "arcsec"),
               "max_std": ("standard deviation s of the deviation", "arcsec"),
               "max_abs": ("largest |deviation|", "arcsec"),
               "max_u": ("expanded uncertainty U", "arcsec"),
               "max_radial_pp": ("peak-to-peak radial error motion", "nm"),
               "max_harmonic": ("amplitude of harmonic", "arcsec"),
               "max_iso": ("ISO 230-2 figure", "arcsec"),
               "max_vdi": ("VDI/DGQ 3441 figure", "arcsec")}


def limits_in_words(limits: dict[str, Any]) -> str:
    """The limits of a conformity statement as a specification states them:
    "peak-to-peak deviation ≤ 5 arcsec; amplitude of harmonic 4 ≤ 1 arcsec"."""
    parts = []
    for key, value in limits.items():
        words, unit = LIMIT_WORDS.get(key, (key, "arcsec"))
        if isinstance(value, dict):
            parts += [f"{words} {n} ≤ {x:g} {unit}" for n, x in value.items()]
        else:
            parts.append(f"{words} ≤ {value:g} {unit}")
    return "; ".join(parts)


def _conformity(report: Report, failures: Sequence[str] | None,
                cert: Certificate | None = None) -> dict[str, Any] | None:
    """The conformity statement and its decision rule, when limits were given: the
    specification the certificate file names, and its limits in words."""
    limits = report.settings.get("thresholds") or {}
    if not limits:
        return None
    spec = cert.table("specification") if cert is not None else {}
    named = ", ".join(str(spec[k]) for k in ("name", "limits") if spec.get(k))
    return {"limits": limits_in_words(limits), "specification": named,
            "failures": list(failures or []),
            "rule": (f"Decision rule: simple acceptance (ILAC-G8 {citations.cite('ilac')}, "
                     "4.2.1; no guard "
                     "band): a figure conforms when its measured value does not exceed "
                     "its limit. The expanded uncertainty stated in this document is not "
                     "added to the measured value, so a value closer to a limit than its "
                     "uncertainty may conform or not (shared risk). Limits in arcsec "
                     "(radial motion in nm).")}


def _uncertainty(report: Report) -> dict[str, Any] | None:
    """The budget of every input that has one (a table each), and the inputs whose
    results carry a Type A uncertainty, named once under one statement."""
    budgets, type_a = [], []
    for s in report.sections:
        if s.budget is not None:
            budgets.append({"source": s.source,
                            "table": budgettable.budget_table(s.budget, s.unit, table),
                            "totals": table(["", ""], budgettable.totals(s.budget, s.unit)),
                            "covariance": _covariance(s)})
        elif any(c.u is not None for c in s.curves) or any(sp.u is not None
                                                           for sp in s.spectra):
            type_a.append(_name(s.source))
    none = [_name(s.source) for s in report.sections if s.budget is None
            and _name(s.source) not in type_a and s.kind in ("deviations", "points", "readings")
            and s.info.get("axis") != "linear"]
    if not budgets and not type_a and not none:
        return None
    return {"budgets": budgets, "type_a": ", ".join(type_a),
            "statement": budgettable.TYPE_A.format(gum=citations.cite("gum")) if type_a else "",
            "none": ", ".join(none)}


def _covariance(s: Any) -> list[str]:
    """The sentences of a section's covariance statement (none: [])."""
    if s.covariance is None:
        return []
    from enctools.report.covariance import sentences

    return sentences(s.covariance, s.unit, lambda v, u: f"{fmt_u(v, u)} {label(u)}")


def _name(source: str) -> str:
    """An input as a table names it: its file name (stdin as "-")."""
    return source.rsplit("/", 1)[-1] or source


def _rigs(report: Report, certificate: bool) -> list[dict[str, Any]]:
    """The measuring set-up of each rig: its encoders and heads. A certificate names
    neither the rig nor its description, nor the rig's model names: the item is named
    as the certificate file says."""
    rigs = {s.rig_name: s.meta for s in report.sections if s.rig_name}
    out = []
    for name, meta in rigs.items():
        rig = meta["rig"]
        rows = []
        for enc in rig_encoders(meta):
            heads = ", ".join(f"{h.name} {h.angle / DEG:g}°" for h in enc.heads)
            rows.append([enc.name] + ([] if certificate else [enc.model])
                        + [heads, enc.periods_per_rev, enc.interpolation, enc.diameter_mm])
        extras = [k for k in ("polygon", "autocollimator", "probes") if rig.get(k)]
        head = ["encoder"] + ([] if certificate else ["model"]) + [
            "heads (nominal angle)", "periods/rev", "interpolation", "diameter [mm]"]
        out.append({"name": "" if certificate else f"Rig {name}",
                    "description": "" if certificate else customer_text(
                        rig.get("description", "")),
                    "encoders": table(head, rows, left=3 - certificate) if rows else None,
                    "also": ", ".join(extras)})
    return out


def _harmonics(curves: Sequence[Curve], top: int) -> dict[str, Any] | None:
    rows = []
    for c in curves:
        if c.harmonics is None:
            continue
        h = c.harmonics.largest(top)
        if not h.n.size:        # none resolvable: the notes say why
            continue
        d = group(h.amplitude, c.unit)
        cells = [f"n={int(n)}: {fmt(float(a), c.unit, d)} @ {phase_text(c, float(p), '°')}"
                 for n, a, p in zip(h.n, h.amplitude, h.phase, strict=True)]
        rows.append([c.name, label(c.unit)] + cells)
    if not rows:
        return None
    shown = max(len(r) for r in rows) - 2        # the columns of the most harmonics listed
    rows = [r + [""] * (shown + 2 - len(r)) for r in rows]
    return table(["curve", "unit"] + [f"#{i + 1}" for i in range(shown)], rows, left=2,
                 caption="Largest harmonics A cos(n x + p): order n, amplitude A, phase p.")


def _iso(s: Section) -> dict[str, Any] | None:
    iso = s.iso
    if iso is None:
        return None
    u = iso.unit
    axis = iso.axis()
    cols, keys = [f"position [{iso.position_unit}]"], []
    for d, arrow, name in ((iso.up, "↑", "up"), (iso.down, "↓", "down")):
        if d is not None:
            cols += [f"mean {arrow}", f"s {arrow}", f"R {arrow}", f"n {arrow}"]
            keys += [f"mean_{name}", f"s_{name}", f"R_{name}", f"n_{name}"]
    if iso.is_bidirectional:
        cols += ["mean", "B_i", "R_i"]
        keys += ["mean", "B", "R"]
    at = f"position_{iso.position_unit}"
    listed = iso.table()
    dt = table_decimals(listed, u)
    cells = [[f"{r[at]:.3f}"] + [str(r[k]) if k.startswith("n_") else fmt(r[k], u, dt)
                                 for k in keys] for r in listed]
    da = group(list(axis.values()), u)
    return {"title": "ISO 230-2 (2014)",
            "axis": table(list(axis), [[fmt(v, u, da) for v in axis.values()]], left=0),
            "note": (f"[{label(u)}] R_i = 4 s_i (±2 s); bidirectional R = max R_i with "
                     "R_i = max(2 s_i↑ + 2 s_i↓ + |B_i|, R_i↑, R_i↓); E over both "
                     "directions' mean deviations; M = range of the mean deviations; "
                     "A = max(mean + 2s) − min(mean − 2s) over both directions; "
                     "B = max |B_i|."),
            "table": table(cols, cells, left=0), "warnings": list(iso.warnings)}


def _vdi(s: Section) -> dict[str, Any] | None:
    vdi = s.vdi
    if vdi is None:
        return None
    u = vdi.unit
    axis = vdi.axis()
    keys = ("mean_up", "s_up", "mean_down", "s_down", "mean", "U", "Ps")
    at = f"position_{vdi.position_unit}"
    listed = vdi.table()
    d, da = table_decimals(listed, u), group(list(axis.values()), u)
    rows = [[f"{r[at]:.3f}"] + [fmt(r[k], u, d) for k in keys]
            + [r["n_up"], r["n_down"]] for r in listed]
    return {"title": "VDI/DGQ 3441 (1977)",
            "axis": table(list(axis), [[fmt(v, u, da) for v in axis.values()]], left=0),
            "note": (f"[{label(u)}] x_j = (x↑ + x↓)/2; U_j = |x↑ − x↓|; Ps_j = 6 (s↑ + s↓)/2 "
                     "(±3 s); Pa = range of x_j; "
                     "P = max(x_j + (U_j + Ps_j)/2) − min(x_j − (U_j + Ps_j)/2)."),
            "table": table([f"position [{vdi.position_unit}]", "x↑", "s↑", "x↓", "s↓", "x_j",
                            "U_j", "Ps_j", "n↑", "n↓"], rows, left=0),
            "warnings": []}


def _value(v: Any) -> str:
    """A value of a section's facts: a float to 4 decimals, anything else as it is."""
    return fmt(v, decimals=4) if isinstance(v, float) else str(v)


#: the kinds whose facts are the laboratory's (a model's settings and internals, a
#: table's layout): a certificate shows their curve, not these
INTERNAL_KINDS = ("model", "rom")


def _section(s: Section, top: int, drawings: Drawings, certificate: bool) -> dict[str, Any]:
    notes = [customer_text(n) for n in s.notes
             if not (certificate and n.startswith(UNUSED_NOTE))]  # the rig file's, by key
    notes += [f"{c.name}: {c.harmonics.note()}" for c in s.curves
              if c.harmonics is not None and c.harmonics.note()]
    info = {} if certificate and s.kind in INTERNAL_KINDS else s.info
    return {"heading": f"{s.source} — {citations.kind_name(s.kind)}",
            "info": table(["", ""], [[k, _value(v)] for k, v in info.items()], left=2)
            if info else None,
            "figures": [_figure(png, caption) for caption, png in drawings.section(s)],
            "harmonics": _harmonics(s.curves, top),
            "standard": _iso(s) or _vdi(s), "notes": notes}


def _comparison(report: Report, drawings: Drawings) -> list[dict[str, Any]]:
    """Inputs of one kind carrying the same curve over a turn (before / after)."""
    out = []
    for kind, pairs in drawings.comparisons():
        unit = pairs[0][1].unit
        rows = [[name, fmt(c.figures.pp, unit, figures(c.figures, unit)),
                 fmt(c.figures.std, unit, figures(c.figures, unit))] for name, c in pairs]
        first = pairs[0][1].figures.std
        ratios = [f"{name}: s of the first / s of this = {fmt(first / c.figures.std, decimals=2)}"
                  for name, c in pairs[1:] if c.figures.std > 0]
        out.append({"heading": f"Comparison of the {citations.kind_name(kind)} inputs "
                               "(before / after compensation)",
                    "figure": _figure(drawings.comparison(kind),
                                      "Deviation of every input on one plot (the first: before)"),
                    "table": table(["input", f"p-p [{label(unit)}]", f"s [{label(unit)}]"],
                                   rows),
                    "ratios": ratios})
    return out


def _history(report: Report, drawings: Drawings) -> dict[str, Any] | None:
    h = report.history
    if h is None:
        return None
    out: dict[str, Any] = {"heading": f"Nightly history — {h.folder + h.filters_text()}",
                           "text": f"{h.runs} run(s)" + (
                               f"; {len(h.skipped)} unreadable file(s) skipped"
                               if h.skipped else "") + ".",
                           "figure": None, "table": None}
    png = drawings.history()
    if png is not None:
        u = h.unit
        long = drawings.history_digest()
        out["figure"] = _figure(png, "p-p, s and drift of every run (× marks runs that failed)"
                                if long is None else "p-p, s and drift, the smallest and "
                                "largest of each bin of time (× marks bins with a failed run)")
        if long is not None:
            shown = long.groups[-12:]   # every rig and month in the JSON summary
            out["text"] += (f" The last {len(long.last)} are listed. Per rig and month"
                            + (f" (the last {len(shown)} of {len(long.groups)})"
                               if len(shown) < len(long.groups) else "") + ": "
                            + "; ".join(f"{g['rig']} {g['month']}: {g['runs']} run(s), "
                                        f"{g['failed']} failed" for g in shown) + ".")
        rows = [[r["time"], r["rig"] or "–", r["status"] or "–", fmt(r["pp"], u),
                 fmt(r["std"], u), fmt(r["drift_max"], u), fmt(r["tolerance"], u)]
                for r in (h.to_records() if long is None else long.last)]
        b = f" [{label(u)}]"
        out["table"] = table(["time (UTC)", "rig", "status", "p-p" + b, "s" + b, "drift" + b,
                              "tolerance" + b], rows, left=3)
    return out


def _approval(cert: Certificate | None) -> dict[str, str] | None:
    if cert is None:
        return None
    given = cert.table("approval")
    return {"name": given.get("name", ""), "function": given.get("function", "")}


def _deviation_words(report: Report, unit: str) -> str:
    """What the summary's deviation is, in which unit (``unit``, the report's angle's):
    a report of linear scales' interpolation errors alone is in nm (enc-interp-check(1))."""
    curves = [c for _, c in report.curves()]
    if not curves or not all(in_length(c) for c in curves):
        return f"indicated − true angle, in {unit}"
    return "a linear scale's interpolation error, read − true position within its signal " \
           "period, in nm"


def build(report: Report, failures: Sequence[str] | None, title: str | None,
          drawings: Drawings, cert: Certificate | None = None) -> dict[str, Any]:
    """The template's data of the whole document (see the module's docstring)."""
    now = _dt.datetime.fromtimestamp(output_time(), _dt.UTC)
    unit = str(report.settings.get("unit", "arcsec"))
    rigs = [s.rig_name for s in report.sections if s.rig_name]
    default = "Calibration certificate" if cert else "Calibration report" + (
        f" — {', '.join(dict.fromkeys(rigs))}" if rigs else "")
    if cert is not None and cert.get("certificate", "title"):
        default = cert.get("certificate", "title")
    with citations.collecting() as cited:  # numbered as a reader meets them
        parts = _in_reading_order(report, failures, drawings, cert, now)
    # every text shown as it is: what reads other than it is (a bidi control, a line
    # separator from a file) escaped, in the HTML, the PDF and its page headers alike
    return escaped_all({  # a certificate keeps its title; --title is then its subject line
        "title": default if cert else title or default,
        "subtitle": title if cert and title else "", "number": cert.number if cert else "",
        "made": "" if cert else f"{now:%Y-%m-%d %H:%M} UTC, enctools {__version__}, "
                                f"{len(report.sections)} input(s)",
        "laboratory": cert.table("laboratory") if cert else {},
        "deviation": _deviation_words(report, label(unit)),  # the summary's, and its unit
        "statement": cert.get("certificate", "statement") if cert else None,
        **parts,
        "record": [] if cert else [{"source": s.source, "lines": s.history or ["(none)"]}
                                   for s in report.sections],
        "unit": label(unit), "papers": citations.listed(cited),
        "approval": _approval(cert),
    })


def _in_reading_order(report: Report, failures: Sequence[str] | None, drawings: Drawings,
                      cert: Certificate | None, now: _dt.datetime) -> dict[str, Any]:
    """The template's parts that may cite a reference, made in the order the template
    shows them (:func:`citations.cite` numbers the references as they are first made)."""
    parts: dict[str, Any] = {
        "identity": table(["", ""], _identity(cert, report, now), left=2, cite=False),
        "environment": _environment(cert), "rigs": _rigs(report, cert is not None),
        "methods": citations.rows(report, table, settings=cert is None),
        "references_std": _references(cert),
        "summary": _summary(report), "results": _results(report),
        "conformity": _conformity(report, failures, cert),
        # "Per GUM [n]" stands before the first budget's table
        "gum_budgets": citations.cite("gum") if any(s.budget is not None
                                                    for s in report.sections) else ""}
    parts["uncertainty"] = _uncertainty(report)
    parts["comparisons"] = _comparison(report, drawings)
    parts["sections"] = [_section(s, drawings.top, drawings, cert is not None)
                         for s in report.sections]
    parts["history"] = _history(report, drawings)
    parts["gum_statement"] = citations.cite("gum") if cert is not None else ""  # after the list
    return parts


@functools.cache
def _template() -> Any:
    """The template, compiled once for both documents."""
    import jinja2

    env = jinja2.Environment(loader=jinja2.PackageLoader("enctools.report", "templates"),
                             autoescape=True, undefined=jinja2.StrictUndefined)
    return env.get_template(TEMPLATE)


def render(doc: dict[str, Any], page: bool) -> str:
    """The template filled with ``doc``: the whole HTML page (``page``), or its body
    alone for the PDF's renderer. Values are escaped as HTML."""
    return str(_template().render(doc, page=page))
