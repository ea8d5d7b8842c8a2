"""The report as one standalone HTML page (plots embedded as PNG data URIs).

The page is the certificate template (``templates/certificate.html.j2``) filled with the
document's data (:mod:`enctools.report.document`), as the PDF is: both say the same.
"""

from __future__ import annotations

from collections.abc import Sequence

from enctools.report.certificate import Certificate
from enctools.report.document import build, render
from enctools.report.drawings import Drawings
from enctools.report.summary import Report


def to_html(report: Report, failures: Sequence[str] | None = None,
            title: str | None = None, drawings: Drawings | None = None,
            cert: Certificate | None = None) -> str:
    """The whole report as one HTML document (str); its plots from ``drawings`` (drawn
    here when not given), the laboratory's fields from ``cert`` (None: a report)."""
    doc = build(report, failures, title, drawings or Drawings(report), cert)
    return render(doc, page=True)
