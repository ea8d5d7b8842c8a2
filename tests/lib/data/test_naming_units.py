"""One naming rule for columns and one unit per kind of quantity (issue 19, item 5).

- every column of every stream a command writes carries ``unit`` in its field metadata;
  angles (grid angles, positions, centres, targets, phases) are rad, angle errors
  arcsec, radial motion nm; an uncertainty column is ``u_`` + the curve its field
  metadata ``of`` names;
- points and model streams of schema v1 (position, centre in deg) read the same as v2
  (rad);
- the library converts angles through enctools.units only (no literal constants);
- ``enc report --unit`` shows angle errors in the unit asked for, on every axis too.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import DATA, ROOT, run

from enctools.data.schemas import make_field
from enctools.data.streams import Header, read_table, write_table

#: one arcsecond in microradians: pi / 648000 * 1e6, written out (not from enctools)
URAD_PER_ARCSEC = 4.8481368

#: the unit of each column (by name) or role of each kind: one per kind of quantity
UNITS = {
    ("readings", "t"): "s", ("readings", "target"): "rad", ("readings", "head"): "count",
    ("readings", "step"): "", ("readings", "run"): "", ("readings", "direction"): "",
    ("readings", "probe"): "m", ("readings", "autocollimator"): "arcsec",
    ("readings", "signal"): "V",
    ("deviations", "theta"): "rad", ("deviations", "deviation"): "arcsec",
    ("deviations", "radial"): "nm",
    ("spectrum", "n"): "", ("spectrum", "amplitude"): "arcsec", ("spectrum", "phase"): "rad",
    ("spectrum", "re"): "arcsec", ("spectrum", "im"): "arcsec", ("spectrum", "transfer"): "",
    ("spectrum", "curve"): "",
    ("points", "position"): "rad", ("points", "deviation"): "arcsec",
    ("points", "direction"): "", ("points", "run"): "", ("points", "reference"): "rad",
    ("model", "centre"): "rad", ("model", "n"): "", ("model", "weight"): "arcsec",
    ("model", "weight_sin"): "arcsec",
    ("rom", "address"): "", ("rom", "correction"): "count",
}


def _fm(field: pa.Field) -> dict[str, str]:
    return {k.decode(): v.decode() for k, v in (field.metadata or {}).items()}


@pytest.fixture(scope="module")
def outputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The streams of every command that writes one, from one short run and table 1."""
    d = tmp_path_factory.mktemp("naming")
    steps = [
        "enc acquire --rig sjtu-dual --revolutions 2 --interval 0.00505 -o raw.arrows",
        "enc selfcal raw.arrows --method esa --spectrum selfcal-spectrum.parquet "
        "-o selfcal.parquet",
        "enc average-heads raw.arrows -o avg.parquet",
        "enc compare avg.parquet --device H --reference P --spectrum compare-spectrum.parquet "
        "-o compare.parquet",
        "enc interp-check raw.arrows --heads H1 --reference P1 --spectrum interp-spectrum.parquet "
        "-o interp.parquet",
        f"enc points {DATA}/seed001_table1.csv -o points.parquet",
        "enc fit-rbf points.parquet -o model.parquet",
        "enc fit-rbf points.parquet --kernel fourier -o fourier.parquet",
        "enc make-rom model.parquet --bits 10 --target stream --allow-no-gain --allow-coarse "
        "-o rom.parquet",
        "enc acquire --rig ciomp-23bit --mode steps --runs 2 --bidirectional -o steps.parquet",
    ]
    r = run(" && ".join(steps), cwd=d)
    assert r.returncode == 0, r.stderr.decode()
    return {p.stem: p for p in d.iterdir() if p.suffix in (".parquet", ".arrows")}


@pytest.mark.slow
def test_every_column_names_its_unit_one_per_kind_of_quantity(outputs):
    kinds = set()
    for name, path in outputs.items():
        header, _ = read_table(str(path))
        kinds.add(header.kind)
        for f in header.schema:
            fm = _fm(f)
            assert "unit" in fm, f"{name}: column {f.name!r} has no unit"
            role = fm.get("role")
            if role == "uncertainty":
                of = header.schema.field(fm["of"])
                assert fm["unit"] == _fm(of)["unit"], (name, f.name)
                continue
            key = (header.kind, f.name) if (header.kind, f.name) in UNITS \
                else (header.kind, role)
            assert key in UNITS, f"{name}: column {f.name!r} (role {role}) unknown here"
            assert fm["unit"] == UNITS[key], (name, f.name, fm["unit"])
    assert kinds == {"readings", "deviations", "spectrum", "points", "model", "rom"}


