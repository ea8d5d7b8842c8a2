"""The report as an A4 PDF: the certificate template's body typeset by fpdf2.

The same template as the HTML page (:mod:`enctools.report.document`) is laid out on A4
pages (595.28 x 841.89 pt) with real tables and the plots drawn once for both
documents, each as wide as the text (180 mm) with its caption below it. The fonts are
the DejaVu Sans TrueType fonts matplotlib ships (every glyph the document uses: ″ µ σ ± ↑ ↓),
embedded as subsets. Every page carries the title, the certificate number and
"Page n of m". Pure Python: no system package is needed.
"""

from __future__ import annotations

import datetime as _dt
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from enctools.data.header import output_time
from enctools.report.certificate import Certificate
from enctools.report.document import build, render
from enctools.report.drawings import Drawings
from enctools.report.summary import Report

#: page margins [mm]
MARGIN_MM = 15.0
#: the body text's size [pt]
BODY_PT = 9.0
#: the font family: DejaVu Sans, regular, bold (headings, table heads) and oblique
#: (captions); each face is parsed and embedded, so the document uses no other
FAMILY = "dejavu"
_FACES = {"": "DejaVuSans.ttf", "B": "DejaVuSans-Bold.ttf", "I": "DejaVuSans-Oblique.ttf"}


def _fonts_folder() -> Path:
    from enctools.report.plots import matplotlib_ready

    matplotlib_ready()
    import matplotlib

    return Path(matplotlib.get_data_path()) / "fonts" / "ttf"


#: a heading starts a new page when less than this is left below it [mm]
KEEP_WITH_HEADING_MM = 45.0
#: room kept below a figure for its caption (two lines of the oblique body text) [mm]
CAPTION_MM = 12.0


def _figure_mm(part: str) -> float:
    """The height [mm] a figure's ``<img>`` (a PNG data URI, its width in pt) is laid out
    at; 0 where the tag says neither."""
    import base64
    import struct

    m = re.match(r'<img src="data:image/png;base64,([A-Za-z0-9+/]{32})[^"]*" width="(\d+)"',
                 part)
    if m is None:
        return 0.0
    wide, high = struct.unpack(">II", base64.b64decode(m.group(1))[16:24])  # IHDR [px]
    return float(m.group(2)) * high / max(wide, 1) * 25.4 / 72.0


def _document(title: str, number: str) -> Any:
    """An empty A4 document whose pages carry ``title``, ``number`` and "Page n of m"."""
    from fpdf import FPDF

    class Pages(FPDF):
        def header(self) -> None:
            self.set_font(FAMILY, "", 7.5)
            self.set_text_color(90)
            left = title if not number else f"{title} — No. {number}"
            width = self.get_string_width(left)
            if width > self.epw:            # a long title, cut to the line
                left = left[:max(1, int(len(left) * self.epw / width) - 2)] + "…"
            self.cell(0, 4, left, align="L")
            self.ln(7)

        def footer(self) -> None:
            self.set_y(-12)
            self.set_font(FAMILY, "", 7.5)
            self.set_text_color(90)
            self.cell(0, 4, (f"Certificate {number} — " if number else "")
                      + f"Page {self.page_no()} of {{nb}}", align="R")

    pdf = Pages(orientation="portrait", unit="mm", format="A4")
    pdf.set_margins(MARGIN_MM, MARGIN_MM, MARGIN_MM)
    pdf.set_auto_page_break(auto=True, margin=MARGIN_MM + 3)
    folder = _fonts_folder()
    for style, name in _FACES.items():
        pdf.add_font(FAMILY, style, str(folder / name))
    pdf.set_title(title)
    pdf.set_creator("enctools")
    # CreationDate as the document's own date: SOURCE_DATE_EPOCH makes the bytes repeat
    pdf.set_creation_date(_dt.datetime.fromtimestamp(output_time(), _dt.UTC))
    pdf.set_font(FAMILY, "", BODY_PT)
    return pdf


def _styles() -> dict[str, Any]:
    from fpdf.fonts import TextStyle

    blue = "#1f4e79"
    return {
        "h1": TextStyle(font_family=FAMILY, font_style="B", font_size_pt=16, color=blue,
                        t_margin=2, b_margin=2),
        "h2": TextStyle(font_family=FAMILY, font_style="B", font_size_pt=12, color=blue,
                        t_margin=5, b_margin=1),
        "h3": TextStyle(font_family=FAMILY, font_style="B", font_size_pt=10, color="#222",
                        t_margin=3, b_margin=1),
        "pre": TextStyle(font_family=FAMILY, font_size_pt=6.5, t_margin=1),
    }


def document_pdf(doc: dict[str, Any]) -> bytes:
    """PDF bytes of the document's data (:func:`enctools.report.document.build`)."""
    pdf = _document(str(doc["title"]), str(doc["number"]))
    pdf.add_page()
    styles = _styles()
    # laid out a heading and a figure at a time: a heading too near the foot of a page,
    # or a figure with its caption that the page cannot hold, starts the next
    for part in re.split(r"(?=<h[23]>)|(?=<img )", render(doc, page=False)):
        keep = (KEEP_WITH_HEADING_MM if part.startswith(("<h2>", "<h3>"))
                else _figure_mm(part) + CAPTION_MM if part.startswith("<img ") else 0.0)
        if keep and pdf.will_page_break(keep):
            pdf.add_page()
        pdf.write_html(part, font_family=FAMILY, tag_styles=styles,
                       table_line_separators=True, li_prefix_color=(60, 60, 60))
    return bytes(pdf.output())


def to_pdf(report: Report, failures: Sequence[str] | None = None,
           title: str | None = None, drawings: Drawings | None = None,
           cert: Certificate | None = None) -> bytes:
    """PDF bytes of the report; its plots from ``drawings`` (drawn here when not given),
    the laboratory's fields from ``cert`` (None: a calibration report)."""
    return document_pdf(build(report, failures, title, drawings or Drawings(report), cert))
