"""enc report: seed 001 figures, each stream kind's section scored against the simulator's
truth, thresholds (the cron contract), HTML/PDF output, the Chromium screenshot, errors.

Streams of the kinds other commands make (deviations with uncertainties and radial
motion, interpolation errors within a signal period, spectra) are built here from the
simulator's ground truth through enctools.streams, following schemas/*.json.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import DATA, ROOT, run

from enctools.data.rig import load_rig
from enctools.data.schemas import make_field
from enctools.data.streams import Header, write_table
from enctools.data.truth import interpolation_error
from enctools.errors import DataError
from enctools.hw.sim_truth import make_truth
from enctools.units import ARCSEC, TWO_PI

U_STD = 0.02          # standard uncertainty given to the synthetic deviations [arcsec]


# ----------------------------------------------------------------- stream builders


def _meta(rig_name: str, command: str) -> dict:
    rig = load_rig(rig_name)
    return {"rig": rig.to_dict(), "truth": make_truth(rig).to_dict(),
            "history": [f"2026-11-26T00:00:00Z enctools test: {command}"]}


def make_deviations(path: Path, grid: int = 1440) -> Path:
    """Encoder II graduation error [arcsec] with a standard uncertainty, and the spindle
    radial motion x, y [nm] of its plane: the truth as a selfcal would report it."""
    rig = load_rig("sjtu-dual")
    truth = make_truth(rig)
    theta = np.arange(grid) * TWO_PI / grid
    eps = truth.graduation["II"].band(n_max=100)(theta)
    rad = truth.radial["II"]
    x = rad["x"].band(synchronous=True)(theta)
    y = rad["y"].band(synchronous=True)(theta)
    u = np.full(grid, U_STD) * (1 + 0.5 * np.cos(theta))
    schema = pa.schema([
        make_field("theta", pa.float64(), "rad"),
        make_field("graduation_II", pa.float64(), "arcsec", "deviation", encoder="II"),
        make_field("u_graduation_II", pa.float64(), "arcsec", "uncertainty", of="graduation_II"),
        make_field("radial_x", pa.float64(), "nm", "radial", axis="x"),
        make_field("radial_y", pa.float64(), "nm", "radial", axis="y")])
    table = pa.table([theta, eps, u, x, y], schema=schema)
    write_table(str(path), Header("deviations", schema, _meta("sjtu-dual", "enc selfcal")),
                table, force=True)
    return path


def make_interp(path: Path, grid: int = 256) -> Path:
    """Interpolation error of every head of encoder II against the phase [rad] within
    its signal period, as enc interp-check writes it."""
    rig = load_rig("sjtu-dual")
    truth = make_truth(rig)
    enc = next(e for e in rig.encoders if e.name == "II")
    phase = np.arange(grid) * TWO_PI / grid
    fields = [make_field("theta", pa.float64(), "rad")]
    cols = [phase]
    for h in enc.heads:
        fields.append(make_field(h.name, pa.float64(), "arcsec", "deviation", encoder="II",
                                 period_arcsec=TWO_PI / enc.periods_per_rev / ARCSEC))
        cols.append(interpolation_error(truth.signals[h.name], phase / enc.periods_per_rev,
                                        enc.periods_per_rev))
    schema = pa.schema(fields)
    meta = _meta("sjtu-dual", "enc interp-check") | {
        "domain": "signal period: theta is the phase the head reads"}
    write_table(str(path), Header("deviations", schema, meta), pa.table(cols, schema=schema),
                force=True)
    return path


def make_spectrum(path: Path, nmax: int = 60) -> Path:
    """The spectrum of encoder II's graduation error with u and |W(n)| of 0/60/135/228 deg."""
    truth = make_truth(load_rig("sjtu-dual"))
    c = truth.graduation["II"].harmonics(nmax)
    n = np.arange(nmax + 1)
    alphas = np.radians([60.0, 135.0, 228.0])
    w = np.abs(np.exp(1j * np.outer(n, alphas)) - 1).min(axis=1)
    schema = pa.schema([make_field("n", pa.int64(), ""),
                        make_field("amplitude", pa.float64(), "arcsec"),
                        make_field("phase", pa.float64(), "rad"),
                        make_field("u_amplitude", pa.float64(), "arcsec", "uncertainty",
                                   of="amplitude"),
                        make_field("transfer", pa.float64(), "")])
    u = 0.005 / np.maximum(w, 0.1)
    table = pa.table([n, np.abs(c), np.angle(c), u, w], schema=schema)
    write_table(str(path), Header("spectrum", schema, _meta("sjtu-dual", "enc selfcal")
                                  | {"blind": [0]}), table, force=True)
    return path