@pytest.mark.slow
def test_every_uncertainty_column_is_u_and_the_curve_it_qualifies(outputs):
    seen = []
    for name, path in outputs.items():
        header, _ = read_table(str(path))
        uncertain = {f.name: _fm(f).get("of") for f in header.schema
                     if _fm(f).get("role") == "uncertainty" or f.name.startswith("u_")}
        if header.kind in ("deviations", "spectrum"):
            assert uncertain, f"{name} has no uncertainty column"
        for col, of in uncertain.items():
            assert of in header.schema.names and col == "u_" + of, (name, col, of)
            assert _fm(header.schema.field(col))["role"] == "uncertainty", (name, col)
            seen.append(col)
    assert {"u_graduation", "u_x", "u_y", "u_H-P", "u_H1", "u_amplitude"} <= set(seen)


# ------------------------------------------------------------ v1 and v2 streams


def _points_stream(path: Path, version: int, table_no: int = 1) -> Path:
    """Seed 001 table N by hand: v1 with position in deg, v2 in rad."""
    rows = [line.split(",") for line in (DATA / f"seed001_table{table_no}.csv").read_text()
            .splitlines() if line and line[0].isdigit()]
    pos, dev = np.array(rows, dtype=float).T
    unit, values = ("deg", pos) if version == 1 else ("rad", pos * np.pi / 180.0)
    schema = pa.schema([make_field("position", pa.float64(), unit),
                        make_field("deviation", pa.float64(), "arcsec")])
    header = Header("points", schema, {"schema_version": version, "source": "by hand"})
    pq.write_table(pa.table([values, dev], schema=header.arrow_schema()), path)
    return path


