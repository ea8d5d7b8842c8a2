"""A certificate as its customer reads it, and the laboratory's record beside it.

A certificate names each result ("Result 1") and the item as the certificate file says;
what only the laboratory needs (the inputs' paths, the commands that made them with
their options, the versions of the software, the settings and internals of a model,
the rig's name) is no part of it (ISO/IEC 17025:2017 7.8.1.2: the information the
customer needs to interpret the results). :func:`view` renames the inputs of a report for
the document; :func:`record` is the laboratory's record of the same certificate: which
input each result is, and each input's history, written apart (its record file, enc-report(1)).
"""

from __future__ import annotations

import copy
import datetime as _dt
from typing import Any

from enctools import __version__
from enctools.data.text import printable_lines
from enctools.report.summary import Report

#: the name of the i-th result (1, 2, ...) on a certificate
RESULT = "Result {}"


def view(report: Report) -> Report:
    """A copy of ``report`` whose inputs are named "Result 1", "Result 2", ... in the
    order given (the report itself is unchanged)."""
    out = copy.copy(report)
    out.sections = []
    for i, s in enumerate(report.sections, 1):
        new = copy.copy(s)
        new.source = RESULT.format(i)
        out.sections.append(new)
    return out


def record(report: Report, number: str, now: _dt.datetime) -> str:
    """The laboratory's record of certificate ``number``: when and by which version it
    was made, then per result its input (as given), its rig, the settings of the
    method and of a model, and every line of the input's history."""
    lines = [f"Laboratory record of certificate {number}",
             f"generated {now:%Y-%m-%d %H:%M} UTC by enctools {__version__}", ""]
    for i, s in enumerate(report.sections, 1):
        lines.append(f"{RESULT.format(i)}: {s.source} ({s.kind}"
                     + (f", rig {s.rig_name})" if s.rig_name else ")"))
        settings = s.meta.get("settings")
        if isinstance(settings, dict) and settings:
            lines.append("  settings: " + ", ".join(f"{k}={_short(v)}"
                                                    for k, v in settings.items()))
        model = s.meta.get("model")
        if isinstance(model, dict) and model:
            lines.append("  model: " + ", ".join(f"{k}={_short(v)}" for k, v in model.items()))
        for line in s.history or ["(no history)"]:
            lines.append(f"  {line}")
        lines.append("")
    return printable_lines(lines) + "\n"     # paths and history come from files


def _short(value: Any) -> str:
    text = str(value)
    return text if len(text) <= 80 else text[:77] + "..."
