"""CSV and TSV streams (enc-streams(5), FORMATS): header first, units in the titles, the
metadata in a CSVW sidecar; every kind reads back to the same stream, and pandas and
csvkit read the table with their defaults."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pyarrow as pa
import pytest
from conftest import DATA, one_error_line, run
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from enctools.data import streams
from enctools.data.schemas import KINDS, kind_spec, make_field
from enctools.errors import DataError, OutputError, SettingsError

NAN = float("nan")
#: the titles of kind_table("spectrum")
SPECTRUM_TITLES = ["n", "amplitude_arcsec", "phase_rad", "transfer", "u_amplitude_arcsec", "curve"]
#: curve names a person may give (--name, --curve): commas, quotes, newlines, tabs, unicode
HOSTILE = ["a,b", 'say "x"', "two\nlines", "tab\there", "ü µrad", " lead", "cr\rx"]


def unit(kind: str, name: str) -> str:
    """The unit the schema gives a named column of a kind (the first, if several)."""
    spec = kind_spec(kind).column(name)
    assert spec is not None
    return spec.unit if isinstance(spec.unit, str) else spec.unit[0]


def named(kind: str, name: str, type_: pa.DataType) -> pa.Field:
    """A named column of a kind, in the unit its schema gives."""
    return make_field(name, type_, unit(kind, name))


def _head(name: str) -> pa.Field:
    return make_field(name, pa.int64(), "count", "head", encoder="E,1", alpha_deg=22.5,
                      counts_per_rev=1 << 20, periods_per_rev=1024, radius_m=0.1,
                      zero_count=-3)


def kind_table(kind: str, n: int) -> tuple[streams.Header, pa.Table]:
    """A stream of ``kind`` with ``n`` rows: hostile names, NaN where the kind allows it,
    awkward floats (subnormal, -0.0, 1/3, big), integer extremes."""
    rng = np.random.default_rng(7)
    awkward = np.array([0.1, -0.0, 1 / 3, 5e-324, 1e-7, 123456.789, math.pi, -2.5e-17])
    f = np.resize(awkward, n) * rng.choice([1.0, -1.0], n) + rng.normal(0, 1e-3, n) * (
        np.arange(n) % 2)
    ints = np.resize(np.array([0, 1, -1, (1 << 62), -(1 << 62), 12345], np.int64), n)
    with_nan = f.copy()
    with_nan[::3] = NAN
    meta = {"rig": {"name": 'rig "x", new', "description": 'rig "x",\nnew', "note": "ü"},
            "settings": {"a": 1.5},
            "figures": {"bessel_std_arcsec": NAN}, "history": ["line one", "line,\ttwo"]}
    if kind == "readings":
        fields = [named(kind, "t", pa.float64()), _head("H1"), _head("P,2"),
                  make_field("AC 1", pa.float64(), "arcsec", "autocollimator"),
                  make_field("probe", pa.float64(), "m", "probe", arm_m=0.1, side=1),
                  named(kind, "target", pa.float64()), named(kind, "step", pa.int32()),
                  named(kind, "direction", pa.int8())]
        cols = [np.abs(f), ints, ints[::-1].copy(), with_nan, f * 1e-6, f, np.arange(n),
                np.resize(np.array([1, -1], np.int8), n)]
    elif kind == "deviations":
        fields = [named(kind, "theta", pa.float64())]
        cols = [np.linspace(0, 2 * math.pi, n, endpoint=False)]
        for name in HOSTILE:
            fields += [make_field(name, pa.float64(), "arcsec", "deviation"),
                       make_field(f"u_{name}", pa.float64(), "arcsec", "uncertainty", of=name)]
            cols += [with_nan, np.abs(f)]
        fields.append(make_field("x", pa.float64(), "nm", "radial"))
        cols.append(with_nan * 10)
    elif kind == "spectrum":
        fields = [named(kind, c, t) for c, t in (
            ("n", pa.int64()), ("amplitude", pa.float64()), ("phase", pa.float64()),
            ("transfer", pa.float64()))]
        fields += [make_field("u_amplitude", pa.float64(), unit(kind, "u_amplitude"),
                              "uncertainty", of="amplitude"), named(kind, "curve", pa.string())]
        cols = [np.arange(1, n + 1), np.abs(f), f, with_nan, np.abs(f),
                [HOSTILE[k % len(HOSTILE)] + ("" if k else ",,") for k in range(n)]]
    elif kind == "points":
        fields = [named(kind, "position", pa.float64()), named(kind, "deviation", pa.float64()),
                  named(kind, "direction", pa.int8()), named(kind, "run", pa.int32())]
        cols = [f, f, np.resize(np.array([1, -1], np.int8), n), np.arange(n) // 4]
    elif kind == "model":
        fields = [named(kind, "n", pa.int64()), named(kind, "weight", pa.float64()),
                  named(kind, "weight_sin", pa.float64())]
        cols = [np.arange(n), f, -f]
        meta["model"] = {"kernel": "fourier", "period_deg": 360.0}
    else:
        fields = [named(kind, "address", pa.int64()), named(kind, "correction", pa.int64())]
        cols = [np.arange(n), ints % 32768 - 16384]
        meta["rom"] = {"entries": n, "crc32": "0"}
    schema = pa.schema(fields)
    table = pa.table([pa.array(c, type=fl.type) for c, fl in zip(cols, fields)], schema=schema)
    return streams.Header(kind, schema, meta), table


def same_stream(a: tuple[streams.Header, pa.Table], b: tuple[streams.Header, pa.Table]) -> None:
    """Kind, schema with field metadata, stream metadata and every value bit for bit."""
    (ha, ta), (hb, tb) = a, b
    assert ha.kind == hb.kind
    assert ha.schema.equals(hb.schema, check_metadata=True), (ha.schema, hb.schema)
    assert json.dumps(ha.meta, sort_keys=True) == json.dumps(hb.meta, sort_keys=True)  # NaN
    assert ta.num_rows == tb.num_rows
    for name in ta.column_names:
        x, y = ta.column(name), tb.column(name)
        assert x.type == y.type, name
        if pa.types.is_string(x.type):
            assert x.to_pylist() == y.to_pylist(), name
        else:
            assert x.to_numpy().tobytes() == y.to_numpy().tobytes(), name


CASES = [(kind, rows, fmt) for kind in KINDS for rows in (0, 1, 37) for fmt in ("csv", "tsv")]
# more rows than a batch (65536): several batches written and read
CASES += [("deviations", 70_000, "csv"), ("spectrum", 70_000, "tsv")]


@pytest.mark.heavy
@pytest.mark.parametrize(("kind", "rows", "fmt"), CASES)
def test_every_kind_reads_back_to_the_same_stream(tmp_path, kind, rows, fmt):
    header, table = kind_table(kind, rows)
    streams.write_table(str(tmp_path / "ref.parquet"), header, table)
    out = tmp_path / f"t.{fmt}"
    streams.write_table(str(out), header, table)
    assert (tmp_path / f"t.{fmt}-metadata.json").is_file()
    same_stream(streams.read_table(str(out)), streams.read_table(str(tmp_path / "ref.parquet")))
    text = out.read_bytes()
    assert not text.startswith(b"#") and text.count(b"\n") >= rows + 1


def test_titles_carry_the_unit_and_the_sidecar_is_csvw(tmp_path):
    header, table = kind_table("deviations", 4)
    streams.write_table(str(tmp_path / "d.csv"), header, table)
    first = (tmp_path / "d.csv").read_text().split("\n")[0]
    assert first.startswith('theta_rad,"a,b_arcsec","u_a,b_arcsec","say ""x""_arcsec"')
    side = json.loads((tmp_path / "d.csv-metadata.json").read_text())
    assert side["@context"] == "http://www.w3.org/ns/csvw" and side["url"] == "d.csv"
    cols = side["tableSchema"]["columns"]
    assert cols[0] == {"name": "theta_rad", "titles": "theta_rad", "datatype": "double",
                       "schema:unitText": "rad"}
    assert cols[1]["name"] == "a%2Cb_arcsec" and cols[1]["titles"] == "a,b_arcsec"
    own = side["enctools"]
    assert own["kind"] == "deviations" and own["schema_version"] == 1 and own["rows"] == 4
    assert own["columns"][1] == {"name": "a,b", "type": "double",
                                 "metadata": {"unit": "arcsec", "role": "deviation"}}
    assert own["metadata"]["history"] == ["line one", "line,\ttwo"]
    # a unitless column keeps its name
    header, table = kind_table("spectrum", 2)
    streams.write_table(str(tmp_path / "s.tsv"), header, table)
    assert (tmp_path / "s.tsv").read_text().split("\n")[0].split("\t") == [
        "n", "amplitude_arcsec", "phase_rad", "transfer", "u_amplitude_arcsec", "curve"]
    # a string in quotes only when it needs them
    assert (tmp_path / "s.tsv").read_text().split("\n")[1].endswith('\ta,b,,')  # no tab in it
    assert (tmp_path / "s.tsv").read_text().split("\n")[2].endswith('\t"say ""x"""')


