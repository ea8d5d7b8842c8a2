"""Every plot of a report drawn once, as PNG, for every output that shows it.

The HTML embeds the PNG; the PDF puts the same image on its page
(:func:`enctools.report.pdf.to_pdf`), so a report written as HTML and PDF draws each
figure one time. A plot is drawn when an output first asks for it: a text or JSON
report draws nothing (and imports no matplotlib).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from enctools.report.summary import Report

if TYPE_CHECKING:
    from enctools.report.sections import Curve, Section

#: resolution of every drawn plot [dots per inch]
DPI = 110


def _caption(caption: str, axes: str) -> str:
    """A plot's caption followed by what its axes show (with their units)."""
    return f"{caption}: {axes}" if axes else caption


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
        self._history_digest: Any = None
        self._comparisons: dict[str, bytes] = {}

    def section(self, s: Section) -> list[tuple[str, bytes]]:
        """(caption, PNG) of every plot of section ``s`` of the report."""
        key = id(s)
        if key not in self._sections:
            from enctools.report import plots

            self._sections[key] = [(_caption(caption, plots.axes_text(fig)),
                                    plots.to_png(fig, DPI))
                                   for caption, fig in plots.section_figures(s, self.top)]
        return self._sections[key]

    def history(self) -> bytes | None:
        """PNG of the nightly history (p-p, s and drift of every run), or None."""
        h = self.report.history
        if h is None or not h.runs:
            return None
        if self._history is None:
            from enctools.report import plots

            long = self.history_digest()
            if long is not None and long.times is not None:   # binned by time
                times, series, bad = long.times, long.series, long.bad
                title = "figures of the nightly runs, binned by time: each bin's extremes"
            else:
                bad = np.array([st != "ok" for st in h.column("status")])
                series = {n: h.column(n).astype(float) for n in ("pp", "std", "drift_max")}
                times, title = h.times(), "figures of each nightly run"
            self._history = plots.to_png(plots.history_plot(times, series, title, bad,
                                                            h.unit), DPI)
        return self._history

    def history_digest(self) -> Any:
        """The digest of a history of more than ``historydigest.LISTED`` runs (read
        once, for the plot and the table), or None."""
        from enctools.report import historydigest

        h = self.report.history
        if h is None or h.runs <= historydigest.LISTED:
            return None
        if self._history_digest is None:
            self._history_digest = historydigest.digest(h)
        return self._history_digest

    def comparisons(self) -> list[tuple[str, list[tuple[str, Curve]]]]:
        """(kind, [(name, curve), ...]) of every kind of which several inputs carry the same
        curve over a turn in the report's unit: a before / after comparison.

        Only curves of one name are compared (two polygon runs, two self-calibrations):
        a graduation error and an H - P difference are different measurands.
        """
        groups: dict[str, list[tuple[str, Curve]]] = {}
        unit = str(self.report.settings.get("unit", "arcsec"))
        for s, c in self.report.curves(unit):
            if c.domain == "revolution" and c.role in ("deviation", "points", "positioning"):
                name = s.source.rsplit("/", 1)[-1]
                if len([x for x in s.curves if x.unit == unit]) > 1:
                    name += f":{c.name}"
                groups.setdefault(s.kind, []).append((name, c))
        return [(kind, pairs[:8]) for kind, pairs in groups.items()
                if len({n.split(":")[0] for n, _ in pairs}) >= 2
                and len({c.name for _, c in pairs}) == 1]

    def comparison(self, kind: str) -> bytes:
        """PNG of the comparison plot of ``kind`` (:meth:`comparisons`)."""
        if kind not in self._comparisons:
            from enctools.report import plots

            pairs = dict(self.comparisons())[kind]
            self._comparisons[kind] = plots.to_png(
                plots.compare_plot(pairs, f"{kind}: every input"), DPI)
        return self._comparisons[kind]
