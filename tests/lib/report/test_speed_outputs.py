"""What the speed work must not change: the report draws every figure once and shows each
in the HTML and the PDF; a text or JSON report loads no plotting library; a command does
not load pandas; make-rom's CSV is the bytes Arrow's CSV writer gave."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from conftest import run
from test_report import make_deviations, make_interp, make_points, make_spectrum


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    """One input of each kind (no two alike, so no before/after comparison plot)."""
    d = tmp_path_factory.mktemp("speed-report")
    return [str(make_points(d / "table1.parquet", 1)), str(make_deviations(d / "dev.parquet")),
            str(make_interp(d / "interp.arrow")), str(make_spectrum(d / "spectrum.h5"))]


def _figure_count(inputs: list[str]) -> int:
    from enctools.report import plots
    from enctools.report.summary import build_report

    rep = build_report(inputs)
    return sum(len(plots.section_figures(s)) for s in rep.sections)


@pytest.mark.slow
def test_html_and_pdf_hold_every_figure(inputs, tmp_path):
    html, pdf = tmp_path / "r.html", tmp_path / "r.pdf"
    r = run(["enc", "report", *inputs, "--html", str(html), "--pdf", str(pdf)])
    assert r.returncode == 0, r.stderr.decode()
    count = _figure_count(inputs)
    assert count >= 7
    assert html.read_text().count("data:image/png;base64,") == count
    data = pdf.read_bytes()
    assert data.count(b"/Subtype /Image") == count           # each plot embedded once
    from pypdf import PdfReader
    pages = PdfReader(pdf).pages
    shown = sum(len(p.images) for p in pages)               # and shown once
    assert shown == count and len(pages) >= 2


@pytest.mark.slow  # the whole report drawn, to HTML and PDF
def test_each_figure_drawn_once_for_both_outputs(inputs, monkeypatch):
    from enctools.report import drawings, plots
    from enctools.report.html import to_html
    from enctools.report.pdf import to_pdf
    from enctools.report.summary import build_report

    drawn: list[int] = []
    real = plots.to_png

    def counted(fig, dpi=drawings.DPI):
        drawn.append(id(fig))
        return real(fig, dpi)

    monkeypatch.setattr(plots, "to_png", counted)
    rep = build_report(inputs)
    d = drawings.Drawings(rep)
    page = to_html(rep, None, "t", d)
    assert len(drawn) == _figure_count(inputs)
    to_pdf(rep, None, "t", d)
    assert len(drawn) == _figure_count(inputs)              # the PDF drew nothing again
    assert page.count("data:image/png") == len(drawn)


LOADED = ("import sys\nfrom enctools.cli.main import main\n"
          "try:\n    main(sys.argv[1:])\nexcept SystemExit as e:\n    code = e.code\n"
          "print(code, *sorted({m.split('.')[0] for m in sys.modules}), file=sys.stderr)\n")


def _modules_after(args: list[str]) -> tuple[str, set[str]]:
    r = subprocess.run([sys.executable, "-c", LOADED, *args], capture_output=True)
    last = r.stderr.decode().strip().splitlines()[-1].split()
    return last[0], set(last[1:])


@pytest.mark.parametrize("extra", [[], ["--json"]])
def test_text_and_json_report_load_no_matplotlib(inputs, extra):
    code, modules = _modules_after(["report", *inputs, *extra])
    assert code in ("None", "0")
    assert "matplotlib" not in modules
    assert "PIL" not in modules
    assert "enctools" in modules and "pyarrow" in modules   # it did run


def test_a_command_loads_no_pandas(inputs):
    pytest.importorskip("pandas")                         # only then could it be loaded
    code, modules = _modules_after(["report", inputs[0]])
    assert code in ("None", "0")
    assert "pandas" not in modules


def test_pandas_imports_again_after_a_command(inputs):
    pytest.importorskip("pandas")
    code = ("import sys\nfrom enctools.cli.main import main\n"
            f"try:\n    main(['report', {inputs[0]!r}])\nexcept SystemExit:\n    pass\n"
            "import pandas, pyarrow as pa\n"
            "print(pa.table({'a': [1.0, 2.0]}).to_pandas()['a'].sum())\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True)
    assert r.returncode == 0, r.stderr.decode()
    assert r.stdout.decode().split()[-1] == "3.0"


@pytest.mark.parametrize("width", [8, 16, 24, 32])
def test_make_rom_csv_is_the_bytes_arrow_csv_wrote(width):
    """The CSV writer against Arrow's CSV writer (its former implementation) on extremes."""
    import io

    import pyarrow as pa
    import pyarrow.csv as pcsv

    from enctools.models.romformats.csvtext import write_csv

    lo, hi = -(1 << (width - 1)), (1 << (width - 1)) - 1
    rng = np.random.default_rng(width)
    values = np.concatenate([[lo, hi, 0, -1, 1], rng.integers(lo, hi, 3000, endpoint=True)])
    got = io.BytesIO()
    write_csv(got, values, None, ["ignored"])  # type: ignore[arg-type]  # CSV needs no target
    want = io.BytesIO()
    want.write(b"address,correction\n")
    pcsv.write_csv(pa.table({"address": pa.array(np.arange(values.size, dtype=np.int64)),
                             "correction": pa.array(values.astype(np.int64))}),
                   want, pcsv.WriteOptions(include_header=False))
    assert got.getvalue() == want.getvalue()
