"""Property tests of the stream layer: round trips bit for bit, and no byte string
makes a reader crash or hang — it reads, or it says why in one DataError."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pyarrow as pa
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from enctools.data import streams, text
from enctools.data.schemas import make_field
from enctools.errors import DataError

FORMATS = [".parquet", ".h5", ".arrow", ".arrows", ".csv", ".tsv"]

# valid: within enc-streams(5) LIMITS (t within +-1e9 s, counts within +-2^62)
floats = st.floats(min_value=-1e9, max_value=1e9, width=64)
ints = st.integers(min_value=-(2**62), max_value=2**62)


@st.composite
def readings_tables(draw):
    n = draw(st.integers(min_value=0, max_value=300))
    heads = draw(st.lists(st.sampled_from(["P1", "P2", "H1", "H5", "X9"]), min_size=1,
                          max_size=5, unique=True))
    fields = [make_field("t", pa.float64(), "s")]
    cols = [pa.array(draw(st.lists(floats, min_size=n, max_size=n)), pa.float64())]
    for h in heads:
        fields.append(make_field(h, pa.int64(), "count", "head", encoder="E", alpha_deg=0.0,
                                 counts_per_rev=1 << 20, periods_per_rev=1024,
                                 radius_m=0.1, zero_count=0))
        cols.append(pa.array(draw(st.lists(ints, min_size=n, max_size=n)), pa.int64()))
    schema = pa.schema(fields)
    name = st.text(st.characters(exclude_characters="".join(map(chr, text.DECEPTIVE)),
                                 exclude_categories=("Cs",)), max_size=20)
    meta = {"rig": {"name": draw(name)}, "settings": {},  # a name holds no control (text.py)
            "history": draw(st.lists(st.text(max_size=40), max_size=3))}
    batch_rows = draw(st.integers(min_value=1, max_value=128))
    table = pa.table(cols, schema=schema)
    return streams.Header("readings", schema, meta), table, batch_rows


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=readings_tables(), ext=st.sampled_from(FORMATS))
@pytest.mark.slow
def test_any_valid_table_round_trips_bit_for_bit(tmp_path, data, ext):
    header, table, rows = data
    path = tmp_path / f"t{ext}"
    with streams.OutputStream(str(path), header, force=True) as out:
        for b in table.to_batches(max_chunksize=rows):
            out.write(b)
    h2, t2 = streams.read_table(str(path), "readings")
    for name in table.column_names:  # bit for bit, NaN payloads included
        a = table.column(name).to_numpy()
        b = t2.column(name).to_numpy()
        assert a.tobytes() == b.tobytes(), name
    assert h2.schema.equals(table.schema, check_metadata=True)
    assert h2.meta["history"] == header.meta["history"]
    assert h2.meta["rig"] == header.meta["rig"]


def _read_bytes(data: bytes) -> None:
    try:
        with streams.open_input(None, stdin=io.BytesIO(data)) as s:
            for _ in s.batches():
                pass
    except DataError as exc:
        assert "\n" not in str(exc)


@pytest.mark.heavy
@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=2048))
def test_any_bytes_read_or_fail_with_one_line(data):
    _read_bytes(data)


@settings(max_examples=150, deadline=None)
@given(st.sampled_from([b"PAR1", b"ARROW1\x00\x00", b"\xff\xff\xff\xff", b"\x89HDF\r\n\x1a\n"]),
       st.binary(max_size=4096))
def test_magic_followed_by_garbage(magic, rest):
    _read_bytes(magic + rest)


@pytest.fixture(scope="module")
def valid_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("valid")
    schema = pa.schema([make_field("theta", pa.float64(), "rad"),
                        make_field("H", pa.float64(), "arcsec", "deviation")])
    table = pa.table([np.linspace(0, 6, 500), np.sin(np.linspace(0, 6, 500))], schema=schema)
    out = {}
    for ext in FORMATS:
        p = d / f"v{ext}"
        streams.write_table(str(p), streams.Header("deviations", schema, {}), table)
        out[ext] = p.read_bytes()
    return out


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ext=st.sampled_from(FORMATS), cut=st.floats(min_value=0.0, max_value=0.999),
       flip=st.integers(min_value=0, max_value=10**9))
def test_truncated_or_flipped_valid_files(valid_files, ext, cut, flip):
    data = valid_files[ext]
    _read_bytes(data[: int(len(data) * cut)])
    b = bytearray(data)
    b[flip % len(b)] ^= 0xFF
    _read_bytes(bytes(b))


FUZZ = Path(__file__).resolve().parents[2] / "data" / "fuzz"


@pytest.mark.parametrize("path", sorted(FUZZ.glob("*")), ids=lambda p: p.name)
def test_fuzz_findings_stay_fixed(path):
    """Inputs the atheris fuzzer (make fuzz) once broke the readers with."""
    _read_bytes(path.read_bytes())
