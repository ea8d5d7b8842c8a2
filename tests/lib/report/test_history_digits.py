"""The nightly history's figures by the report's one rule (issue 33 item 4, the history).

A rig whose nightly curves are a few milliarcseconds (p-p 3.1 mas, s 0.87 mas, drifts of
0.42 mas) read "0.003 0.001 0.000" in ``enc history show`` and ``enc report --history``
(three fixed decimals), while the HTML beside it printed 0.003100. The history's text
now prints each figure as enctools.report.numbers.fmt does (enc-report(1) NUMBERS: four
significant digits, a run carrying no U): the same strings in the text and the HTML.
"""

from __future__ import annotations

import datetime as dt
import html
import re

import numpy as np
import pytest
from conftest import run_in_process

from enctools.report.history import append_run, read_history
from enctools.report.numbers import fmt, fmt_each

#: p-p, s, drift and tolerance of the nights [arcsec]: 3.1 mas curves, sub-mas drifts
NIGHTS = [(0.0031, 0.00087, 0.00042, 0.002), (0.00312, 0.000866, 0.000511, 0.002),
          (0.003087, 0.000871, 0.0, 0.002)]


def _history(root) -> None:
    for k, (pp, std, drift, tol) in enumerate(NIGHTS):
        append_run(root, {"rig": "lab-3", "run_id": f"n{k}", "status": "ok",
                          "time": dt.datetime(2026, 11, 1 + k, 2, 30, tzinfo=dt.UTC),
                          "pp": pp, "std": std, "drift_max": drift, "tolerance": tol})


@pytest.mark.heavy
def test_a_history_of_milliarcsecond_curves_prints_four_significant_digits(tmp_path):
    _history(tmp_path)
    lines = read_history(tmp_path).text_lines()
    rows = [line.split()[3:] for line in lines[2:5]]
    # before: ['0.003', '0.001', '0.000', '0.002'] on every night
    assert rows == [["0.003100", "0.0008700", "0.0004200", "0.002000"],
                    ["0.003120", "0.0008660", "0.0005110", "0.002000"],
                    ["0.003087", "0.0008710", "0.000", "0.002000"]]
    assert lines[-1].startswith('  drift: last 0.000", largest 0.0005110"')


def test_the_text_and_the_html_print_the_same_strings(tmp_path):
    _history(tmp_path / "h")
    page = tmp_path / "h.html"
    shown = run_in_process(["history", "show", str(tmp_path / "h"), "--html", str(page)])
    assert shown.returncode == 0, shown.stderr.decode()
    text_rows = [line.split()[3:] for line in shown.stdout.decode().splitlines()
                 if line.startswith("  2026-")]
    section = page.read_text().split("Nightly history", 1)[1]
    cells = [[html.unescape(c) for c in re.findall(r"<t[dh][^>]*>([^<]*)</t[dh]>", row)]
             for row in re.findall(r"<tr[^>]*>(.*?)</tr>", section, re.S)]
    html_rows = [row[3:7] for row in cells if row and row[0].startswith("2026-")]
    assert text_rows == html_rows and len(text_rows) == 3


@pytest.mark.parametrize("unit", ["arcsec", "urad", "mrad", "deg", "rad", "nm"])
def test_the_history_column_rule_is_fmt_value_by_value(unit):
    """fmt_each (a column of a million runs at once) gives fmt's string of each value."""
    rng = np.random.default_rng(33)
    values = np.concatenate([rng.normal(size=3000) * 10.0 ** rng.integers(-14, 7, 3000),
                             [0.0, -0.0, 9.9996, 9.99949, 0.00099996, -5.6e-17, 1e-3,
                              -0.0031, 0.0005, -0.0004999, np.nan, np.inf, -np.inf]])
    assert fmt_each(values, unit, "-") == [fmt(float(v), unit, missing="-") for v in values]