def test_pandas_reads_it_with_its_defaults(tmp_path):
    pd = pytest.importorskip("pandas")
    header, table = kind_table("spectrum", 50)
    streams.write_table(str(tmp_path / "s.csv"), header, table)
    df = pd.read_csv(tmp_path / "s.csv")
    assert list(df.columns) == SPECTRUM_TITLES
    assert [str(t) for t in df.dtypes[:5]] == ["int64", "float64", "float64", "float64",
                                              "float64"]
    assert pd.api.types.is_string_dtype(df["curve"])  # object before pandas 3, str since
    assert df["curve"].tolist() == table.column("curve").to_pylist()
    assert np.array_equal(df["n"].to_numpy(), table.column("n").to_numpy())
    for name, title in (("amplitude", "amplitude_arcsec"), ("transfer", "transfer")):
        want = table.column(name).to_numpy()
        # by default, pandas before 3 parses long numbers (0.00004850094540107198) only to
        # some 1e-12; exactly with float_precision="round_trip", and by default since
        assert np.allclose(df[title].to_numpy(), want, rtol=1e-11, atol=1e-300, equal_nan=True)
        exact = pd.read_csv(tmp_path / "s.csv", **(
            {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}))
        assert exact[title].to_numpy().tobytes() == want.tobytes()
    tsv = tmp_path / "s.tsv"
    streams.write_table(str(tsv), header, table)
    assert pd.read_csv(tsv, sep="\t")["curve"].tolist() == table.column("curve").to_pylist()


