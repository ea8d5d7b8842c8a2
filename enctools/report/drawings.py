"""Every plot of a report drawn once, as PNG, for every output that shows it.

The HTML embeds the PNG; the PDF puts the same image on its page
(:func:`enctools.report.pdf.to_pdf`), so a report written as HTML and PDF draws each
figure one time. A plot is drawn when an output first asks for it: a text or JSON
report draws nothing (and imports no matplotlib).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from enctools.report.summary import Report

if TYPE_CHECKING:
    from enctools.report.sections import Section

#: resolution of every drawn plot [dots per inch]
DPI = 110


class Drawings:
    """The drawn plots of one report: those of each section and the nightly history.

    Each method returns PNG bytes (with captions where a plot has one), drawing on
    the first call and returning the same bytes after.
    """

    def __init__(self, report: Report) -> None:
        self.report = report
        self.top = int(report.settings.get("top_harmonics", 5))
        self._sections: dict[int, list[tuple[str, bytes]]] = {}
        self._history: bytes | None = None

    def section(self, s: Section) -> list[tuple[str, bytes]]:
        """(caption, PNG) of every plot of section ``s`` of the report."""
        key = id(s)
        if key not in self._sections:
            from enctools.report import plots

            self._sections[key] = [(caption, plots.to_png(fig, DPI))
                                   for caption, fig in plots.section_figures(s, self.top)]
        return self._sections[key]

    def history(self) -> bytes | None:
        """PNG of the nightly history (p-p, s and drift of every run), or None."""
        h = self.report.history
        if h is None or not h.runs:
            return None
        if self._history is None:
            from enctools.report import plots

            bad = np.array([st != "ok" for st in h.column("status")])
            series = {n: h.column(n).astype(float) for n in ("pp", "std", "drift_max")}
            self._history = plots.to_png(plots.history_plot(
                h.times(), series, "figures of each nightly run", bad, h.unit), DPI)
        return self._history
