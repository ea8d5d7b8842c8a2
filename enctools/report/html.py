"""A standalone HTML calibration report: every plot embedded as a PNG data URI.

Contents: result of the checks, rig and method, a summary table, one part per input
(plots, harmonics, ISO 230-2 table, notes, the data's history), before/after
comparison when several inputs carry deviation curves, the nightly history, and the
conventions used (Bessel s, U with k = 2, ISO 230-2 definitions).
"""

# The page's typography is meant: en dashes for missing values, minus signs and x.

from __future__ import annotations

import base64
import datetime as _dt
import html
import math
from collections.abc import Sequence
from typing import Any

from enctools import __version__
from enctools.data.readings import rig_encoders
from enctools.report import plots
from enctools.report.display import label
from enctools.report.drawings import DPI, Drawings
from enctools.report.sections import Curve, Section
from enctools.report.summary import Report
from enctools.units import DEG

CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;max-width:1000px;
margin:1.5em auto;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.6em;border-bottom:3px solid #1f77b4;padding-bottom:.2em}
h2{font-size:1.25em;margin-top:1.6em;border-bottom:1px solid #ccc}
h3{font-size:1.05em;margin-bottom:.3em}
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}
th,td{border:1px solid #ccc;padding:.2em .5em;text-align:right}
th{background:#f0f4f8}td.l,th.l{text-align:left}
figure{margin:.8em 0}figcaption{font-size:.85em;color:#555}
img{max-width:100%}pre{background:#f6f6f6;padding:.5em;font-size:.75em;overflow-x:auto}
.ok{background:#e6f4ea;border-left:5px solid #2ca02c;padding:.5em}
.fail{background:#fdecea;border-left:5px solid #d62728;padding:.5em}
.note{font-size:.85em;color:#555}
"""


def _e(x: Any) -> str:
    return html.escape(str(x))


def _f(x: float | None, digits: int = 3) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    if abs(x) < 1e-9:           # a mean removed to rounding: 0, not -3.5e-18
        x = 0.0
    if x != 0 and abs(x) < 0.5 * 10 ** -digits:
        return f"{x:.2g}"
    return f"{x:.{digits}f}"


def _img(png: bytes, caption: str) -> str:
    data = base64.b64encode(png).decode()
    return (f'<figure><img alt="{_e(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{_e(caption)}</figcaption></figure>")


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]], left: int = 1,
           also_left: Sequence[int] = ()) -> str:
    """A table; the first ``left`` columns (and those in ``also_left``) are text."""
    def cls(i: int) -> str:
        return "l" if i < left or i in also_left else ""
    th = "".join(f'<th class="{cls(i)}">{_e(h)}</th>' for i, h in enumerate(header))
    body = "".join("<tr>" + "".join(f'<td class="{cls(i)}">{_e(v)}</td>'
                                    for i, v in enumerate(r)) + "</tr>" for r in rows)
    return f"<table><tr>{th}</tr>{body}</table>"


def _rig_html(metas: dict[str, dict[str, Any]]) -> str:
    """The rigs (name -> the metadata of an input recorded on it) as headings and tables."""
    if not metas:
        return "<p>The inputs do not describe their rig.</p>"
    out = []
    for name, meta in metas.items():
        rig = meta["rig"]
        out.append(f"<h3>{_e(name)}</h3><p>{_e(rig.get('description', ''))}</p>")
        rows = []
        for enc in rig_encoders(meta):
            heads = ", ".join(f"{h.name} {h.angle / DEG:g}°" for h in enc.heads)
            rows.append([enc.name, enc.model, enc.periods_per_rev, enc.interpolation,
                         enc.diameter_mm, heads])
        if rows:
            out.append(_table(["encoder", "model", "periods/rev", "interpolation",
                               "diameter [mm]", "heads (nominal angle)"], rows, left=2,
                              also_left=(5,)))
        extras = [k for k in ("polygon", "autocollimator", "probes") if rig.get(k)]
        if extras:
            out.append(f"<p class='note'>Also: {_e(', '.join(extras))}; backend "
                       f"{_e((rig.get('backend') or {}).get('kind', '?'))}.</p>")
    return "".join(out)


def _method_rows(report: Report) -> list[list[str]]:
    rows = []
    for s in report.sections:
        hist = s.history
        last = hist[-1].split(": ", 1)[-1] if hist else "(no history)"
        settings = s.meta.get("settings", {})
        brief = ", ".join(f"{k}={v}" for k, v in settings.items()
                          if isinstance(v, (int, float, str)) and k not in ("backend",))[:160]
        rows.append([s.source, s.kind, last, brief or "–"])
    return rows


def _summary_rows(report: Report) -> list[list[str]]:
    rows = []
    for s, c in report.curves():
        f = c.figures
        rows.append([s.source, c.name, label(c.unit), f.n, _f(f.pp), _f(f.plus_minus), _f(f.mean),
                     _f(f.std), _f(c.U_max)])
    return rows


def _harmonics_table(curves: Sequence[Curve], top: int) -> str:
    """One row per curve: its largest harmonics as n: A @ p."""
    rows = []
    for c in curves:
        if c.harmonics is None:
            continue
        h = c.harmonics.largest(top)
        cells = [f"n={int(n)}: {float(a):.3f} @ {float(p) / DEG:.0f}°"
                 for n, a, p in zip(h.n, h.amplitude, h.phase, strict=True)]
        rows.append([c.name, label(c.unit)] + cells + [""] * (top - len(cells)))
    if not rows:
        return ""
    return ("<p class='note'>Largest harmonics, A cos(n x + p): n, amplitude A, phase p.</p>"
            + _table(["curve", "unit"] + [f"#{i + 1}" for i in range(top)], rows, left=2))


def _iso_html(s: Section) -> str:
    iso = s.iso
    if iso is None:
        return ""
    axis = iso.axis()
    out = ["<h3>ISO 230-2 (2014)</h3>",
           _table(list(axis), [[_f(v) for v in axis.values()]], left=0),
           f"<p class='note'>[{_e(label(iso.unit))}]. R_i = 4 s_i (±2 s); "
           "bidirectional R = max R_i with "
           "R_i = max(2 s_i↑ + 2 s_i↓ + |B_i|, R_i↑, R_i↓); E over both directions' mean "
           "deviations; M = range of x̄_i; A = max(x̄ + 2s) − min(x̄ − 2s) over both "
           "directions; B = max |B_i|.</p>"]
    cols = ["position [deg]"]
    if iso.up is not None:
        cols += ["x̄↑", "s↑", "R↑", "n↑"]
    if iso.down is not None:
        cols += ["x̄↓", "s↓", "R↓", "n↓"]
    if iso.is_bidirectional:
        cols += ["x̄", "B_i", "R_i"]
    rows = []
    for r in iso.table():
        row: list[Any] = [f"{r['position_deg']:.3f}"]
        if iso.up is not None:
            row += [_f(r["mean_up"]), _f(r["s_up"]), _f(r["R_up"]), r["n_up"]]
        if iso.down is not None:
            row += [_f(r["mean_down"]), _f(r["s_down"]), _f(r["R_down"]), r["n_down"]]
        if iso.is_bidirectional:
            row += [_f(r["mean"]), _f(r["B"]), _f(r["R"])]
        rows.append(row)
    out.append(_table(cols, rows, left=0))
    for w in iso.warnings:
        out.append(f"<p class='note'>⚠ {_e(w)}</p>")
    return "".join(out)


def _vdi_html(s: Section) -> str:
    vdi = s.vdi
    if vdi is None:
        return ""
    axis = vdi.axis()
    out = ["<h3>VDI/DGQ 3441 (1977)</h3>",
           _table(list(axis), [[_f(v) for v in axis.values()]], left=0),
           f"<p class='note'>[{_e(label(vdi.unit))}]. x̄_j = (x̄↑ + x̄↓)/2; U_j = |x̄↑ − x̄↓|; "
           "Ps_j = 6 (s↑ + s↓)/2 (±3 s); Pa = range of x̄_j; "
           "P = max(x̄_j + (U_j + Ps_j)/2) − min(x̄_j − (U_j + Ps_j)/2).</p>"]
    keys = ("mean_up", "s_up", "mean_down", "s_down", "mean", "U", "Ps")
    rows = [[f"{r['position_deg']:.3f}"] + [_f(r[k]) for k in keys] + [r["n_up"], r["n_down"]]
            for r in vdi.table()]
    out.append(_table(["position [deg]", "x̄↑", "s↑", "x̄↓", "s↓", "x̄_j", "U_j", "Ps_j",
                       "n↑", "n↓"], rows, left=0))
    return "".join(out)


def _section_html(s: Section, top: int, drawings: Drawings) -> str:
    out = [f"<h2>{_e(s.source)} — {_e(s.kind)}</h2>"]
    if s.info:
        out.append(_table(["", ""], [[k, v] for k, v in s.info.items()]))
    for caption, png in drawings.section(s):
        out.append(_img(png, caption))
    out.append(_harmonics_table(s.curves, top))
    for c in s.curves:
        if c.harmonics is not None and c.harmonics.left_out:
            out.append(f"<p class='note'>{_e(c.name)}: {_e(c.harmonics.left_out_text())}</p>")
    out.append(_iso_html(s))
    out.append(_vdi_html(s))
    for n in s.notes:
        out.append(f"<p class='note'>Note: {_e(n)}</p>")
    out.append("<p class='note'>How these data were made (history):</p><pre>"
               + _e("\n".join(s.history) or "(none)") + "</pre>")
    return "".join(out)


def _compare_html(report: Report) -> str:
    """Inputs of one kind carrying the same curve over a turn, on one plot (before/after).

    Only curves of one name are compared (two polygon runs, two self-calibrations):
    a graduation error and an H - P difference are different measurands.
    """
    groups: dict[str, list[tuple[str, Curve]]] = {}
    unit = str(report.settings.get("unit", "arcsec"))
    for s, c in report.curves(unit):
        if c.domain == "revolution" and c.role in ("deviation", "points", "positioning"):
            name = s.source.rsplit("/", 1)[-1]
            if len([x for x in s.curves if x.unit == unit]) > 1:
                name += f":{c.name}"
            groups.setdefault(s.kind, []).append((name, c))
    out = []
    for kind, pairs in groups.items():
        if len({label.split(":")[0] for label, _ in pairs}) < 2:
            continue
        if len({c.name for _, c in pairs}) > 1:  # different measurands: not before/after
            continue
        rows = [[label, _f(c.figures.pp), _f(c.figures.std)] for label, c in pairs]
        first = pairs[0][1].figures.std
        ratio = "".join(f"<li>{_e(label)}: s of the first / s of this = "
                        f"{first / c.figures.std:.2f}</li>"
                        for label, c in pairs[1:] if c.figures.std > 0)
        out.append(f"<h2>Comparison of the {_e(kind)} inputs (before / after compensation)</h2>"
                   + _img(plots.to_png(plots.compare_plot(pairs[:8], f"{kind}: every input"),
                                       DPI),
                          "Deviation of every input on one plot (the first: before)")
                   + _table(["input", f"p-p [{label(unit)}]", f"s [{label(unit)}]"], rows)
                   + f"<ul class='note'>{ratio}</ul>")
    return "".join(out)


def _history_html(report: Report, drawings: Drawings) -> str:
    h = report.history
    if h is None:
        return ""
    out = [f"<h2>Nightly history — {_e(h.folder + h.filters_text())}</h2>",
           f"<p>{h.runs} run(s)"
           + (f"; {len(h.skipped)} unreadable file(s) skipped" if h.skipped else "") + ".</p>"]
    png = drawings.history()
    if png is not None:
        out.append(_img(png, "p-p, s and drift of every run (× marks runs that failed)"))
        rows = [[r["time"], r["rig"] or "–", r["status"] or "–", _f(r["pp"]), _f(r["std"]),
                 _f(r["drift_max"]), _f(r["tolerance"])] for r in h.to_records()]
        u = f" [{label(h.unit)}]"
        out.append(_table(["time (UTC)", "rig", "status", "p-p" + u, "s" + u, "drift" + u,
                           "tolerance" + u],
                          rows, left=3))
    return "".join(out)


def to_html(report: Report, failures: Sequence[str] | None = None,
            title: str | None = None, drawings: Drawings | None = None) -> str:
    """The whole report as one HTML document (str); its plots from ``drawings`` (drawn
    here when not given)."""
    drawings = drawings or Drawings(report)
    top = drawings.top
    unit = str(report.settings.get("unit", "arcsec"))
    rigs = {s.rig_name: s.meta for s in report.sections if s.rig_name}
    title = title or ("Calibration report" + (f" — {', '.join(rigs)}" if rigs else ""))
    now = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
             f"<title>{_e(title)}</title><style>{CSS}</style></head><body>",
             f"<h1>{_e(title)}</h1><p class='note'>Made {now} by enctools {__version__} "
             f"from {len(report.sections)} input(s).</p>"]
    limits = report.settings.get("thresholds") or {}
    if limits:
        if failures:
            parts.append("<div class='fail'><b>Check failed:</b><ul>"
                         + "".join(f"<li>{_e(f)}</li>" for f in failures) + "</ul></div>")
        else:
            parts.append(f"<div class='ok'><b>Within every threshold</b> "
                         f"({_e(', '.join(f'{k}={v}' for k, v in limits.items()))}).</div>")
    if report.sections:
        parts.append("<h2>Summary</h2>" + _table(
            ["input", "curve", "unit", "n", "p-p", "±", "mean", "s (Bessel)", "U max"],
            _summary_rows(report), left=3))
    parts.append(_compare_html(report))
    if report.sections:
        parts.append("<h2>Rig and method</h2>" + _rig_html(rigs))
        parts.append(_table(["input", "kind", "made by", "settings"], _method_rows(report),
                            left=4))
    for s in report.sections:
        parts.append(_section_html(s, top, drawings))
    parts.append(_history_html(report, drawings))
    parts.append(
        "<h2>Conventions</h2><ul class='note'>"
        f"<li>Deviation = indicated − true angle [{_e(label(unit))}]; angles in degrees.</li>"
        "<li>s: Bessel standard deviation √(Σ(x_i − x̄)²/(n − 1)) over the values as "
        "given (seed 001 eq. 8); ± is half the peak-to-peak.</li>"
        "<li>U: expanded uncertainty, U = k·u with k = 2, from the standard "
        "uncertainties the input carries (or s/√n over the runs of repeated positions); "
        "for a polygon run's points with an uncertainty budget, the budget's U = k·u_c, "
        "k Student's at its effective degrees of freedom.</li>"
        "<li>Harmonics: A cos(n x + p), n per revolution (per signal period for "
        "interpolation errors).</li>"
        "<li>ISO 230-2:2014 definitions; repeatability uses ±2 s (R = 4 s); the readings "
        "of one approach are one x_ij, n counts runs.</li></ul>")
    parts.append("</body></html>")
    return "\n".join(p for p in parts if p)
