"""enc report: figures with the digits their uncertainty warrants (issue 33 item 4).

A curve of a few milliarcseconds (p-p 3.1 mas, a U of 0.24 mas: the graduation of a
good encoder after compensation, or a nanometre-level error written in arcsec) printed
with three fixed decimals read "p-p 0.003" and "U max 0.000". The one rule
(enctools.report.numbers, enc-report(1) NUMBERS): U to two significant digits, each
value to U's decade (GUM 7.2.6); figures without a U to four significant digits of the
largest shown together; the same strings in the text, the HTML and the PDF.
"""

from __future__ import annotations

import json
import math
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from conftest import run
from test_report import _meta

from enctools.data.schemas import make_field
from enctools.data.streams import Header, write_table
from enctools.units import TWO_PI

PP = 0.0031        # peak-to-peak of the curve [arcsec]
U_STD = 0.00012    # its standard uncertainty [arcsec]


def _small_curve(path: Path, grid: int = 720) -> Path:
    """A graduation error of 3.1 mas p-p with u 0.12 mas (its largest 0.18 mas)."""
    theta = np.arange(grid) * TWO_PI / grid
    eps = PP / 2 * np.sin(2 * theta)
    u = U_STD * (1 + 0.5 * np.cos(theta))
    schema = pa.schema([
        make_field("theta", pa.float64(), "rad"),
        make_field("graduation_II", pa.float64(), "arcsec", "deviation", encoder="II"),
        make_field("u_graduation_II", pa.float64(), "arcsec", "uncertainty",
                   of="graduation_II")])
    write_table(str(path), Header("deviations", schema, _meta("sjtu-dual", "enc selfcal")),
                pa.table([theta, eps, u], schema=schema), force=True)
    return path


def _two(U: float) -> int:
    """The decimals of U to two significant digits (GUM 7.2.6)."""
    return 1 - math.floor(math.log10(U))


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    """The text, the JSON summary, the HTML and pdftotext's -layout text of one report."""
    d = tmp_path_factory.mktemp("digits")
    dev = _small_curve(d / "small.parquet")
    html, pdf = d / "r.html", d / "r.pdf"
    r = run(["enc", "report", str(dev), "--html", str(html), "--pdf", str(pdf)])
    assert r.returncode == 0, r.stderr.decode()
    j = run(["enc", "report", "--json", str(dev)])
    assert j.returncode == 0, j.stderr.decode()
    text = ""
    if shutil.which("pdftotext"):
        text = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True,
                              text=True, check=True).stdout
    return r.stdout.decode(), json.loads(j.stdout), html.read_text(), text


def test_a_milliarcsecond_curve_prints_readable_figures(small):
    out, doc, _, _ = small
    curve = doc["sections"][0]["curves"][0]
    pp, U = curve["pp_arcsec"], curve["expanded_u_max_arcsec"]
    assert pp == pytest.approx(PP, rel=1e-3) and 2e-4 < U < 1e-3
    # before: 'p-p 0.003"' and 'max 0.000"' (three fixed decimals)
    assert 'p-p 0.003"' not in out and 'max 0.000"' not in out
    assert f'p-p {pp:.6f}"' in out                      # 4 significant digits: 0.003100
    assert f'max {U:.{_two(U)}f}"' in out               # two digits: 0.00036
    # each results row: U to two digits, the deviation to its decade, never all zero
    rows = doc["sections"][0]["results"][0]["rows"]
    assert len(rows) == 36
    for r in rows:
        U_i = r["expanded_u_arcsec"]
        d = _two(U_i)
        assert round(U_i, d) == U_i and d >= 5
        line = f"{r['target_deg']:.3f}  {r['deviation_arcsec']:.{d}f}  {U_i:.{d}f}"
        assert re.sub(r"-(0\.0+)\b", r"\1", line) in re.sub(r" +", "  ", out), line
    assert sum(abs(r["deviation_arcsec"]) > 5e-4 for r in rows) >= 20


def _summary_cells(page: str) -> list[str]:
    """The summary table's p-p, +/-, mean, s and U max of the HTML's first row."""
    table = page.split("<h2>Results</h2>", 1)[1].split("</table>", 1)[0]
    first = table.split("</th></tr>", 1)[1].split("</tr>", 1)[0]
    return re.findall(r"<td[^>]*>([^<]*)</td>", first)[4:9]


