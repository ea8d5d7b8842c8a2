"""What a file can make enctools allocate or loop over is bounded: a stream or table beyond
a limit of enc-streams(5) LIMITS is refused with one line and exit 2, quickly and in
bounded memory, before the work starts."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from conftest import one_error_line, run

from enctools.data import streams

# peak memory of a refused input (the child's maximum resident set) [KiB]
MAX_RSS_KIB = 500 << 10


@pytest.fixture(scope="module")
def raw(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("limits")
    r = run(f"enc acquire --rig sjtu-dual --revolutions 0.5 -o {d}/raw.parquet")
    assert r.returncode == 0, r.stderr.decode()
    return d / "raw.parquet"


def rewrite(src: Path, dst: Path, fields: dict[str, dict[str, str]] | None = None,
            meta: dict | None = None, columns: dict[str, np.ndarray] | None = None) -> Path:
    """``src`` with field metadata, stream metadata or column values replaced."""
    header, table = streams.read_table(str(src))
    schema = header.schema
    for name, changes in (fields or {}).items():
        i = schema.get_field_index(name)
        f = schema.field(i)
        md = {k.decode(): v.decode() for k, v in (f.metadata or {}).items()} | changes
        schema = schema.set(i, f.with_metadata(md))
    arrays = [pa.array(columns[n], type=schema.field(n).type) if columns and n in columns
              else table.column(n) for n in schema.names]
    table = pa.table(arrays, schema=schema)
    m = dict(header.meta) if meta is None else meta
    # as another program may write it: streams.write_table refuses what enctools cannot read
    pq.write_table(table.replace_schema_metadata(
        streams.Header(header.kind, schema, m).arrow_schema().metadata), dst)
    return dst


_MEASURED = ("import resource, subprocess, sys; "
             "code = subprocess.run(sys.argv[1:]).returncode; "
             "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); "
             "sys.exit(code)")


def refused(cmd: str, what: str, name: str | None = None, timeout: float = 60) -> str:
    """Run ``cmd`` (enc ...); its one error line, once its peak memory is under 500 MB."""
    r = run([sys.executable, "-c", _MEASURED, "bash", "-c", cmd], timeout=timeout)
    *lines, rss = r.stderr.decode().splitlines()
    assert int(rss) < MAX_RSS_KIB, f"{cmd}: peak resident set {int(rss) >> 10} MiB"
    r = subprocess.CompletedProcess(r.args, r.returncode, r.stdout,
                                    "".join(f"{ln}\n" for ln in lines).encode())
    line = one_error_line(r, 2, name or f"enc {cmd.split()[1]}")
    assert what in line, line
    assert "internal error" not in line
    return line


@pytest.mark.parametrize("key, value", [
    ("counts_per_rev", "1"), ("counts_per_rev", "-5"), ("periods_per_rev", "1e18"),
    ("interpolation", "0"), ("alpha_deg", "abc"), ("alpha_deg", "nan"),
    ("radius_m", "-1"), ("zero_count", "1e30"), ("encoder", ""),
])
@pytest.mark.parametrize("command", [
    "info",  # the stream is refused when opened, whatever the command: the others are slow
    pytest.param("selfcal --method esa", marks=pytest.mark.slow),
    pytest.param("compare --device H1,H2,H3,H4 --reference P1,P2", marks=pytest.mark.slow)])
def test_head_field_metadata_out_of_range(raw, tmp_path, key, value, command):
    bad = rewrite(raw, tmp_path / "bad.parquet", {"H1": {key: value}})
    out = "" if command == "info" else f" -o {tmp_path}/out.parquet"
    line = refused(f"enc {command} {bad}{out}", key)
    assert "'H1'" in line and (value in line or key == "encoder")


def test_counts_per_rev_must_be_periods_times_interpolation(raw, tmp_path):
    bad = rewrite(raw, tmp_path / "bad.parquet", {"H2": {"counts_per_rev": "212992001"}})
    refused(f"enc selfcal --method esa {bad} -o {tmp_path}/out.parquet", "counts_per_rev")


def _deep_header(path: Path, depth: int) -> Path:
    schema = pa.schema([pa.field("theta", pa.float64(), metadata={"unit": "rad"}),
                        pa.field("H", pa.float64(), metadata={"unit": "arcsec",
                                                              "role": "deviation"})])
    deep = "[" * depth + "]" * depth
    text = '{"kind": "deviations", "schema_version": 1, "x": ' + deep + "}"
    schema = schema.with_metadata({b"kind": b"deviations", b"enctools": text.encode()})
    pq.write_table(pa.table([[0.0], [0.0]], schema=schema), path)
    return path


def test_deeply_nested_metadata(tmp_path):
    line = refused(f"enc info {_deep_header(tmp_path / 'deep.parquet', 200_000)}", "nested")
    assert "200001" in line and "64" in line
    r = run(f"enc info {_deep_header(tmp_path / 'ok.parquet', 20)}")
    assert r.returncode == 0, r.stderr.decode()


@pytest.mark.slow
def test_huge_metadata(tmp_path):
    schema = pa.schema([pa.field("theta", pa.float64(), metadata={"unit": "rad"})])
    text = json.dumps({"kind": "deviations", "pad": "x" * (17 << 20)})
    schema = schema.with_metadata({b"kind": b"deviations", b"enctools": text.encode()})
    pq.write_table(pa.table([[0.0]], schema=schema), tmp_path / "big.parquet")
    refused(f"enc info {tmp_path}/big.parquet", "bytes")


def _hdf5_claiming(path: Path, rows: int, chunk: int, compression: str | None = None) -> Path:
    import h5py

    with h5py.File(path, "w") as h5:
        g = h5.create_group("deviations")
        g.attrs["kind"] = np.bytes_(b"deviations")
        g.attrs["enctools"] = np.bytes_(b'{"kind": "deviations", "schema_version": 1}')
        g.attrs["columns"] = np.bytes_(b'["theta", "H"]')
        for name, unit, role in (("theta", b"rad", None), ("H", b"arcsec", b"deviation")):
            ds = g.create_dataset(name, shape=(rows,), maxshape=(None,), dtype="f8",
                                  chunks=(chunk,), compression=compression)
            if compression:
                ds[:chunk] = 0.0
            ds.attrs["arrow_type"] = np.bytes_(b"double")
            ds.attrs["unit"] = np.bytes_(unit)
            if role:
                ds.attrs["role"] = np.bytes_(role)
    return path


def test_hdf5_claiming_1e12_rows(tmp_path):
    bad = _hdf5_claiming(tmp_path / "claims.h5", 10**12, 8192)
    assert bad.stat().st_size < 100_000
    line = refused(f"enc info {bad}", "1000000000000 rows", timeout=30)
    assert "1000000000" in line


def test_hdf5_with_a_huge_gzip_chunk(tmp_path):
    bad = _hdf5_claiming(tmp_path / "chunk.h5", 1 << 22, 1 << 22, "gzip")  # 32 MiB a chunk
    refused(f"enc info {bad}", "chunks of", timeout=30)


def test_hdf5_mostly_fill_value(tmp_path):
    bad = _hdf5_claiming(tmp_path / "fill.h5", 500_000_000, 8192)
    refused(f"enc info {bad}", "bytes of data in", timeout=30)


@pytest.mark.slow
def test_latency_on_a_parquet_of_2e8_rows(raw, tmp_path):
    header, table = streams.read_table(str(raw))
    small = table.select(["t", "P1"])
    schema = small.schema
    block = pa.table([pa.array(np.zeros(4 << 20, dtype=np.float64)),
                      pa.array(np.zeros(4 << 20, dtype=np.int64))], schema=schema)
    h = streams.Header(header.kind, schema, header.meta)
    with pq.ParquetWriter(tmp_path / "long.parquet", h.arrow_schema()) as writer:
        for _ in range(48):  # 48 row groups of 4 Mi rows: 201326592 rows
            writer.write_table(block)
    assert (tmp_path / "long.parquet").stat().st_size < 64 << 20
    line = refused(f"enc latency {tmp_path}/long.parquet", "rows", timeout=60)
    assert "201326592" in line


@pytest.mark.slow
@pytest.mark.parametrize("rows", [6_000_000])
def test_whole_table_commands_refuse_long_streams(tmp_path, rows):
    schema = pa.schema([pa.field("position", pa.float64(), metadata={"unit": "deg"}),
                        pa.field("deviation", pa.float64(), metadata={"unit": "arcsec"})])
    h = streams.Header("points", schema, {"schema_version": 1})  # v1: position in deg
    table = pa.table([np.linspace(0, 360, rows), np.zeros(rows)], schema=schema)
    streams.write_table(str(tmp_path / "p.parquet"), h, table)
    refused(f"enc fit-rbf {tmp_path}/p.parquet -o {tmp_path}/m.parquet", "rows")


def test_counts_near_the_int64_maximum(raw, tmp_path):
    _, table = streams.read_table(str(raw))
    h1 = table.column("H1").to_numpy() + (np.iinfo(np.int64).max - 10**9)
    bad = rewrite(raw, tmp_path / "big.parquet", columns={"H1": h1})
    for cmd in (f"enc selfcal --method esa {bad} -o {tmp_path}/o.parquet",
                f"enc compare --device H1,H2,H3,H4 --reference P1,P2 {bad} "
                f"-o {tmp_path}/o.parquet"):
        refused(cmd, "'H1'")


def test_latency_on_constant_t(raw, tmp_path):
    _, table = streams.read_table(str(raw))
    bad = rewrite(raw, tmp_path / "t0.parquet", columns={"t": np.zeros(table.num_rows)})
    refused(f"enc latency {bad}", "'t'")


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_average_heads_refuses_non_finite_t(raw, tmp_path, value):
    t = streams.read_table(str(raw))[1].column("t").to_numpy().copy()
    t[5] = value
    bad = rewrite(raw, tmp_path / "t.parquet", columns={"t": t})
    refused(f"enc average-heads {bad} -o {tmp_path}/o.parquet", "'t'")


@pytest.mark.parametrize("encoder, key", [
    ({"name": "E", "periods_per_rev": "many"}, "periods_per_rev"),
    ({"name": "E", "counter_bits": 2.5}, "counter_bits"),
    ({"name": "E", "heads": [{"name": "H", "angle": "abc"}]}, "angle"),
    ({"name": "E", "latency_s": [1]}, "latency_s"),
])
def test_rig_metadata_of_the_wrong_type_names_the_field(encoder, key):
    from enctools.data.readings import rig_encoders
    from enctools.errors import DataError

    with pytest.raises(DataError, match=rf"malformed encoder: rig encoder 'E'.*{key} = "):
        rig_encoders({"rig": {"encoders": [encoder]}})


def test_compare_name_of_a_column_of_its_own(raw, tmp_path):
    out = tmp_path / "c.parquet"
    line = refused(f"enc compare --device H1,H2,H3,H4 --reference P1,P2 --name theta {raw} "
                   f"-o {out}",
                   "--name 'theta'")
    assert "deviations" in line and not out.exists()


def test_a_stream_enctools_would_refuse_is_not_written(tmp_path):
    from enctools.data.schemas import make_field
    from enctools.errors import DataError

    schema = pa.schema([make_field("theta", pa.float64(), "rad"),
                        make_field("H", pa.float64(), "um", "deviation")])  # nm: a scale's
    h = streams.Header("deviations", schema, {})
    with pytest.raises(DataError, match=r"output .*column 'H' is in 'um'"):
        streams.write_table(str(tmp_path / "m.parquet"), h,
                            pa.table([[0.0], [0.0]], schema=schema))
    schema = pa.schema([make_field("centre", pa.float64(), "rad"),
                        make_field("weight", pa.float64(), "arcsec")])
    h = streams.Header("model", schema, {"model": {}})
    with pytest.raises(DataError, match=r"output .*column 'weight' holds NaN"):
        streams.write_table(str(tmp_path / "m.parquet"), h,
                            pa.table([[0.0], [np.nan]], schema=schema))
    assert not (tmp_path / "m.parquet").exists()


def test_csv_field_over_128_kib(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("position_deg,deviation_arcsec\n0," + "1" * (129 << 10) + "\n")
    line = refused(f"enc points {f} -o {tmp_path}/p.parquet", "131072")
    assert "line 2" in line
    refused(f"enc fit-rbf {f} -o {tmp_path}/m.parquet", "131072")


@pytest.mark.parametrize("value", ["1e308", "-1e308"])
def test_fit_rbf_on_huge_deviations(tmp_path, value):
    f = tmp_path / "p.csv"
    rows = "".join(f"{15 * k},{value if k % 2 else 0}\n" for k in range(24))
    f.write_text("position_deg,deviation_arcsec\n" + rows)
    refused(f"enc fit-rbf {f} -o {tmp_path}/m.parquet", "deviation")
    assert not (tmp_path / "m.parquet").exists()


@pytest.mark.slow
def test_autocollimator_of_1e308(tmp_path):
    r = run(f"enc acquire --rig ciomp-23bit -o {tmp_path}/steps.parquet")
    assert r.returncode == 0, r.stderr.decode()
    header, table = streams.read_table(str(tmp_path / "steps.parquet"))
    ac = next(f.name for f in header.schema
              if (f.metadata or {}).get(b"role") == b"autocollimator")
    values = table.column(ac).to_numpy().copy()
    values[3] = 1e308
    bad = rewrite(tmp_path / "steps.parquet", tmp_path / "bad.parquet", columns={ac: values})
    line = refused(f"enc points {bad} -o {tmp_path}/p.parquet", f"'{ac}'")
    assert "1e+308" in line


def test_a_small_but_consistent_counts_per_rev(raw, tmp_path):
    tiny = {"counts_per_rev": "16", "periods_per_rev": "1", "interpolation": "16"}
    bad = rewrite(raw, tmp_path / "c16.parquet", {h: tiny for h in ("H1", "H2", "H3", "H4")})
    for cmd in (f"enc selfcal --method esa --heads H1,H2,H3,H4 {bad} -o {tmp_path}/o.parquet",
                f"enc compare --device P1,P2 --reference H1,H2,H3,H4 {bad} "
                f"-o {tmp_path}/o.parquet"):
        line = refused(cmd, "turns between two samples", timeout=30)
        assert "counts_per_rev" in line


def _model(path: Path, rows: int, spread: object = 5.0) -> Path:
    schema = pa.schema([pa.field("centre", pa.float64(), metadata={"unit": "deg"}),
                        pa.field("weight", pa.float64(), metadata={"unit": "arcsec"})])
    h = streams.Header("model", schema, {"model": {"kernel": "rbf", "spread_deg": spread},
                                         "schema_version": 1})  # v1: centre in deg
    pq.write_table(pa.table([np.linspace(0, 360, rows, endpoint=False), np.zeros(rows)],
                            schema=h.arrow_schema()), path)
    return path


@pytest.mark.parametrize("rows, spread, what", [
    (20_000, 5.0, "10000"), (24, "abc", "spread_deg"), (24, 1e308, "spread_deg"),
])
def test_make_rom_model_limits(tmp_path, rows, spread, what):
    model = _model(tmp_path / "m.parquet", rows, spread)
    refused(f"enc make-rom {model} --bits 23 --address-bits 12 -o {tmp_path}/r.bin", what)


def _wide(raw: Path, heads: int) -> pa.Table:
    """``raw``'s t and ``heads`` copies of its head H1 (G0, G1, ...), its metadata kept."""
    header, table = streams.read_table(str(raw))
    field = header.schema.field("H1")
    fields = [header.schema.field("t")] + [field.with_name(f"G{k}") for k in range(heads)]
    cols = [table.column("t")] + [table.column("H1")] * heads
    return pa.Table.from_arrays(cols, schema=pa.schema(fields, header.arrow_schema().metadata))


