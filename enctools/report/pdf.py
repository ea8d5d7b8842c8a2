"""The report as a PDF through matplotlib's PDF backend (no system packages needed)."""

from __future__ import annotations

import io
from collections.abc import Sequence

import numpy as np
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure

from enctools.report import plots
from enctools.report.summary import Report
from enctools.report.text import to_text


def _text_pages(text: str, title: str, lines_per_page: int = 70) -> list[Figure]:
    lines = text.splitlines() or [""]
    pages = []
    for start in range(0, len(lines), lines_per_page):
        fig = Figure(figsize=(8.27, 11.69))
        fig.text(0.05, 0.97, title if start == 0 else f"{title} (cont.)", fontsize=13,
                 va="top", weight="bold")
        chunk = "\n".join(line[:110] for line in lines[start:start + lines_per_page])
        fig.text(0.05, 0.94, chunk, family="monospace", fontsize=6.3, va="top")
        pages.append(fig)
    return pages


def to_pdf(report: Report, failures: Sequence[str] | None = None,
           title: str | None = None) -> bytes:
    """PDF bytes: the text summary (and failed checks), then every plot, one per page."""
    title = title or "Calibration report"
    text = to_text(report)
    if failures:
        text = "CHECK FAILED:\n" + "\n".join(f"  {f}" for f in failures) + "\n\n" + text
    buf = io.BytesIO()
    top = int(report.settings.get("top_harmonics", 5))
    with PdfPages(buf, metadata={"Title": title, "Creator": "enctools"}) as pdf:
        for page in _text_pages(text, title):
            pdf.savefig(page)
        for s in report.sections:
            for caption, fig in plots.section_figures(s, top):
                fig.suptitle(caption, fontsize=9, y=0.02, va="bottom")
                pdf.savefig(fig, bbox_inches="tight")
        h = report.history
        if h is not None and h.runs:
            bad = np.array([st != "ok" for st in h.column("status")])
            series = {n: h.column(n).astype(float) for n in ("pp", "std", "drift_max")}
            pdf.savefig(plots.history_plot(h.times(), series, "nightly history", bad, h.unit),
                        bbox_inches="tight")
    return buf.getvalue()
