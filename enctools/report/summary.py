"""The report of several inputs: one section per input, in the order given."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from enctools.data.streams import InputStream, open_input
from enctools.report.sections import DEFAULT_OPTIONS, Options, Section, build_section


@dataclass
class Report:
    """Sections of every input, plus the nightly history when asked for."""

    sections: list[Section] = field(default_factory=list)
    history: Any = None                 # history.History or None
    settings: dict[str, Any] = field(default_factory=dict)

    def curves(self, unit: str | None = None):
        """Every (section, curve) pair, optionally of one unit."""
        for s in self.sections:
            for c in s.curves:
                if unit is None or c.unit == unit:
                    yield s, c


def build_report(inputs: Sequence[str | None], opts: Options = DEFAULT_OPTIONS,
                 progress: Callable[[int], object] | None = None,
                 mapping: Any = None) -> Report:
    """Read every input (a path, or None/'-' for stdin) into its section;
    ``progress(done)`` is called with the inputs read. A user's table is read as points
    mapped by ``mapping`` (a ``data.tablemap.Mapping``; None: by its titles).

    Raises DataError (exit 2) naming the input when one cannot be read.
    """
    report = Report(settings={"top_harmonics": opts.top_harmonics, "nmax": opts.nmax,
                             "standard": opts.standard})
    for k, path in enumerate(inputs):
        with _open(path, mapping) as stream:
            report.sections.append(build_section(stream, opts))
        if progress is not None:
            progress(k + 1)
    return report


def _open(path: str | None, mapping: Any) -> InputStream:
    """A stream, or a user's table as a points stream (enc-points(1), TABLES)."""
    from enctools.data import usertables
    from enctools.methods.points import read_points

    if path is None or not usertables.is_table_file(path):
        return open_input(path)
    comma = bool(mapping and mapping.decimal_comma)
    header, points = read_points(usertables.read(path, comma), mapping, linear=True)
    return InputStream(header, iter(points.table().to_batches()), path, "table")
