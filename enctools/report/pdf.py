"""The report as a PDF through matplotlib's PDF backend (no system packages needed):
the text pages, then the plots as drawn for the HTML, one per page."""

from __future__ import annotations

import io
from collections.abc import Sequence

from matplotlib import rc_context
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure

from enctools.report.drawings import DPI, Drawings
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
        fig.text(0.05, 0.94, chunk, family="monospace", fontsize=6.3, va="top",
                 weight="medium")  # the weight the PDF's own Courier has
        pages.append(fig)
    return pages


def _image_page(png: bytes, caption: str | None = None) -> Figure:
    """A page holding a drawn plot as it is (its pixels at :data:`DPI`), the caption
    below it."""
    from matplotlib.image import imread

    pixels = imread(io.BytesIO(png), format="png")[..., :3]
    high, wide = pixels.shape[:2]
    below = 0.3 if caption else 0.0  # inch of caption under the plot
    fig = Figure(figsize=(wide / DPI, high / DPI + below), dpi=DPI)
    fig.figimage(pixels, 0, round(below * DPI))
    if caption:
        fig.text(0.5, 0.5 * below / (high / DPI + below), caption, fontsize=9, ha="center",
                 va="center", weight="medium")
    return fig


def to_pdf(report: Report, failures: Sequence[str] | None = None,
           title: str | None = None, drawings: Drawings | None = None) -> bytes:
    """PDF bytes: the text summary (and failed checks), then every plot, one per page.

    The plots are the ones drawn for the HTML (``drawings``; drawn here when not
    given), each placed on its page as drawn.
    """
    drawings = drawings or Drawings(report)
    title = title or "Calibration report"
    text = to_text(report)
    if failures:
        text = "CHECK FAILED:\n" + "\n".join(f"  {f}" for f in failures) + "\n\n" + text
    buf = io.BytesIO()
    # the PDF's own fonts (Courier for the text pages): nothing to lay out and embed
    with rc_context({"pdf.use14corefonts": True}), \
            PdfPages(buf, metadata={"Title": title, "Creator": "enctools"}) as pdf:
        for page in _text_pages(text, title):
            pdf.savefig(page)
        for s in report.sections:
            for caption, png in drawings.section(s):
                pdf.savefig(_image_page(png, caption), dpi=DPI)
        history = drawings.history()
        if history is not None:
            pdf.savefig(_image_page(history), dpi=DPI)
    return buf.getvalue()