def test_wide_rows_are_read_and_written_a_few_megabytes_at_a_time(raw, tmp_path):
    """enc-streams(5) LIMITS: a batch read holds at most 8 MiB of rows, however many
    columns (2000 heads: 512 rows, not 65536), and the Parquet row groups written are
    of that size too, whether the batches written are one row each (a closure run) or wide."""
    from enctools.data import limits
    wide = _wide(raw, 2000)  # 16 kB a row
    pq.write_table(wide, tmp_path / "one-group.parquet")
    with streams.open_input(str(tmp_path / "one-group.parquet")) as s:
        sizes = [(b.num_rows, b.nbytes) for b in s.batches()]
    assert sum(n for n, _ in sizes) == wide.num_rows and len(sizes) > 1
    assert max(nbytes for _, nbytes in sizes) <= limits.BATCH_BYTES * 1.05  # and bitmaps
    assert sizes[0][0] == limits.BATCH_BYTES // (8 * 2001)
    header, table = streams.read_table(str(raw))
    for name, batches in (("narrow", table.to_batches(max_chunksize=1)),
                          ("wide", wide.to_batches(max_chunksize=100))):
        h = header if name == "narrow" else streams.Header(header.kind, wide.schema,
                                                           header.meta)
        with streams.OutputStream(str(tmp_path / f"{name}.parquet"), h) as out:
            for b in batches:
                out.write(b)
        meta = pq.ParquetFile(tmp_path / f"{name}.parquet").metadata
        groups = [meta.row_group(i) for i in range(meta.num_row_groups)]
        assert sum(g.num_rows for g in groups) == table.num_rows
        if name == "narrow":  # one row a batch: 65536 rows a group, not one
            assert [g.num_rows for g in groups[:-1]] == [65536] * (len(groups) - 1)
        else:
            assert len(groups) > 1  # and each of some 8 MiB of batches (its pages' bytes more)
            assert max(g.total_byte_size for g in groups) <= 2 * limits.BATCH_BYTES


def test_a_row_group_of_too_many_bytes_is_refused(raw, tmp_path, monkeypatch):
    from enctools.data import limits
    from enctools.errors import DataError
    pq.write_table(_wide(raw, 20), tmp_path / "w.parquet")
    monkeypatch.setattr(limits, "MAX_ROW_GROUP_BYTES", 1 << 20)
    with pytest.raises(DataError, match=r"a Parquet row group of \d+ bytes decoded; at most "
                                        r"1048576 are read \(rewrite it with smaller"):
        streams.open_input(str(tmp_path / "w.parquet"))