def make_points(path: Path, table_no: int) -> Path:
    """Seed 001 table N as a points stream, through enctools.data.streams (no enc points)."""
    rows = [line.split(",") for line in (DATA / f"seed001_table{table_no}.csv").read_text()
            .splitlines() if line and not line.startswith("#") and line[0].isdigit()]
    pos, dev = np.array(rows, dtype=float).T
    schema = pa.schema([make_field("position", pa.float64(), "rad"),
                        make_field("deviation", pa.float64(), "arcsec")])
    write_table(str(path), Header("points", schema, {"source": f"seed 001 table {table_no}"}),
                pa.table([np.radians(pos), dev], schema=schema), force=True)
    return path


@pytest.fixture(scope="module")
def streams(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("report-streams")
    out = {"deviations": make_deviations(d / "selfcal.parquet"),
           "interp": make_interp(d / "interp.arrow"),
           "spectrum": make_spectrum(d / "spectrum.h5")}
    for t in (1, 2, 3):
        out[f"table{t}"] = make_points(d / f"table{t}.parquet", t)
    return out


@pytest.fixture(scope="module")
def iso_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 5-run bidirectional polygon run (24 positions, 1 reading each) as points."""
    d = tmp_path_factory.mktemp("iso")
    raw = d / "raw.parquet"
    r = run(f"enc acquire --rig ciomp-23bit --mode steps --runs 5 --bidirectional "
            f"--readings 1 -o {raw}")
    assert r.returncode == 0, r.stderr.decode()
    return raw


def report_json(*args: str) -> dict:
    r = run(["enc", "report", "--json", *map(str, args)])
    assert r.returncode == 0, r.stderr.decode()
    return json.loads(r.stdout)


# ------------------------------------------------------------------ seed 001 tables


@pytest.mark.parametrize("table_no, pp, std, paper_std", [
    (1, 5.46, 1.2674, 1.30),    # paper prints 1.30 (no convention over the table gives it)
    (2, 1.97, 0.5097, 0.4989),  # paper 0.4989: the s of the 25 rows as listed (0.499)
    (3, 2.29, 0.5291, 0.5264),  # paper 0.5264
])
@pytest.mark.slow
def test_seed001_tables_through_enc_points(table_no, pp, std, paper_std):
    """CSV -> enc points -> enc report: p-p and Bessel s over the positions modulo 360 deg
    (a closing 360 deg row is the 0 deg position again), against numpy on the table."""
    rows = np.loadtxt(DATA / f"seed001_table{table_no}.csv", delimiter=",", skiprows=3)
    one = rows[np.mod(rows[:, 0], 360.0) < 360.0 - 1e-9]
    if table_no < 3:   # tables 1 and 2 close with a 360 deg row equal to the 0 deg one
        assert rows[-1, 0] == 360.0 and rows[-1, 1] == rows[0, 1]
        one = rows[:-1]
    assert np.std(one[:, 1], ddof=1) == pytest.approx(std, abs=5e-5)
    r = run(f"enc points {DATA}/seed001_table{table_no}.csv | enc report --json")
    assert r.returncode == 0, r.stderr.decode()
    curve = json.loads(r.stdout)["sections"][0]["curves"][0]
    assert curve["n_points"] == 24
    assert curve["pp_arcsec"] == pytest.approx(pp, abs=1e-9)
    assert curve["s_bessel_arcsec"] == pytest.approx(std, abs=5e-5)
    assert "Bessel" in curve["std_convention"]
    # the paper's figures: table 3 within 0.003", table 2 0.011" off, table 1 0.033" off
    assert abs(curve["s_bessel_arcsec"] - paper_std) < {1: 0.034, 2: 0.012, 3: 0.003}[table_no]


def test_seed001_table1_conventions(streams):
    """Table 1: 25 rows, 24 positions (360 deg is 0 deg); s over them 1.267", the figure
    enc points and enc fit-rbf give; not the paper's 1.30 (stated in enc-report(1))."""
    r = run(["enc", "report", str(streams["table1"])])
    assert r.returncode == 0
    out = r.stdout.decode()
    assert 'n=24  p-p 5.460"' in out and 's 1.267" (Bessel n-1' in out
    assert "positions: 24" in out and "points: 25" in out
    c = report_json(streams["table1"])["sections"][0]["curves"][0]
    assert c["s_bessel_arcsec"] == pytest.approx(1.2674, abs=1e-4)
    assert c["pm_arcsec"] == pytest.approx(2.73)


# ------------------------------------------------------------- sections vs the truth


def test_deviations_section_against_truth(streams):
    truth = make_truth(load_rig("sjtu-dual"))
    eps = truth.graduation["II"].band(n_max=100)
    grid = np.arange(1440) * TWO_PI / 1440
    sec = report_json(streams["deviations"])["sections"][0]
    grad, rx, ry = sec["curves"]
    assert grad["pp_arcsec"] == pytest.approx(np.ptp(eps(grid)), rel=1e-9)
    assert grad["expanded_u_max_arcsec"] == pytest.approx(2 * 1.5 * U_STD, rel=1e-9)  # U = 2u
    # the largest harmonic and its phase, against c_n of the truth
    c = eps.harmonics(100)
    n_big = int(np.argmax(np.abs(c[1:]))) + 1
    top = grad["harmonics"][0]
    assert top["n"] == n_big
    assert top["amplitude_arcsec"] == pytest.approx(abs(c[n_big]), abs=1e-6)
    assert top["phase_rad"] == pytest.approx(np.angle(c[n_big]), abs=1e-6)
    assert rx["unit"] == "nm" and rx["pp_nm"] > 0 and ry["pp_nm"] > 0


def test_interp_section_per_period(streams):
    truth = make_truth(load_rig("sjtu-dual"))
    sec = report_json(streams["interp"])["sections"][0]
    assert sec["domain"] == "period"
    assert [c["head"] for c in sec["curves"]] == ["H1", "H2", "H3", "H4", "H5", "H6", "H7"]
    assert sec["info"]["signal period"] == "24.92 arcsec"
    phase = np.arange(256) * TWO_PI / 256
    for c in sec["curves"]:
        want = interpolation_error(truth.signals[c["head"]], phase / 52000, 52000)
        assert c["pp_arcsec"] == pytest.approx(np.ptp(want), rel=1e-9)
        # harmonics are counted per signal period: 1st and 2nd dominate (seed 000 sec. 4)
        assert {h["n"] for h in c["harmonics"][:2]} <= {1, 2}


def test_harmonics_of_a_grid_finer_than_1e4_of_a_turn():
    """A uniform 20000-point curve (selfcal --points 20000) keeps its harmonics: its
    points once counted as one position, and the report listed no harmonic."""
    from enctools.report.figures import harmonics
    x = np.arange(20000) * (TWO_PI / 20000) + 0.25
    y = 1.5 * np.cos(3 * x + 0.4) + 0.2 * np.cos(7 * x - 1.0) + 0.1
    h = harmonics(x, y, 10)
    assert list(h.n) == list(range(11))
    assert h.amplitude_of(3) == pytest.approx(1.5, abs=1e-9)
    assert h.amplitude_of(7) == pytest.approx(0.2, abs=1e-9)
    assert h.amplitude_of(0) == pytest.approx(0.1, abs=1e-9)
    assert h.phase[3] == pytest.approx(0.4, abs=1e-9)
    assert h.phase[7] == pytest.approx(-1.0, abs=1e-9)


def test_spectrum_section_U_and_transfer(streams):
    sec = report_json(streams["spectrum"], "--top", "3")["sections"][0]
    rows = sec["spectra"][0]["harmonics"]
    assert len(rows) == 3
    amplitudes = [row["amplitude_arcsec"] for row in rows]
    assert amplitudes == sorted(amplitudes, reverse=True)
    for row in rows:
        w = row["transfer"]
        assert row["expanded_u_arcsec"] == pytest.approx(2 * 0.005 / max(w, 0.1))
    assert sec["info"]["blind harmonics"] == "0"


@pytest.mark.slow
def test_iso230_from_a_polygon_run_against_truth(iso_run):
    """enc acquire (5 bidirectional runs) | enc points | enc report: ISO 230-2 figures.
    The mean bidirectional deviation per position follows the truth's graduation error
    averaged over F1/F2 within 0.1" RMS and 0.25" at worst (what is left: the polygon's
    face errors, 0.05" each, and 10 readings' noise per position)."""
    r = run(f"enc points {iso_run} | enc report --json")
    assert r.returncode == 0, r.stderr.decode()
    sec = json.loads(r.stdout)["sections"][0]
    iso = sec["iso230_2"]
    assert len(iso["positions"]) == 24
    assert all(p["n_up"] == 5 and p["n_down"] == 5 for p in iso["positions"])
    axis = iso["axis"]
    assert axis["R"] >= max(axis["R_up"], axis["R_down"])
    assert axis["A"] >= axis["E"] >= axis["M"]
    # truth: head average of encoder A at the targets, relative to position 0
    meta_truth = _truth_of(iso_run)
    pos = np.radians([p["position_deg"] for p in iso["positions"]])
    eps = meta_truth.graduation["A"]
    avg = (eps(pos) + eps(pos + np.pi)) / 2
    want = avg - avg[0]
    got = -np.array([p["mean"] for p in iso["positions"]])     # x = -deviation
    resid = (got - got[0]) - want
    assert np.sqrt(np.mean(resid ** 2)) < 0.1 and np.max(np.abs(resid)) < 0.25
    # noise: 0.05" per head -> s of a position about 0.05/sqrt(2) plus positioning
    s_all = [p["s_up"] for p in iso["positions"][1:]]
    assert 0.01 < np.median(s_all) < 0.2


def _truth_of(path: Path):
    from enctools.data.streams import open_input
    from enctools.data.truth import Truth
    with open_input(str(path)) as s:
        return Truth.from_dict(s.meta["truth"])


@pytest.mark.slow
def test_readings_section_steps_and_signals(tmp_path, ciomp_steps):
    sweep = tmp_path / "sweep.parquet"
    r = run(f"enc acquire --rig ciomp-23bit --mode sweep --signals -o {sweep}")
    assert r.returncode == 0, r.stderr.decode()
    out = report_json(ciomp_steps, sweep)
    steps, sw = out["sections"]
    assert steps["info"]["mode"] == "steps" and steps["info"]["positions"] == 24
    # the axis servo holds the encoder on target: encoder - target is small
    assert steps["curves"][0]["pp_arcsec"] < 0.5
    assert sw["kind"] == "readings" and "F1" in sw["info"]["heads"]


@pytest.mark.slow
def test_model_section_evaluates_the_model(tmp_path):
    model = tmp_path / "model.parquet"
    r = run(f"enc fit-rbf {DATA}/seed001_table1.csv -o {model}")
    if r.returncode != 0:
        pytest.skip("enc fit-rbf not available: " + r.stderr.decode()[:100])
    sec = report_json(model)["sections"][0]
    c = sec["curves"][0]
    assert c["role"] == "model" and c["n_points"] == 720
    # the RBF network passes through table 1 (seed 001: training goal 1e-4"), p-p ~ 5.46
    assert c["pp_arcsec"] == pytest.approx(5.46, abs=0.3)


# ---------------------------------------------------------------------- thresholds


def test_threshold_exceeded_exit1_reason_on_stderr_summary_on_stdout(streams):
    r = run(["enc", "report", str(streams["table1"]), str(streams["table2"]),
             "--max-pp", "3", "--max-std", "1.0", "--max-harmonic", "2:0.5"])
    assert r.returncode == 1
    err = r.stderr.decode().splitlines()
    assert any("p-p of deviation in" in e and "table1" in e and "--max-pp 3" in e for e in err)
    assert any("s (Bessel)" in e and "--max-std 1" in e for e in err)
    assert any("harmonic 2" in e and "--max-harmonic 2:0.5" in e for e in err)
    assert not any("table2" in e for e in err)          # table 2 is within every limit
    assert err[-1] == "enc report: error: 3 threshold(s) exceeded"
    out = r.stdout.decode()
    assert 'p-p 5.460"' in out and 's 0.510"' in out     # the summary is still there


def test_threshold_within_limits_exit0_and_json_says_ok(streams):
    r = run(["enc", "report", "--json", str(streams["table2"]), "--max-pp", "2",
             "--max-std", "0.51"])
    assert r.returncode == 0, r.stderr.decode()
    assert json.loads(r.stdout)["thresholds"] == {"exceeded": [], "ok": True}


def test_max_u_fails_on_a_result_that_states_no_u(streams):
    """Seed 001's table 2 as printed has one value a face and no budget: no U, so a
    limit on U cannot be shown met and fails (exit 1), naming the option."""
    r = run(["enc", "report", "--json", str(streams["table2"]), "--max-u", "1"])
    assert r.returncode == 1, r.stderr.decode()
    (line,) = json.loads(r.stdout)["thresholds"]["exceeded"]
    assert "states no U" in line and "--max-u 1 cannot be checked" in line


@pytest.mark.slow
def test_threshold_iso_and_u_and_radial(streams, iso_run):
    r = run(f"enc points {iso_run} | enc report - {streams['deviations']} --max-iso R:0.01 "
            f"--max-u 0.01 --max-radial-pp 1")
    assert r.returncode == 1
    err = r.stderr.decode()
    assert "ISO 230-2 R of stdin" in err and "--max-iso R:0.01" in err
    assert "U (k=2) of graduation_II" in err
    assert "radial_x" in err and "nm > --max-radial-pp 1" in err


# --------------------------------------------------------------- HTML, PDF, Chromium


@pytest.fixture(scope="module")
def demo_html(tmp_path_factory, streams, iso_run) -> Path:
    d = tmp_path_factory.mktemp("html")
    sweep = d / "sweep.parquet"
    points = d / "points.parquet"
    r = run(f"enc acquire --rig sjtu-dual --mode sweep --signals --range 5 -o {sweep} && "
            f"enc points {iso_run} -o {points}")
    assert r.returncode == 0, r.stderr.decode()
    html = d / "report.html"
    r = run(["enc", "report", str(streams["table1"]), str(streams["table2"]),
             str(streams["deviations"]), str(streams["interp"]), str(streams["spectrum"]),
             str(points), str(sweep), "--html", str(html), "--max-pp", "6"])
    assert r.returncode == 0, r.stderr.decode()
    return html


@pytest.mark.slow
def test_html_report_stands_alone(demo_html):
    text = demo_html.read_text()
    assert text.startswith("<!DOCTYPE html>")
    assert "src=\"http" not in text and "<script" not in text       # nothing fetched
    for part in ("Rig and method", "(before / after compensation)", "ISO 230-2 (2014)",
                 "Lissajous", "Interpolation error per head", "radial error motion",
                 "with U band (k=2)", "How these data were made",
                 "<b>Conforms</b> to every limit given"):
        assert part in text, part
    assert text.count("data:image/png;base64,") >= 10


@pytest.mark.slow
def test_pdf_report(streams, tmp_path):
    pdf = tmp_path / "r.pdf"
    r = run(["enc", "report", str(streams["table1"]), "--pdf", str(pdf), "--max-pp", "1"])
    assert r.returncode == 1                       # the check fails, the PDF is still written
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF") and data.rstrip().endswith(b"%%EOF")
    assert data.count(b"/Type /Page") >= 3        # text page, deviation, spectrum


@pytest.mark.slow
def test_every_plot_has_axes_with_units(streams, iso_run):
    from enctools.report import plots
    from enctools.report.summary import build_report
    rep = build_report([str(streams[k]) for k in ("table1", "deviations", "interp", "spectrum")])
    figs = [f for s in rep.sections for _, f in plots.section_figures(s)]
    assert len(figs) >= 7
    for fig in figs:
        for ax in fig.axes:
            label = ax.get_xlabel() + " " + ax.get_ylabel()
            assert "[" in ax.get_xlabel() and "]" in ax.get_xlabel(), ax.get_title()
            if ax.name != "polar":
                assert "[" in ax.get_ylabel(), ax.get_title()
            assert any(u in label for u in ("arcsec", "nm", "deg", "V", "rev", "period"))


def _titled_plot(values, title: str):
    from matplotlib.figure import Figure

    from enctools.report import plots
    fig = Figure(figsize=plots.SIZE)
    ax = fig.add_subplot()
    x = np.linspace(0.0, 360.0, 50)
    ax.plot(x, values(np.radians(x)))
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("angle [deg]")
    ax.set_ylabel("deviation [rad]")
    return fig


@pytest.mark.heavy
@pytest.mark.parametrize("values", [np.sin, lambda x: 1000 + np.sin(x),
                                    lambda x: 1e-9 * np.sin(x), lambda x: 1e-6 + 1e-9 * np.sin(x)],
                         ids=["plain", "offset", "power of ten", "both"])
def test_plot_title_where_matplotlib_would_put_it(values, monkeypatch):
    """A title placed at once (not measured against every tick label) is drawn where
    matplotlib's own placement draws it, also when the y axis writes an offset or a power
    of ten above its ticks, which a long title must clear."""
    from enctools.report import plots
    long = "deviation — " + "a-long-file-name-" * 5 + ".parquet"
    ours = [plots.to_png(_titled_plot(values, t)) for t in ("short", long)]
    monkeypatch.setattr(plots, "_title_in_place", lambda ax: None)
    assert ours == [plots.to_png(_titled_plot(values, t)) for t in ("short", long)]


@pytest.mark.heavy
def test_plot_title_clears_the_power_of_ten(monkeypatch):
    """The case above can fail: at the top edge, a long title would cover the y axis's
    power of ten."""
    from enctools.report import plots
    long = "deviation — " + "a-long-file-name-" * 5 + ".parquet"
    placed = plots.to_png(_titled_plot(lambda x: 1e-9 * np.sin(x), long))
    monkeypatch.setattr(plots, "_title_in_place", lambda ax: ax.set_title(
        ax.get_title(), fontsize=ax.title.get_fontsize(), y=1.0))
    assert placed != plots.to_png(_titled_plot(lambda x: 1e-9 * np.sin(x), long))


def test_report_collects_less_then_as_before(streams, monkeypatch):
    """enc report runs with a young generation of YOUNG_OBJECTS and gives the
    collector's thresholds back when it ends (an in-process run keeps them)."""
    import gc

    from conftest import run_in_process

    from enctools.cli import tuning
    from enctools.report import output
    seen = []
    monkeypatch.setattr(output, "run_report", lambda *a, **k: seen.append(gc.get_threshold()))
    before = gc.get_threshold()
    r = run_in_process(["report", str(streams["table1"])])
    assert r.returncode == 0, r.stderr
    assert seen == [(tuning.YOUNG_OBJECTS, *before[1:])]
    assert gc.get_threshold() == before
    with tuning.collect_less(1234):
        assert gc.get_threshold() == (1234, *before[1:])
    assert gc.get_threshold() == before


@pytest.mark.skipif(not Path("/usr/bin/chromium").exists(), reason="chromium not installed")
@pytest.mark.slow
def test_html_report_renders_in_headless_chromium(demo_html, tmp_path):
    png = tmp_path / "report.png"
    r = run([str(ROOT / "bin" / "enc-report-screenshot"), str(demo_html), str(png),
             "1000", "1600"], timeout=120)
    assert r.returncode == 0, r.stderr.decode()
    import matplotlib.image as mpimg
    img = mpimg.imread(str(png))
    assert img.shape[0] == 1600 and img.shape[1] == 1000
    # not a blank page: text and plot lines make dark pixels, the page is mostly white
    gray = img[..., :3].mean(axis=2)
    assert 0.005 < np.mean(gray < 0.5) < 0.3


# ---------------------------------------------------------------------------- errors


@pytest.mark.parametrize("args, needle", [
    (["/nonexistent.parquet"], "/nonexistent.parquet: no such file"),
    (["--max-harmonic", "two:1", "X"], "--max-harmonic wants KEY:VALUE"),
    (["--max-harmonic", "0:1", "X"], "harmonic order must be >= 1"),
    (["--max-iso", "Q:1", "X"], "unknown ISO 230-2 figure 'Q'"),
    (["--max-pp", "-1", "X"], "--max-pp"),
    (["--top", "0", "X"], "--top"),
])
def test_bad_usage_one_line_exit2(args, needle, streams):
    args = [str(streams["table1"]) if a == "X" else a for a in args]
    r = run(["enc", "report", *args])
    assert r.returncode == 2
    err = r.stderr.decode().strip().splitlines()
    assert len(err) == 1 and err[0].startswith("enc report: error:") and needle in err[0]


def test_nan_input_exit2_and_no_html_left(tmp_path):
    schema = pa.schema([make_field("position", pa.float64(), "rad"),
                        make_field("deviation", pa.float64(), "arcsec")])
    bad = tmp_path / "bad.parquet"
    with pytest.raises(DataError, match="NaN"):  # enctools writes no such stream
        write_table(str(bad), Header("points", schema, {}),
                    pa.table([[0.0, 15.0, 30.0, 45.0], [0.0, np.nan, 1.0, 2.0]], schema=schema))
    pq.write_table(pa.table([[0.0, 15.0, 30.0, 45.0], [0.0, np.nan, 1.0, 2.0]],
                            schema=Header("points", schema, {}).arrow_schema()), bad)
    html = tmp_path / "r.html"
    r = run(["enc", "report", str(bad), "--html", str(html)])
    assert r.returncode == 2
    assert r.stderr.decode().startswith("enc report: error:") and "NaN" in r.stderr.decode()
    assert not html.exists() and not list(tmp_path.glob(".r.html*"))


@pytest.mark.slow
def test_existing_html_needs_force(streams, tmp_path):
    html = tmp_path / "r.html"
    html.write_text("old")
    r = run(["enc", "report", str(streams["table2"]), "--html", str(html)])
    assert r.returncode == 2 and "use --force" in r.stderr.decode()
    assert html.read_text() == "old"
    r = run(["enc", "report", str(streams["table2"]), "--html", str(html), "--force"])
    assert r.returncode == 0 and html.read_text().startswith("<!DOCTYPE html>")


def test_not_a_stream_exit2(tmp_path):
    junk = tmp_path / "junk.bin"
    junk.write_bytes(b"\xa4hello world, not a stream")
    r = run(["enc", "report", str(junk)])
    assert r.returncode == 2 and "neither an Arrow, Parquet or HDF5 stream nor a text table" \
        in r.stderr.decode()


def test_stdin_and_closed_pipe(streams):
    r = run(f"cat {streams['deviations']} | enc report | head -1")
    assert r.returncode == 0 and r.stdout.decode().startswith("stdin: deviations")
    assert r.stderr == b""


def test_report_help_is_documented_in_man_page():
    page = (ROOT / "man" / "enc-report.1").read_text()
    from enctools.cli.report import command
    for p in command.params:
        for opt in p.opts:
            if opt.startswith("-"):
                assert opt.replace("-", r"\-") in page, opt
    if shutil.which("man"):
        r = run("MANWIDTH=80 man --warnings -l " + str(ROOT / "man" / "enc-report.1")
                + " 2>&1 >/dev/null")
        assert r.stdout == b"", r.stdout.decode()


# ------------------------------------------------------- through the real pipeline


def _have(*commands: str) -> bool:
    r = run("enc --help")
    return all(f"  {c} " in r.stdout.decode() for c in commands)


@pytest.mark.skipif(not _have("selfcal", "compare", "interp-check"),
                    reason="selfcal/compare/interp-check not available")
@pytest.mark.slow
def test_real_pipeline_selfcal_compare_interp(sjtu_raw, tmp_path):
    """enc acquire | enc selfcal / compare / interp-check | enc report: every section is
    read, its figures equal the columns' own (numpy on the file), the HTML is written."""
    d = tmp_path
    r = run(f"enc selfcal {sjtu_raw} --spectrum {d}/spec.parquet -o {d}/selfcal.parquet && "
            f"enc compare {sjtu_raw} --device H1 --reference P1,P2 -o {d}/compare.parquet && "
            f"enc acquire --rig sjtu-dual --mode sweep | enc interp-check -o {d}/interp.parquet")
    assert r.returncode == 0, r.stderr.decode()
    files = [d / f for f in ("selfcal.parquet", "spec.parquet", "compare.parquet",
                             "interp.parquet")]
    out = report_json(*files)
    kinds = [s["kind"] for s in out["sections"]]
    assert kinds == ["deviations", "spectrum", "deviations", "deviations"]
    import pyarrow.parquet as pq
    for sec, f in zip(out["sections"], files):
        if sec["kind"] != "deviations":
            continue
        t = pq.read_table(f)
        for c in sec["curves"]:
            col = t.column(c["name"]).to_numpy()
            assert c[f"pp_{c['unit']}"] == pytest.approx(np.ptp(col), rel=1e-12)
            assert c[f"s_bessel_{c['unit']}"] == pytest.approx(np.std(col, ddof=1), rel=1e-12)
    selfcal, _, _, interp = out["sections"]
    assert {c["unit"] for c in selfcal["curves"]} == {"arcsec", "nm"}
    assert any(k.startswith("expanded_u_max_") for c in selfcal["curves"] for k in c)
    assert interp["domain"] == "period"
    assert all(c["harmonics"][0]["n"] in (1, 2) for c in interp["curves"])
    # the graduation error the self-calibration found vs the truth: p-p within 0.1"
    truth = _truth_of(d / "selfcal.parquet")
    grid = np.arange(1024) * TWO_PI / 1024
    grad = next(c for c in selfcal["curves"] if c["unit"] == "arcsec")
    want = truth.graduation["II"].band(n_max=100)(grid)
    assert grad["pp_arcsec"] == pytest.approx(np.ptp(want), abs=0.1)


def test_rom_section_counts(tmp_path):
    """A correction table: figures in counts over the addresses, not checked by --max-pp."""
    size = 4096
    address = np.arange(size)
    corr = np.round(-20 * np.sin(2 * TWO_PI * address / size)).astype(np.int64)
    schema = pa.schema([make_field("address", pa.int64(), ""),
                        make_field("correction", pa.int64(), "count")])
    rom = tmp_path / "rom.parquet"
    write_table(str(rom), Header("rom", schema, {"rom": {"size": size, "bits": 12}}),
                pa.table([address, corr], schema=schema))
    r = run(["enc", "report", "--json", str(rom), "--max-pp", "1"])
    assert r.returncode == 0, r.stderr.decode()
    sec = json.loads(r.stdout)["sections"][0]
    c = sec["curves"][0]
    assert c["unit"] == "count" and c["pp_count"] == 40 and c["harmonics"][0]["n"] == 2
    assert sec["info"]["bits"] == 12