def test_points_v1_in_deg_and_v2_in_rad_give_the_same_fit_and_report(tmp_path):
    v1 = _points_stream(tmp_path / "v1.parquet", 1)
    v2 = _points_stream(tmp_path / "v2.parquet", 2)
    r = run(f"enc fit-rbf {v1} -o {tmp_path}/m1.parquet && enc fit-rbf {v2} -o "
            f"{tmp_path}/m2.parquet && enc report {v1} > {tmp_path}/r1.txt && "
            f"enc report {v2} > {tmp_path}/r2.txt", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    (h1, m1), (h2, m2) = (read_table(str(tmp_path / f"m{k}.parquet")) for k in (1, 2))
    for part, figures in h1.meta["residuals"].items():  # equal to rounding (rad -> deg)
        for key, value in figures.items():
            assert h2.meta["residuals"][part][key] == pytest.approx(value, abs=1e-9), key
    assert h1.meta["model"]["spread_deg"] == h2.meta["model"]["spread_deg"]
    np.testing.assert_allclose(m1.column("centre").to_numpy(), m2.column("centre").to_numpy(),
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(m1.column("weight").to_numpy(), m2.column("weight").to_numpy(),
                               rtol=1e-9, atol=1e-9)
    assert _fm(m1.schema.field("centre"))["unit"] == "rad" and h1.meta["schema_version"] == 2
    t1, t2 = ((tmp_path / f"r{k}.txt").read_text() for k in (1, 2))
    assert "p-p 5.460\"" in t1 and t1.replace("v1.parquet", "v2.parquet") == t2


def test_model_v1_in_deg_gives_the_same_table_as_v2(tmp_path):
    v2 = _points_stream(tmp_path / "p.parquet", 2)
    r = run(f"enc fit-rbf {v2} -o {tmp_path}/m2.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    header, table = read_table(str(tmp_path / "m2.parquet"))
    schema = pa.schema([make_field("centre", pa.float64(), "deg"),
                        make_field("weight", pa.float64(), "arcsec")])
    old = Header("model", schema, {**header.meta, "schema_version": 1})
    pq.write_table(pa.table([table.column("centre").to_numpy() * 180.0 / np.pi,
                             table.column("weight")], schema=old.arrow_schema()),
                   tmp_path / "m1.parquet")
    rom = "--bits 23 --address-bits 12 --target stream --allow-no-gain"
    r = run(f"enc make-rom m1.parquet {rom} -o r1.parquet && "
            f"enc make-rom m2.parquet {rom} -o r2.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    c1, c2 = (read_table(str(tmp_path / f"r{k}.parquet"))[1].column("correction").to_numpy()
              for k in (1, 2))
    assert np.array_equal(c1, c2) and np.ptp(c1) > 0


def test_spectrum_v1_u_reads_as_v2_u_amplitude(tmp_path):
    n = np.arange(1, 9)
    amplitude, u = 1.0 / n, 0.01 * n
    for version, u_name, extra in ((1, "u", {}), (2, "u_amplitude",
                                                  {"role": "uncertainty", "of": "amplitude"})):
        meta = {"unit": "arcsec", **extra}
        schema = pa.schema([make_field("n", pa.int64(), ""),
                            make_field("amplitude", pa.float64(), "arcsec"),
                            make_field("phase", pa.float64(), "rad"),
                            pa.field(u_name, pa.float64(), metadata=meta)])
        header = Header("spectrum", schema, {"schema_version": version})
        pq.write_table(pa.table([n, amplitude, np.zeros(8), u], schema=header.arrow_schema()),
                       tmp_path / f"s{version}.parquet")
    r = run("enc report s1.parquet && enc report s2.parquet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr.decode()
    one, two = r.stdout.decode().split("s2.parquet")
    assert "(U 0.020\")" in one and one.replace("s1.parquet", "") == two


def test_a_v1_position_beyond_its_range_in_deg_is_refused(tmp_path):
    """The value ranges apply in the unit the stream names: 4e8 deg is beyond +-3.6e8 deg."""
    schema = pa.schema([make_field("position", pa.float64(), "deg"),
                        make_field("deviation", pa.float64(), "arcsec")])
    header = Header("points", schema, {"schema_version": 1})
    pq.write_table(pa.table([[0.0, 4e8, 30.0], [0.0, 1.0, 2.0]], schema=header.arrow_schema()),
                   tmp_path / "p.parquet")
    r = run(f"enc fit-rbf {tmp_path}/p.parquet -o {tmp_path}/m.parquet")
    err = r.stderr.decode().strip().splitlines()
    assert r.returncode == 2 and len(err) == 1 and "'position'" in err[0] and "deg" in err[0]


def test_a_points_v2_stream_in_deg_is_refused(tmp_path):
    schema = pa.schema([make_field("position", pa.float64(), "deg"),
                        make_field("deviation", pa.float64(), "arcsec")])
    header = Header("points", schema, {"schema_version": 2})
    pq.write_table(pa.table([[0.0, 15.0], [0.0, 1.0]], schema=header.arrow_schema()),
                   tmp_path / "p.parquet")
    r = run(f"enc report {tmp_path}/p.parquet")
    err = r.stderr.decode().strip().splitlines()
    assert r.returncode == 2 and len(err) == 1 and "'rad'" in err[0]


# ------------------------------------------------------------ conversions in one place

#: literal angle conversions: arcsec per radian or degree, 180/pi, numpy's and math's
#: converters
_LITERALS = re.compile(
    r"206264|57\.29|0\.01745|4\.848|[*/]\s*3600\b|\b3600(\.0*)?\s*[*/]|1_?296_?000(\.0*)?\s*/|"
    r"180(\.0*)?\s*/\s*(np\.|math\.)?pi|(np\.|math\.)?pi\s*/\s*180|deg2rad|rad2deg|"
    r"np\.radians|np\.degrees|math\.radians|math\.degrees")


@pytest.mark.heavy
def test_no_literal_angle_conversion_left_in_the_library():
    found = []
    for path in sorted((ROOT / "enctools").rglob("*.py")):
        if path.name == "units.py" and path.parent.name == "enctools":
            continue
        for k, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("#", 1)[0]
            if _LITERALS.search(code):
                found.append(f"{path.relative_to(ROOT)}:{k}: {line.strip()}")
    assert not found, "convert through enctools.units:\n" + "\n".join(found)


def test_the_grep_finds_what_it_looks_for():
    for bad in ("x * 3600.0", "np.degrees(a)", "a * 180 / np.pi", "v / 206264.8",
                "math.radians(x)", "1_296_000.0 / n", "np.deg2rad(x)"):
        assert _LITERALS.search(bad), bad
    for fine in ("(0.0, 3600.0)", "x * DEG", "factor('deg', 'arcsec')", "timeout_s = 3600"):
        assert not _LITERALS.search(fine), fine


# ------------------------------------------------------------ --unit


def _iso_points(path: Path) -> Path:
    """5 runs up and down at 8 positions (v2, rad): ISO 230-2 figures in the report."""
    rng = np.random.default_rng(7)
    pos = np.tile(np.arange(8) * 45.0, 10)
    direction = np.repeat(np.tile([1, -1], 5), 8)
    run_no = np.repeat(np.arange(10) // 2, 8)
    dev = 2.0 * np.sin(np.radians(pos)) + 0.3 * direction + rng.normal(0, 0.2, pos.size)
    schema = pa.schema([make_field("position", pa.float64(), "rad"),
                        make_field("deviation", pa.float64(), "arcsec"),
                        make_field("direction", pa.int8(), ""), make_field("run", pa.int32(), "")])
    write_table(str(path), Header("points", schema, {}),
                pa.table([np.radians(pos), dev, direction.astype(np.int8),
                          run_no.astype(np.int32)], schema=schema))
    return path


_NUMBER = r"(-?\d+\.\d+(?:e[-+]\d+)?)"


def _same_rounded(arcsec: str, urad: str) -> None:
    """``arcsec`` and ``urad`` as printed are one number, each rounded in its own unit (to
    its U's decade or to four digits): they agree within half a last digit of each."""
    def half(t: str) -> float:
        return 0.5 * 10.0 ** -len(t.split(".")[1]) if "." in t else 0.5

    tol = half(urad) + URAD_PER_ARCSEC * half(arcsec) + 1e-9
    assert float(urad) == pytest.approx(float(arcsec) * URAD_PER_ARCSEC, abs=tol), (arcsec, urad)


def test_report_unit_urad_is_arcsec_times_4_848(tmp_path):
    pts = _iso_points(tmp_path / "iso.parquet")
    table1 = _points_stream(tmp_path / "t1.parquet", 2)
    texts = {}
    for unit in ("arcsec", "urad"):
        r = run(["enc", "report", "--unit", unit, str(pts), str(table1)])
        assert r.returncode == 0, r.stderr.decode()
        texts[unit] = r.stdout.decode()
    a = re.findall(_NUMBER + '"', texts["arcsec"])
    u = re.findall(_NUMBER + " urad", texts["urad"])
    assert len(a) == len(u) >= 15
    for x, y in zip(a, u, strict=True):
        _same_rounded(x, y)
    # the ISO 230-2 figures and table: same layout, numbers scaled, positions in deg kept
    iso_a = texts["arcsec"].split("ISO 230-2")[1].splitlines()
    iso_u = texts["urad"].split("ISO 230-2")[1].splitlines()
    assert "[arcsec]" in iso_a[0] and "[urad]" in iso_u[0]
    rows_a = [line.split() for line in iso_a[2:10]]
    rows_u = [line.split() for line in iso_u[2:10]]
    assert [r[0] for r in rows_a] == [r[0] for r in rows_u] == [
        f"{45.0 * k:.3f}" for k in range(8)]
    for ra, ru in zip(rows_a, rows_u, strict=True):
        for x, y in zip(ra[1:], ru[1:], strict=True):
            _same_rounded(x, y)
    assert "arcsec" not in texts["urad"].replace("seed 001", "")


def test_report_json_keeps_arcsec_whatever_unit(tmp_path):
    pts = _iso_points(tmp_path / "iso.parquet")
    outs = [run(["enc", "report", "--json", "--unit", u, str(pts)]).stdout for u in
            ("arcsec", "mrad")]
    assert outs[0] == outs[1] and outs[0]
    r = run(["enc", "report", str(pts)], env={"ENC_UNIT": "deg"})
    assert r.returncode == 0 and "deviation [deg]" in r.stdout.decode()


@pytest.mark.slow
def test_html_and_pdf_in_urad_every_axis_names_its_unit(tmp_path):
    from enctools.report import plots
    from enctools.report.display import in_unit
    from enctools.report.summary import build_report

    pts = _iso_points(tmp_path / "iso.parquet")
    r = run(["enc", "report", "--unit", "urad", str(pts), "--html", str(tmp_path / "r.html"),
             "--pdf", str(tmp_path / "r.pdf")])
    assert r.returncode == 0, r.stderr.decode()
    page = (tmp_path / "r.html").read_text()
    assert "µrad" in page and "[arcsec]" not in page
    r = run(["enc", "report", str(pts), "--html", str(tmp_path / "a.html")])
    assert r.returncode == 0, r.stderr.decode()
    cells = {}
    for name in ("a", "r"):
        tds = re.findall(r"<td[^>]*>([^<]*)</td>", (tmp_path / f"{name}.html").read_text())
        cells[name] = [x for td in tds for x in re.findall(r"-?\d+\.\d+", td)]
    assert len(cells["a"]) == len(cells["r"]) >= 40
    scaled = 0
    for a, b in zip(cells["a"], cells["r"], strict=True):
        if a != b:  # positions, counts and degrees stay; every angle error is scaled
            _same_rounded(a, b)
            scaled += 1
    assert scaled >= 30
    assert (tmp_path / "r.pdf").read_bytes().startswith(b"%PDF")
    report = in_unit(build_report([str(pts)]), "urad")
    figs = [f for s in report.sections for _, f in plots.section_figures(s)]
    assert len(figs) >= 3
    for fig in figs:
        for ax in fig.axes:
            labels = [ax.get_xlabel()] + ([ax.get_ylabel()] if ax.name != "polar" else [])
            for text in labels:
                assert re.search(r"\[[^\]]+\]", text), (ax.get_title(), text)
            assert "arcsec" not in ax.get_ylabel()
            if "deviation" in ax.get_ylabel() or "amplitude" in ax.get_ylabel():
                assert "[µrad]" in ax.get_ylabel()
