"""What ``enc report`` does once its options are parsed: build, check, print, write."""

from __future__ import annotations

import datetime as _dt
import sys
from collections.abc import Callable, Sequence
from typing import Any

from enctools.data.files import OutputGroup, check_new_file
from enctools.data.header import output_time
from enctools.errors import CheckFailed, DataError, OutputError, SettingsError
from enctools.report.display import in_unit
from enctools.report.sections import Options
from enctools.report.summary import Report, build_report
from enctools.report.thresholds import Thresholds, check, in_words


def check_paths(paths: Sequence[str | None], force: bool) -> None:
    """Fail early when a report file cannot be written (exists without ``force``, no
    folder)."""
    for p in paths:
        if p is not None:
            check_new_file(p, force)


def _check_stdout() -> None:
    """OutputError when the process was started with stdout closed: nowhere to print."""
    if sys.stdout is None:
        msg = "stdout is closed: the report cannot be printed; give it a stdout (> FILE)"
        raise OutputError(msg)


def _recorded(report: Report, output: str | None) -> Report:
    """A copy of ``report`` whose sections name their files as ``output`` (None: stdout)
    records them (:func:`~enctools.data.header.recorded_word`): never an absolute path."""
    import copy

    from enctools.data.header import output_folder, recorded_word

    folder = output_folder(output)
    out = copy.copy(report)
    out.sections = []
    for s in report.sections:
        named = copy.copy(s)
        named.source = recorded_word(s.source, folder)
        out.sections.append(named)
    return out


def _print(report: Report, as_json: bool, failures: list[str] | None) -> None:
    """The report on stdout, as JSON (with ``failures``) or as text."""
    if as_json:
        from enctools.report.jsonout import to_json
        sys.stdout.write(to_json(_recorded(report, None), failures) + "\n")
    else:
        from enctools.report.text import write_text
        write_text(_recorded(report, None), sys.stdout)
    sys.stdout.flush()


def one_rig(report: Any) -> None:
    """A certificate is of one item on one rig: DataError naming the inputs of each
    rig when they come from several."""
    rigs: dict[str, list[str]] = {}
    for s in report.sections:
        if s.rig_name:
            rigs.setdefault(s.rig_name, []).append(s.source)
    if len(rigs) > 1:
        said = "; ".join(f"rig {name}: {', '.join(srcs)}" for name, srcs in rigs.items())
        msg = f"the inputs of one certificate come from {len(rigs)} rigs ({said}): give one rig's"
        raise DataError(msg)


def _documents(report: Any, shown: Any, failures: list[str], title: str | None, cert: Any,
               paths: tuple[str | None, str | None, str | None],
               step: Callable[[int], object]) -> None:
    """The HTML, the PDF and the laboratory's record (``paths``; None: not written), all
    or none; ``step(n)`` after the n-th document."""
    html_path, pdf_path, record_path = paths
    with OutputGroup() as outputs:  # every document, or none
        if html_path is None and pdf_path is None:
            return
        from enctools.report import customer
        from enctools.report.document import build, render
        from enctools.report.drawings import Drawings
        # a certificate names its results, not the laboratory's files
        seen = shown if cert is None else customer.view(shown)
        # each plot drawn once, the document's data built once, for the HTML and the PDF
        doc = build(_recorded(seen, html_path or pdf_path), failures, title, Drawings(seen),
                    cert)
        if record_path is not None:
            made = _dt.datetime.fromtimestamp(output_time(), _dt.UTC)
            outputs.write(record_path, customer.record(
                _recorded(report, record_path), cert.number, made).encode())
        done = 0
        if html_path is not None:
            outputs.write(html_path, render(doc, page=True).encode())
            done += 1
            step(done)
        if pdf_path is not None:
            from enctools.report.pdf import document_pdf
            outputs.write(pdf_path, document_pdf(doc))
            step(done + 1)


def run_report(sources: Sequence[str | None], opts: Options, limits: Thresholds, *,
               as_json: bool = False, html_path: str | None = None, pdf_path: str | None = None,
               title: str | None = None, history_dir: str | None = None,
               history_filter: dict[str, Any] | None = None,
               prog: str = "enc report", unit: str = "arcsec",
               progress: Callable[[int, int], object] | None = None,
               mapping: Any = None, cert: Any = None,
               words: Callable[[str], str] | None = None,
               record_path: str | None = None) -> None:
    """Build the report, print it on stdout, write HTML/PDF, then apply the thresholds.

    A threshold exceeded is one line on stderr each, headed by ``prog``. The text, HTML
    and PDF show angle errors in ``unit`` (:func:`~enctools.report.display.in_unit`);
    the JSON summary and the thresholds keep arcsec. ``history_filter``: the ``rig`` and
    ``since`` of the history's runs to read. ``progress(done, total)``: the inputs read
    and the HTML and PDF renderings. ``mapping``: how a user's table maps to points
    (``data.tablemap.Mapping``). ``cert``: the laboratory's fields (``certificate.
    Certificate``; None: a calibration report). ``words``: a threshold's field -> the
    words that name it (a command: its option; None: the field). ``record_path``: with
    ``cert``, where the laboratory's record of the certificate is written (the inputs'
    paths and history, which the certificate leaves out: :mod:`enctools.report.customer`).
    """
    _check_stdout()
    if record_path is not None and cert is None:
        msg = "a laboratory record is of a certificate: give `certificate_path`"
        raise SettingsError(msg)
    total = len(sources) + (html_path is not None) + (pdf_path is not None)

    def step(done: int) -> None:
        if progress is not None:
            progress(done, total)

    report = build_report(sources, opts, step, mapping)
    if history_dir is not None:
        from enctools.report.history import read_history
        report.history = read_history(history_dir, **(history_filter or {}))
    if cert is not None:
        from enctools.report import standards
        one_rig(report)
        standards.apply(report, cert)
    report.settings["thresholds"] = limits.to_dict()
    failures = in_words(check(report, limits), words)
    shown = in_unit(report, unit)
    _print(report if as_json else shown, as_json, failures if limits.any else None)
    _documents(report, shown, failures, title, cert, (html_path, pdf_path, record_path),
               lambda done: step(len(sources) + done))
    if failures:
        for line in failures:
            sys.stderr.write(f"{prog}: threshold exceeded: {line}\n")
        msg = f"{len(failures)} threshold(s) exceeded"
        raise CheckFailed(msg)