@pytest.mark.skipif(not shutil.which("pdftotext"), reason="poppler-utils not installed")
def test_the_same_strings_in_text_html_and_pdf(small):
    out, _, page, pdf = small
    figures = _summary_cells(page)
    assert len(figures) == 5 and all(re.fullmatch(r"-?\d+\.\d+", v) for v in figures)
    pp, pm, mean, s, U = figures
    assert all(float(v) != 0.0 for v in (pp, pm, s, U))       # before: U max "0.000"
    line = next(x for x in out.splitlines() if "p-p" in x)
    assert f'p-p {pp}"  +/-{pm}"  mean {mean}"  s {s}"' in line
    assert f'max {U}"' in out
    flat = " ".join(pdf.split())
    assert f"{pp} {pm} {mean} {s} {U}" in flat
    # the results per position: every row of the text in the HTML and in the PDF
    rows = [x.split() for x in out.splitlines() if re.match(r"\s+\d+\.000\s", x)]
    assert len(rows) == 36
    for cells in rows:
        assert "".join(f'<td align="right" class="r">{c}</td>' for c in cells) in page, cells
        assert " ".join(cells) in flat, cells


@pytest.mark.skipif(not shutil.which("pdftotext"), reason="poppler-utils not installed")
def test_a_budget_prints_the_same_u_and_U_in_text_html_and_pdf(tmp_path):
    """A step run's budget: u_c, U and every u_i once, to two significant digits (before:
    the text said 'u_c 0.07781 ... U 0.1531', the HTML and the PDF '0.078', '0.153')."""
    raw, points = tmp_path / "raw.parquet", tmp_path / "points.parquet"
    for cmd in (f"enc acquire --rig ciomp-23bit --mode steps --runs 3 --bidirectional "
                f"--readings 1 -q -o {raw}", f"enc points {raw} -q -o {points}"):
        r = run(cmd)
        assert r.returncode == 0, r.stderr.decode()
    html, pdf = tmp_path / "r.html", tmp_path / "r.pdf"
    r = run(["enc", "report", str(points), "--html", str(html), "--pdf", str(pdf)])
    assert r.returncode == 0, r.stderr.decode()
    out, page = r.stdout.decode(), html.read_text()
    flat = " ".join(subprocess.run(["pdftotext", "-layout", str(pdf), "-"], check=True,
                                   capture_output=True, text=True).stdout.split())
    head = re.search(r"u_c (\S+) .* U (\S+) \(", out)
    assert head is not None
    shown = list(head.groups()) + re.findall(r"-> u (\S+) \(dof", out)
    assert len(shown) >= 5
    for v in shown:                       # two significant digits each
        assert re.fullmatch(r"0\.0*[1-9]\d|[1-9]\.\d|[1-9]\d", v), v
    u_c, U = shown[:2]
    for v in (u_c, U):
        assert f">{v} arcsec</td>" in page and f"{v} arcsec" in flat, v
    cells = re.findall(r'<td align="right" class="r">([^<]*)</td><td align="right" '
                       r'class="r">(?:\d+|∞)</td></tr>', page)    # u_i, then nu_i
    assert sorted(cells) == sorted(shown[2:])


@pytest.mark.parametrize("nu, text, doc", [
    (math.inf, "inf", "∞"), (2.0, "2", "2"), (96.4, "96", "96"), (10_000.0, "10000", "10000"),
    (6446655606.0, "> 10000", "> 10000")])
def test_degrees_of_freedom_print_whole_and_a_huge_one_as_more_than_10000(nu, text, doc):
    """H - P on 3 revolutions: a Type A on 2 dof beside the reference's exact bound gives
    nu_eff 6446655606 by Welch-Satterthwaite (its k 1.960); the documents print "> 10000"
    (the JSON keeps the number)."""
    from enctools.report.numbers import fmt_dof

    assert fmt_dof(nu) == text and fmt_dof(nu, "∞") == doc


def test_a_comparison_budget_says_its_huge_nu_eff_as_more_than_10000(tmp_path):
    r = run("enc acquire --rig sjtu-dual --revolutions 3 --interval 0.012 -q -o raw.arrows "
            "&& enc average-heads raw.arrows -q | enc compare --device H --reference P -q "
            "-o hp.parquet && enc report hp.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    line = next(x for x in r.stdout.decode().splitlines() if "uncertainty budget (GUM)" in x)
    assert "nu_eff > 10000  k 1.960" in line, line
