"""The report as a few lines of text per input (``enc report``'s stdout)."""

from __future__ import annotations

from typing import Any

from enctools.data.text import printable_lines
from enctools.report.budget import budget_lines
from enctools.report.display import mark, phase_text
from enctools.report.numbers import figures, fmt, fmt_u, group, table_decimals
from enctools.report.results import correction_of, results
from enctools.report.sections import Curve, Section
from enctools.report.summary import Report


def curve_lines(c: Curve, s: Section, top: int = 5) -> list[str]:
    f = c.figures
    u = c.unit
    sym = mark(u)

    d = figures(f, u)    # shown together: one decade

    def g(x: float | None) -> str:
        return fmt(x, u, d, missing="-")

    lines = [f"  {c.name} [{u}]{' (head ' + c.head + ')' if c.head else ''}: n={f.n}  "
             f"p-p {g(f.pp)}{sym}  +/-{g(f.plus_minus)}{sym}  mean {g(f.mean)}{sym}  "
             f"s {g(f.std)}{sym} (Bessel n-1)"]
    if c.u is not None:
        U = fmt_u(c.U_max, u, missing="-")
        lines.append(f"    expanded uncertainty U (k={c.k:.3g}): max {U}{sym}")
    h = c.harmonics.largest(top) if c.harmonics is not None else None
    if h is not None and h.n.size:
        per = "/period" if c.domain == "period" else "/rev"
        da = group(h.amplitude, u)
        parts = [f"n={int(n)} {fmt(a, u, da)}{sym} @ {phase_text(c, p)}"
                 for n, a, p in zip(h.n, h.amplitude, h.phase, strict=True)]
        lines.append(f"    largest harmonics ({per[1:]}, A cos(n x + p)): " + "; ".join(parts))
    if c.harmonics is not None and c.harmonics.note():
        lines.append(f"    {c.harmonics.note()}")
    return lines


def iso_lines(s: Section) -> list[str]:
    iso = s.iso
    if iso is None:
        return []
    axis = iso.axis()
    da = group(list(axis.values()), iso.unit)
    lines = [f"  ISO 230-2 (R = 4s, A with +/-2s) [{iso.unit}]: "
             + "  ".join(f"{k} {fmt(v, iso.unit, da, missing='-')}" for k, v in axis.items())]
    head = f"    pos [{iso.position_unit}]"
    cols = []
    if iso.up is not None:
        cols += ["mean up", "s up"]
    if iso.down is not None:
        cols += ["mean dn", "s dn"]
    if iso.is_bidirectional:
        cols += ["B_i", "R_i"]
    lines.append(head + "".join(f"{c:>9}" for c in cols))
    rows, table = [], iso.table()
    for row in table:
        vals = []
        if iso.up is not None:
            vals += [row["mean_up"], row["s_up"]]
        if iso.down is not None:
            vals += [row["mean_down"], row["s_down"]]
        if iso.is_bidirectional:
            vals += [row["B"], row["R"]]
        rows.append((row[f"position_{iso.position_unit}"], vals))
    dt = table_decimals(table, iso.unit)    # as the documents' table, which lists more
    lines += [f"    {pos:9.3f}" + "".join(f"{fmt(v, iso.unit, dt, missing='-'):>9}" for v in vals)
              for pos, vals in rows]
    return lines


def vdi_lines(s: Section) -> list[str]:
    vdi = s.vdi
    if vdi is None:
        return []
    da = group(list(vdi.axis().values()), vdi.unit)
    lines = [f"  VDI/DGQ 3441 (Ps = 6s, P with (U + Ps)/2) [{vdi.unit}]: "
             + "  ".join(f"{k} {fmt(v, vdi.unit, da, missing='-')}"
                         for k, v in vdi.axis().items())]
    keys = ("mean_up", "s_up", "mean_down", "s_down", "mean", "U", "Ps")
    cols = ("mean up", "s up", "mean dn", "s dn", "mean", "U_j", "Ps_j")
    lines.append(f"    pos [{vdi.position_unit}]" + "".join(f"{c:>9}" for c in cols))
    table = vdi.table()
    dt = table_decimals(table, vdi.unit)
    for row in table:
        lines.append(f"    {row[f'position_{vdi.position_unit}']:9.3f}"
                     + "".join(f"{fmt(row[k], vdi.unit, dt, missing='-'):>9}" for k in keys))
    return lines


def result_lines(s: Section, model: Curve | None = None) -> list[str]:
    """The results per calibrated position (:mod:`enctools.report.results`): one line a
    target, the same numbers as the JSON, HTML and PDF."""
    lines = []
    for res in results(s, model):
        lines.append(f"  results per calibrated position, {res.curve}: {res.note()}")
        head = res.header()
        cells = res.cells()
        widths = [max(len(h), *(len(r[i]) for r in cells)) for i, h in enumerate(head)]
        lines.append("    " + "  ".join(h.rjust(w) for h, w in zip(head, widths, strict=True)))
        lines += ["    " + "  ".join(v.rjust(w) for v, w in zip(r, widths, strict=True))
                  for r in cells]
    return lines


def section_lines(s: Section, top: int, model: Curve | None = None) -> list[str]:
    rig = f", rig {s.rig_name}" if s.rig_name else ""
    lines = [f"{s.source}: {s.kind}{rig}"]
    for k, v in s.info.items():
        lines.append(f"  {k}: {v}")
    for c in s.curves:
        lines += curve_lines(c, s, top)
    for sp in s.spectra:
        parts = []
        for i in sp.largest(top):
            U = None if sp.u is None else sp.k * float(sp.u[i])
            p = f"n={int(sp.n[i])} {fmt(float(sp.amplitude[i]), sp.unit, u=U)}{mark(sp.unit)}"
            if U is not None:
                p += f" (U {fmt_u(U, sp.unit)}{mark(sp.unit)})"
            if sp.transfer is not None:
                p += f" |W| {fmt(float(sp.transfer[i]), decimals=2)}"
            parts.append(p)
        lines.append(f"  spectrum {sp.curve}: largest " + "; ".join(parts))
    lines += result_lines(s, model)
    if s.budget is not None:
        lines += budget_lines(s.budget, s.unit)
    if s.covariance is not None:
        from enctools.report.covariance import lines as covariance_lines

        lines += covariance_lines(s.covariance, s.unit)
    lines += iso_lines(s)
    lines += vdi_lines(s)
    lines += [f"  note: {n}" for n in s.notes]
    return lines


def history_lines(report: Report) -> list[str]:
    h = report.history
    if h is None:
        return []
    return h.text_lines()


def to_text(report: Report) -> str:
    top = int(report.settings.get("top_harmonics", 5))
    out: list[str] = []
    model = correction_of(report.sections)
    for s in report.sections:
        out += section_lines(s, top, model)
    out += history_lines(report)
    return printable_lines(out)  # names, notes and history come from files


def write_text(report: Report, out: Any, block: int = 10_000) -> None:
    """:func:`to_text` and a newline written to ``out`` a block of lines at a time: the
    history's runs are read batch by batch, so memory does not grow with them."""
    top = int(report.settings.get("top_harmonics", 5))
    lines: list[str] = []
    model = correction_of(report.sections)
    for s in report.sections:
        lines += section_lines(s, top, model)
    history = iter(()) if report.history is None else report.history.iter_text_lines()
    wrote = False
    for line in history:
        lines.append(line)
        if len(lines) >= block:
            out.write(printable_lines(lines) + "\n")
            lines, wrote = [], True
    if lines or not wrote:
        out.write(printable_lines(lines) + "\n")
