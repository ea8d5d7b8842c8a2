"""The methods of a report's inputs named for a customer, and the references they cite.

Each input is named by the command that made it (its last history line) with the
paper or standard it follows as a reference number; the references the document cites
are listed once in its References section, numbered in the order of their first
citation: :func:`cite` numbers them as the document is made, inside :func:`collecting`,
and :func:`listed` gives the list. Nothing in the rendered text is parsed for "[n]", so
a "[3]" in a laboratory's own text stays as written.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

from enctools.report.summary import Report

#: the references of every document, numbered in this order: [1], [2], ...
REFERENCES = (
    ("000", "Jiao Y., Huang M., Liu P., Li M., Qin D.: Calibration of angular errors of "
            "high-precision rotary table with two-angle encoders. Optics and Precision "
            "Engineering 27(10), 2180–2191 (2019). doi:10.3788/OPE.20192710.2180"),
    ("001", "Yu H., Wan Q., Wang S., Lu X., Du Y.: High-precision real-time angle reference "
            "in dynamic measurement of photoelectric encoder. Chinese Optics 8(3), 447–455 "
            "(2015). doi:10.3788/CO.20150803.0447"),
    ("iso230", "ISO 230-2:2014 Test code for machine tools — Part 2: Determination of "
               "accuracy and repeatability of positioning of numerically controlled axes"),
    ("vdi3441", "VDI/DGQ 3441:1977 Statistical testing of the operational and positional "
                "accuracy of machine tools"),
    ("gum", "JCGM 100:2008 Evaluation of measurement data — Guide to the expression of "
            "uncertainty in measurement (GUM)"),
    ("ilac", "ILAC-G8:09/2019 Guidelines on decision rules and statements of conformity"),
)
_TEXT = dict(REFERENCES)
#: the keys cited so far in the document being made, in the order of first citation
_CITED: ContextVar[list[str] | None] = ContextVar("cited", default=None)

#: what each stream kind holds, as a heading names it
KINDS = {"deviations": "deviation curves", "spectrum": "harmonic spectrum",
         "points": "calibration points", "model": "error model", "rom": "correction table",
         "readings": "recorded readings"}

_METHODS = {
    "esa": ("four-head error separation of the graduation error from the spindle's radial "
            "error motion", "000"),
    "selfcal": ("self-calibration with several reading heads (Fourier method)", "000"),
    "compare": ("direct comparison of two angle encoders on one spindle", "000"),
    "average-heads": ("averaging of the reading heads of each encoder", "000"),
    "interp-check": ("interpolation error within one signal period against a reference "
                     "(capacitive probes or a second encoder)", "000"),
    "interp-check-signals": ("interpolation error within one signal period from the "
                             "encoder's own sine and cosine signals (Heydemann's ellipse fit)",
                             ""),
    "points": ("angular positions against a reference (polygon and autocollimator, or a "
               "reference encoder)", "001"),
    "fit-rbf": ("radial-basis-function error model through the calibration points", "001"),
    "make-rom": ("correction table of the error model", "001"),
    "steps": ("step run over the full turn: positioning deviation at each target", "iso230"),
    "linear": ("positions of a linear axis against a reference (a laser interferometer's "
               "positioning test)", "iso230"),
    "acquire": ("recording of the encoder readings", ""),
    "correct": ("readings corrected with a correction table", ""),
}


@contextmanager
def collecting() -> Iterator[list[str]]:
    """Number the citations made inside, 1, 2, ... in the order first made; yields the
    keys cited, in that order (for :func:`listed`). The document is made in its reading
    order, so the numbers run in the order a reader meets them."""
    cited: list[str] = []
    token = _CITED.set(cited)
    try:
        yield cited
    finally:
        _CITED.reset(token)


def cite(key: str) -> str:
    """The reference number of ``key`` (a paper "000", "001" or a standard) as "[n]":
    its place among the document's citations (inside :func:`collecting` only)."""
    cited = _CITED.get()
    if cited is None:
        msg = "a citation made outside a document (citations.collecting)"
        raise RuntimeError(msg)
    if key not in _TEXT:
        raise KeyError(key)
    if key not in cited:
        cited.append(key)
    return f"[{cited.index(key) + 1}]"


def kind_name(kind: str) -> str:
    """What a stream kind holds, in words."""
    return KINDS.get(kind, kind)


def listed(cited: list[str]) -> list[str]:
    """The references of the keys ``cited``, in that order (a document's list)."""
    return [_TEXT[key] for key in cited]


def _settings(meta: dict[str, Any]) -> dict[str, Any]:
    given = meta.get("settings")
    return given if isinstance(given, dict) else {}


def method_of(meta: dict[str, Any]) -> str:
    """The method that made an input (from its last history line), with its reference."""
    history = meta.get("history") or []
    line = str(history[-1]) if history else ""
    m = re.search(r": enc ([a-z-]+)", line)
    command = m.group(1) if m else ""
    settings = _settings(meta)
    if command == "selfcal" and settings.get("method") == "esa":
        command = "esa"
    elif command == "interp-check" and settings.get("mode") == "signals":
        command = "interp-check-signals"
    elif command == "acquire" and meta.get("mode") == "steps":
        command = "steps"
    if meta.get("axis") == "linear":
        command = "linear"
    name, key = _METHODS.get(command, ("as the data's history records it", ""))
    return f"{name} {cite(key)}" if key else name


def rows(report: Report, table: Callable[..., dict[str, Any]], settings: bool = True
         ) -> dict[str, Any] | None:
    """The table of every input's kind, method and (``settings``) the settings it was
    made with (``table`` builds it); a certificate leaves the settings to the
    laboratory's record."""
    out = []
    for s in report.sections:
        brief = ", ".join(f"{k}={v}" for k, v in _settings(s.meta).items()
                          if isinstance(v, (int, float, str)) and k != "backend")[:160]
        out.append([s.source.rsplit("/", 1)[-1] or s.source, kind_name(s.kind),
                    method_of(s.meta)] + ([brief or "–"] if settings else []))
    if not out:
        return None
    return table(["input" if settings else "result", "holds", "method"]
                 + (["settings"] if settings else []), out, left=4)