@pytest.mark.slow
def test_csvkit_reads_it_with_its_defaults(tmp_path):
    if shutil.which("csvcut") is None and not (DATA.parent.parent / ".venv/bin/csvcut").exists():
        pytest.skip("csvkit is not installed")
    header, table = kind_table("spectrum", 20)
    plain = table.set_column(5, header.schema.field("curve"),
                             pa.array([f"H{k % 3}" for k in range(20)]))
    for name, t, sniff in (("s.csv", plain, ""), ("hostile.csv", table, "--snifflimit 0 ")):
        # (csvkit guesses the dialect from the first 1024 bytes: tabs and quotes in curve
        # names can mislead the guess, hence no sniffing for the hostile table)
        streams.write_table(str(tmp_path / name), header, t)
        r = run(f"csvcut -n {name}", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        titles = [ln.split(":", 1)[1].strip() for ln in r.stdout.decode().splitlines()]
        assert titles == SPECTRUM_TITLES
        r = run(f"csvjson {sniff}{name}", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        rows = json.loads(r.stdout)
        # (csvkit reads text with universal newlines: a CR inside a quoted field is a LF)
        assert [row["curve"] for row in rows] == [
            c.replace("\r", "\n") for c in t.column("curve").to_pylist()]
        assert [row["n"] for row in rows] == t.column("n").to_pylist()


@pytest.mark.skipif(shutil.which("mlr") is None, reason="Miller is not installed")
def test_miller_reads_it_with_its_defaults(tmp_path):
    header, table = kind_table("spectrum", 6)
    plain = table.set_column(5, header.schema.field("curve"), pa.array(["H-P", "a b"] * 3))
    for fmt, t in (("csv", table), ("tsv", plain), ("csv", plain)):
        streams.write_table(str(tmp_path / f"s.{fmt}"), header, t, force=True)
        r = run(f"mlr --i{fmt} --ojson cat s.{fmt}", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
        rows = json.loads(r.stdout)
        assert list(rows[0]) == SPECTRUM_TITLES
        assert [row["curve"] for row in rows] == t.column("curve").to_pylist()
        assert [row["n"] for row in rows] == t.column("n").to_pylist()


@pytest.mark.slow
def test_selfcal_to_csv_with_a_unit_then_back(tmp_path, sjtu_raw):
    r = run(f"enc selfcal {sjtu_raw} -o ref.parquet && enc selfcal {sjtu_raw} -o u.csv "
            f"--unit urad --spectrum s.tsv && enc selfcal {sjtu_raw} --format csv > plain.csv",
            cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    ref = streams.read_table(str(tmp_path / "ref.parquet"))
    h, t = streams.read_table(str(tmp_path / "u.csv"))
    first = (tmp_path / "u.csv").read_text().split("\n")[0].split(",")
    assert "graduation_urad" in first and "u_graduation_urad" in first and "theta_rad" in first
    assert h.schema.equals(ref[0].schema, check_metadata=True)
    for name in ref[1].column_names:  # arcsec again, within rounding of the conversion
        assert np.allclose(t.column(name).to_numpy(), ref[1].column(name).to_numpy(),
                           rtol=1e-14, atol=0, equal_nan=True), name
    assert "amplitude_urad" in (tmp_path / "s.tsv").read_text().split("\n")[0]
    assert (tmp_path / "plain.csv").read_text().startswith("theta_rad,graduation_arcsec")
    assert not (tmp_path / "plain.csv-metadata.json").exists()
    # no sidecar: not a stream (but for a points table)
    r = run("enc info plain.csv", cwd=tmp_path)
    err = one_error_line(r, 2, "enc info")
    assert "plain.csv-metadata.json" in err and "missing" in err


@pytest.mark.slow
def test_points_table_through_fit_rbf_and_make_rom(tmp_path):
    r = run(f"enc points {DATA}/seed001_table1.csv -o p.csv && enc fit-rbf p.csv -q -o m.tsv "
            "&& enc make-rom m.tsv --bits 12 --target stream --format csv --allow-no-gain "
            "--allow-coarse -o rom.csv "
            "&& enc make-rom m.tsv --bits 12 -o table.csv --verify --allow-no-gain --allow-coarse "
            "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    h, t = streams.read_table(str(tmp_path / "p.csv"), "points")
    assert t.num_rows > 10 and h.meta["history"][-1].endswith("-o p.csv")
    assert streams.read_table(str(tmp_path / "m.tsv"), "model")[1].num_rows > 0
    assert streams.read_table(str(tmp_path / "rom.csv"), "rom")[1].num_rows == 4096
    assert (tmp_path / "rom.csv").read_text().startswith("address,correction_count\n")
    table = (tmp_path / "table.csv").read_text()  # the table format: header first too
    assert table.startswith("address,correction\n") and "#" not in table
    # its sidecar says its layout (enc-make-rom(1)): read back without --bits, not a stream
    side = json.loads((tmp_path / "table.csv-metadata.json").read_text())
    assert side["url"] == "table.csv" and side["enctools"]["table"]["code_bits"] == 12
    err = one_error_line(run("enc info table.csv", cwd=tmp_path), 2, "enc info")
    assert "correction table of enc make-rom" in err
    r = run(f"enc correct {DATA}/seed001_table1.csv --table table.csv -q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr


def test_output_and_sidecar_are_written_together_or_not_at_all(tmp_path):
    header, table = kind_table("points", 3)
    out = tmp_path / "p.csv"
    (tmp_path / "p.csv-metadata.json").write_text("old")
    with pytest.raises(OutputError, match=r"p\.csv-metadata\.json exists"):
        streams.write_table(str(out), header, table)
    assert not out.exists() and (tmp_path / "p.csv-metadata.json").read_text() == "old"
    streams.write_table(str(out), header, table, force=True)
    assert streams.read_table(str(out))[1].num_rows == 3
    # a failure while writing leaves neither file, nor a temporary
    with pytest.raises(RuntimeError), streams.OutputStream(str(tmp_path / "q.csv"), header) as o:
        o.write(table)
        raise RuntimeError
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv", "p.csv-metadata.json"]


def test_missing_values_are_refused_not_dropped(tmp_path):
    header, table = kind_table("spectrum", 3)
    holed = table.set_column(5, header.schema.field("curve"), pa.array(["a", None, "b"]))
    with pytest.raises(DataError, match="missing values"):
        streams.write_table(str(tmp_path / "s.csv"), header, holed)
    assert list(tmp_path.iterdir()) == []


def test_text_goes_to_a_terminal_binary_does_not():
    class Tty:
        def isatty(self) -> bool:
            return True

    streams.check_output(None, fmt="csv", stdout=Tty())  # type: ignore[arg-type]
    streams.check_output(None, fmt="tsv", stdout=Tty())  # type: ignore[arg-type]
    with pytest.raises(SettingsError, match="binary data to a terminal"):
        streams.check_output(None, fmt="arrows", stdout=Tty())  # type: ignore[arg-type]


def _pair(tmp_path, kind="deviations", rows=5, fmt="csv"):
    header, table = kind_table(kind, rows)
    if kind == "deviations":  # one plain curve: a line of the file is a row
        table = table.select([0, 1])
        header = streams.Header(kind, table.schema.set(1, make_field("H", pa.float64(), "arcsec",
                                                                     "deviation")), header.meta)
        table = pa.Table.from_arrays(table.columns, schema=header.schema)
    out = tmp_path / f"t.{fmt}"
    streams.write_table(str(out), header, table)
    return out, tmp_path / f"t.{fmt}-metadata.json"


@pytest.mark.parametrize(("damage", "message"), [
    (lambda t, s: t.write_bytes(t.read_bytes()[:-5]), "does not end with a newline"),
    (lambda t, s: t.write_bytes(b"\n".join(t.read_bytes().split(b"\n")[:-2]) + b"\n"),
     "4 rows, its sidecar says 5"),
    (lambda t, s: t.write_bytes(t.read_bytes() + t.read_bytes().split(b"\n")[1] + b"\n"),
     "over 6 rows"),
    (lambda t, s: t.write_bytes(t.read_bytes().replace(b"theta_rad", b"theta_deg", 1)),
     "header line"),
    (lambda t, s: s.write_text(s.read_text().replace('"kind": "deviations"', '"kind": "nope"')),
     "unknown stream kind"),
    (lambda t, s: s.write_text("{"), "not valid JSON"),
    (lambda t, s: s.write_text("[]"), "not a JSON object"),
    (lambda t, s: s.write_text("{}"), "not an enctools CSV sidecar"),
    (lambda t, s: s.unlink(), "missing"),
    (lambda t, s: s.write_text(s.read_text().replace('"titles": "H_arcsec"', '"titles": []')),
     "not an enctools CSV sidecar"),
    (lambda t, s: s.write_text(s.read_text().replace('"H_arcsec"', '"theta_rad"')),
     "the same title"),
    (lambda t, s: s.write_text(s.read_text().replace('"rows": 5', '"rows": "five"')),
     "not an enctools CSV sidecar"),
    (lambda t, s: s.write_text(s.read_text().replace('"schema:unitText": "rad"',
                                                    '"schema:unitText": "deg"')),
     "is in 'deg', its field in 'rad'"),
    (lambda t, s: s.write_text(s.read_text().replace('"type": "double"', '"type": "date32"', 1)),
     "column type"),
    (lambda t, s: t.write_bytes(t.read_bytes().replace(b"\n0,", b"\nnan,", 1)), "'theta'"),
    (lambda t, s: t.write_bytes(t.read_bytes().replace(b"\n0,", b"\nzero,", 1)), "zero"),
    (lambda t, s: t.write_bytes(t.read_bytes().replace(b"\n0,", b"\n" + b"1" * (2 << 20) + b",")),
     "a line over 1048576 bytes"),
])
def test_hostile_tables_and_sidecars_are_one_data_error(tmp_path, damage, message):
    table, side = _pair(tmp_path)
    damage(table, side)
    with pytest.raises(DataError, match=message.replace("(", r"\(")) as e:
        streams.read_table(str(table))
    assert "\n" not in str(e.value)


def test_the_sidecar_of_another_table_is_refused(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    ta, _ = _pair(tmp_path / "a", "deviations")
    _, sb = _pair(tmp_path / "b", "spectrum")
    shutil.copy(sb, ta.parent / sb.name)
    with pytest.raises(DataError, match="header line"):
        streams.read_table(str(ta))


def test_a_huge_string_field_is_refused(tmp_path):
    header, table = kind_table("spectrum", 3)
    big = table.set_column(5, header.schema.field("curve"),
                           pa.array(["x" * (200 << 10), "a", "b"]))
    streams.write_table(str(tmp_path / "s.csv"), header, big)
    with pytest.raises(DataError, match="a field of 204800 bytes"):
        streams.read_table(str(tmp_path / "s.csv"))


def test_an_error_unit_other_than_arcsec_reads_back_in_arcsec(tmp_path):
    header, table = kind_table("points", 10)
    streams.write_table(str(tmp_path / "p.csv"), header, table, unit="deg")
    position = f"position_{unit('points', 'position')}"  # the schema's unit, not --unit's
    assert (tmp_path / "p.csv").read_text().startswith(f"{position},deviation_deg,direction,")
    _, back = streams.read_table(str(tmp_path / "p.csv"))
    assert np.allclose(back.column("deviation").to_numpy(), table.column("deviation").to_numpy(),
                       rtol=1e-15, atol=1e-300)
    assert back.column("position").to_numpy().tobytes() == \
        table.column("position").to_numpy().tobytes()


def test_unit_option_and_env_for_the_csv_of_a_command(tmp_path):
    from conftest import run_in_process

    table1 = str(DATA / "seed001_table1.csv")
    r = run_in_process(["points", table1, "-o", str(tmp_path / "ref.parquet")])
    assert r.returncode == 0, r.stderr
    r = run_in_process(["points", table1, "-o", str(tmp_path / "u.csv"), "--unit", "urad"])
    assert r.returncode == 0, r.stderr
    r = run_in_process(["points", table1, "-o", str(tmp_path / "d.tsv")], env={"ENC_UNIT": "deg"})
    assert r.returncode == 0, r.stderr
    _, ref = streams.read_table(str(tmp_path / "ref.parquet"))
    for name, shown in (("u.csv", "urad"), ("d.tsv", "deg")):
        titles = (tmp_path / name).read_text().split("\n")[0]
        assert f"deviation_{shown}" in titles and "arcsec" not in titles
        _, back = streams.read_table(str(tmp_path / name))
        assert np.allclose(back.column("deviation").to_numpy(),
                           ref.column("deviation").to_numpy(), rtol=1e-14, atol=0)
        assert back.column("position").to_numpy().tobytes() == \
            ref.column("position").to_numpy().tobytes()
    r = run_in_process(["points", table1, "-o", str(tmp_path / "x.csv"), "--unit", "furlong"])
    assert r.returncode == 2 and b"--unit" in r.stderr


@pytest.mark.parametrize("what", ["table", "sidecar"])
def test_a_full_disk_leaves_neither_file(tmp_path, what):
    from conftest import small_tmpfs

    from enctools.errors import OutputError

    header, table = kind_table("deviations", 5000 if what == "table" else 3)
    if what == "sidecar":  # the table fits, its sidecar does not
        header.meta["history"] = ["x" * 1000] * 300
    with small_tmpfs(tmp_path / "full", "128k") as mnt:
        with pytest.raises(OutputError, match="No space left on device"):
            streams.write_table(str(mnt / "d.csv"), header, table)
        assert list(mnt.iterdir()) == []


@pytest.fixture(scope="module")
def valid_pair(tmp_path_factory):
    d = tmp_path_factory.mktemp("pair")
    header, table = kind_table("spectrum", 40)
    streams.write_table(str(d / "s.csv"), header, table)
    return (d / "s.csv").read_bytes(), (d / "s.csv-metadata.json").read_bytes()


def _read_pair(tmp_path, table: bytes, sidecar: bytes) -> None:
    (tmp_path / "x.csv").write_bytes(table)
    (tmp_path / "x.csv-metadata.json").write_bytes(sidecar)
    try:
        streams.read_table(str(tmp_path / "x.csv"))
    except DataError as exc:
        assert "\n" not in str(exc)


@pytest.mark.heavy
@settings(max_examples=80, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.floats(min_value=0.0, max_value=1.0), flip=st.integers(0, 10**9),
       byte=st.integers(0, 255), side=st.booleans())
def test_cut_or_changed_tables_and_sidecars_read_or_fail_with_one_line(
        tmp_path, valid_pair, cut, flip, byte, side):
    table, sidecar = valid_pair
    data = bytearray(sidecar if side else table)
    data[flip % len(data)] = byte
    changed = bytes(data[: max(1, int(len(data) * cut))])
    _read_pair(tmp_path, table if side else changed, changed if side else sidecar)
