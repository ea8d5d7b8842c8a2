"""enc make-rom: correction tables from a model, in every format, read back equal."""

from __future__ import annotations

import zlib

import numpy as np
import pyarrow as pa
import pytest
from conftest import DATA, run

from enctools.data import streams
from enctools.data.schemas import make_field
from enctools.errors import DataError
from enctools.models import romformats as rf
from enctools.models.curve_model import from_stream
from enctools.models.fourier import FourierModel
from enctools.models.rom import RomSpec, build_rom

MEMORY = ("bin", "ihex", "mif", "coe", "mem", "csv")


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("rom")
    r = run(f"enc fit-rbf {DATA}/seed001_table1.csv -q -o {d}/m.parquet")
    assert r.returncode == 0, r.stderr.decode()
    return d / "m.parquet"


@pytest.fixture(scope="module")
def rom23(model_file):
    """The full 23-bit table, int16, of the table-1 RBF model."""
    header, table = streams.read_table(str(model_file), "model")
    return build_rom(from_stream(header, table), RomSpec(23, width=16)), from_stream(header, table)


@pytest.mark.slow
def test_quantisation_within_half_an_lsb(rom23):
    rom, model = rom23
    assert rom.values.size == 1 << 23 and rom.values.dtype == np.int16
    assert rom.max_quantisation_lsb <= 0.5
    # spot-check against the model: value = round(-deviation / LSB) at the code's angle
    lsb = 1_296_000 / 2 ** 23
    k = np.random.default_rng(0).integers(0, 1 << 23, 2000)
    want = -model(k * 360.0 / 2 ** 23) / lsb
    assert np.abs(rom.values[k] - want).max() <= 0.5 + 1e-9
    assert np.array_equal(rom.values[k], np.rint(want))
    assert rom.crc32 == zlib.crc32(rom.values.astype("<i2").tobytes())


@pytest.mark.parametrize("fmt", MEMORY)
@pytest.mark.slow
def test_full_23_bit_table_reads_back(rom23, tmp_path, fmt):
    rom, _ = rom23
    for endian in (("little", "big") if fmt in ("bin", "ihex") else ("little",)):
        target = rf.Target(fmt, 16, endian)
        path = tmp_path / f"t.{fmt}"
        rf.write_table(str(path), rom.values, target, force=True, comment=["test"])
        assert np.array_equal(rf.read_table(str(path), target), rom.values)


@pytest.mark.parametrize("fmt", ("acs", "siemens"))
@pytest.mark.slow
def test_controller_tables_read_back(rom23, tmp_path, fmt):
    values = rom23[0].values[::32]  # 2^18 points: a big controller table
    target = rf.Target(fmt, 16, count_deg=360 / 2 ** 23, axis="0" if fmt == "acs" else "C1",
                       max_entries=1 << 19)
    path = tmp_path / f"t.{fmt}"
    rf.write_table(str(path), values, target)
    assert np.array_equal(rf.read_table(str(path), target), values)


def test_odd_widths_in_text_formats(tmp_path):
    values = np.array([-2048, -1, 0, 1, 2047, -7], dtype=np.int16)
    for fmt in ("mif", "coe", "mem"):
        target = rf.Target(fmt, 12)
        rf.write_table(str(tmp_path / f"x.{fmt}"), values, target)
        assert np.array_equal(rf.read_table(str(tmp_path / f"x.{fmt}"), target), values)
    assert "\t0 : 800;" in (tmp_path / "x.mif").read_text()  # two's complement, 3 digits


def test_mif_reader_takes_ranges_and_decimal(tmp_path):
    f = tmp_path / "q.mif"
    f.write_text("-- by hand\nWIDTH=8;\nDEPTH=6;\nADDRESS_RADIX=UNS;\nDATA_RADIX=DEC;\n"
                 "CONTENT BEGIN\n[0..2] : -1;\n3 : 5 6;\n5 : 127;\nEND;\n")
    assert rf.read_table(str(f), rf.Target("mif", 8)).tolist() == [-1, -1, -1, 5, 6, 127]


@pytest.mark.slow
def test_make_rom_command_every_format(model_file, tmp_path):
    crcs = set()
    for fmt, ext in (("bin", "bin"), ("ihex", "hex"), ("mif", "mif"), ("coe", "coe"),
                     ("mem", "mem"), ("csv", "csv"), ("acs", "prg"), ("siemens", "spf")):
        out = tmp_path / f"t.{ext}"
        r = run(f"enc make-rom {model_file} --bits 23 --address-bits 12 --verify -o {out}")
        assert r.returncode == 0, r.stderr.decode()
        err = r.stderr.decode()
        assert "read back equal" in err and "largest quantisation error" in err
        crcs.add(err.split("CRC-32 ")[1].split()[0])
    # controller tables sample the start of each address range, memories its centre
    assert len(crcs) == 2
    data = (tmp_path / "t.bin").read_bytes()
    assert f"{zlib.crc32(data):08x}" in crcs and len(data) == 2 * 4096


@pytest.mark.slow
def test_siemens_rotary_rules(model_file, tmp_path):
    out = tmp_path / "c.spf"
    r = run(f"enc make-rom {model_file} --bits 23 --address-bits 8 --axis C1 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    lines = out.read_text().splitlines()
    comp = [ln for ln in lines if ln.startswith("$AA_ENC_COMP[")]
    assert len(comp) == 257  # 0 deg .. 360 deg, no gaps
    assert comp[0].startswith("$AA_ENC_COMP[0,0,C1]=") and comp[-1].startswith("$AA_ENC_COMP[0,256,C1]=")
    assert comp[0].split("=")[1] == comp[-1].split("=")[1]  # 0 and 360 deg agree
    assert "$AA_ENC_COMP_STEP[0,C1]=1.40625" in lines and "$AA_ENC_COMP_MAX[0,C1]=360.0" in lines
    assert "$AA_ENC_COMP_IS_MODULO[0,C1]=1" in lines
    target = rf.Target("siemens", count_deg=360 / 2 ** 23, axis="C1")
    gap = tmp_path / "gap.spf"
    gap.write_text("\n".join(ln for ln in lines if not ln.startswith("$AA_ENC_COMP[0,7,")))
    with pytest.raises(Exception, match="gaps"):
        rf.read_table(str(gap), target)
    opened = tmp_path / "open.spf"
    opened.write_text("\n".join(ln if not ln.startswith("$AA_ENC_COMP[0,256,") else
                                "$AA_ENC_COMP[0,256,C1]=0.004291534423828125" for ln in lines))
    with pytest.raises(Exception, match="0 deg and 360 deg"):
        rf.read_table(str(opened), target)


def test_deviations_curve_as_model(tmp_path):
    theta = np.arange(3600) * 2 * np.pi / 3600
    schema = pa.schema([make_field("theta", pa.float64(), "rad"),
                        make_field("A", pa.float64(), "arcsec", "deviation")])
    table = pa.table([theta, 3.0 * np.sin(2 * theta)], schema=schema)
    streams.write_table(str(tmp_path / "d.parquet"), streams.Header("deviations", schema, {}), table)
    r = run(f"enc make-rom {tmp_path}/d.parquet --bits 16 --width 8 --lsb 4 -o {tmp_path}/d.bin")
    assert r.returncode == 0, r.stderr.decode()
    v = np.fromfile(tmp_path / "d.bin", dtype=np.int8)
    lsb = 4 * 1_296_000 / 2 ** 16
    x = np.arange(v.size) * 2 * np.pi / v.size
    assert np.abs(v - (-3.0 * np.sin(2 * x) / lsb)).max() < 0.5 + 1e-3  # + linear interpolation


def test_a_curve_with_empty_bins_is_interpolated_with_a_warning(tmp_path):
    """NaN points of a curve (empty angle bins of compare --band 0) are bridged, and said so."""
    theta = np.arange(360) * 2 * np.pi / 360
    y = 3.0 * np.sin(theta)
    y[[10, 11, 200]] = np.nan
    schema = pa.schema([make_field("theta", pa.float64(), "rad"),
                        make_field("A", pa.float64(), "arcsec", "deviation")])
    streams.write_table(str(tmp_path / "d.parquet"), streams.Header("deviations", schema, {}),
                        pa.table([theta, y], schema=schema))
    r = run(f"enc make-rom {tmp_path}/d.parquet --bits 16 --width 16 --lsb 0.001 "
            f"-o {tmp_path}/d.bin")
    assert r.returncode == 0, r.stderr.decode()
    assert "3 of 360 points NaN" in r.stderr.decode()
    lsb = 0.001 * 1_296_000 / 2 ** 16  # arcsec
    v = np.fromfile(tmp_path / "d.bin", dtype="<i2") * lsb
    x = np.arange(v.size) * 2 * np.pi / v.size
    # half an LSB + linear interpolation across a 3 deg gap of a 3" sine (< 0.002")
    assert np.abs(v - (-3.0 * np.sin(x))).max() < lsb / 2 + 0.002


@pytest.mark.slow
def test_rom_stream_output(model_file):
    r = run(f"enc make-rom {model_file} --bits 23 --address-bits 10 -q | enc info")
    assert r.returncode == 0, r.stderr.decode()
    assert b"rom stream" in r.stdout and b"1024 rows" in r.stdout


@pytest.mark.parametrize("args, what", [
    ("--bits 23 --width 4", "use --width"),               # corrections do not fit 4 bits
    ("--bits 32", "2^32 = 4294967296 entries"),   # 2^32 entries
    ("--bits 23 --target siemens", "exceed the 5000"),
    ("--bits 23 --address-bits 24", "--address-bits"),
    ("--bits 23 --address-bits 10 --target acs --zone -3", "--zone"),
])
def test_make_rom_refuses(model_file, tmp_path, args, what):
    out = tmp_path / "t.bin"
    r = run(f"enc make-rom {model_file} {args} -o {out}")
    assert r.returncode == 2, r.stderr.decode()
    err = r.stderr.decode()
    assert err.startswith("enc make-rom: error:") and err.count("\n") == 1, err
    assert what in err
    assert not out.exists() and not list(tmp_path.iterdir())  # no partial or temporary file


@pytest.mark.slow
def test_make_rom_wrong_kind_and_existing_output(tmp_path, model_file):
    out = tmp_path / "t.bin"
    r = run(f"enc points {DATA}/seed001_table1.csv | enc make-rom --bits 16 -o {out}")
    assert r.returncode == 2 and b"this command reads model or deviations" in r.stderr
    assert not out.exists()
    out.write_bytes(b"keep")
    r = run(f"enc make-rom {model_file} --bits 16 -o {out}")
    assert r.returncode == 2 and b"--force" in r.stderr and out.read_bytes() == b"keep"


def test_fourier_model_table_exact():
    m = FourierModel(np.array([0, 1, 2]), np.array([0.0, 10.0, 0.0]), np.array([0.0, 0.0, -5.0]))
    rom = build_rom(m, RomSpec(10, width=12, lsb=8))
    lsb = 8 * 1_296_000 / 2 ** 10
    x = np.arange(1024) * 2 * np.pi / 1024
    want = -(10 * np.cos(x) - 5 * np.sin(2 * x)) / lsb
    assert np.array_equal(rom.values, np.rint(want))
    assert rom.max_quantisation_lsb == pytest.approx(np.abs(np.rint(want) - want).max())


@pytest.mark.slow
def test_grid_evaluation_equals_the_model_everywhere(model_file):
    """The fast uniform-grid path (Fourier series by BLAS) gives the model's own values."""
    from enctools.models.rbf import RBFModel

    header, table = streams.read_table(str(model_file), "model")
    rbf = from_stream(header, table)
    series = rbf.as_fourier()
    assert series is not None and series.n.size < 32 * rbf.centres_deg.size
    narrow = RBFModel(rbf.centres_deg, rbf.weights, 0.0, 0.05)  # too narrow: unit by unit
    assert narrow.as_fourier() is None
    fourier = FourierModel(np.arange(40), np.linspace(1, 0, 40), np.linspace(0, -2, 40))
    for model in (rbf, narrow, fourier):
        scale = np.abs(model(np.linspace(0, 360, 4097))).max()
        for spec in (RomSpec(16), RomSpec(23, address_bits=13), RomSpec(20, sample="start")):
            first, step = spec.grid_deg()
            at = model.on_grid(first, step)
            for start, stop in ((0, 5000), (spec.entries - 4096, spec.entries), (777, 778)):
                want = model(spec.angles_deg(start, stop))
                assert np.abs(at(start, stop) - want).max() <= 1e-12 * scale


@pytest.mark.slow
def test_grid_and_plain_evaluation_build_the_same_table(model_file):
    """build_rom through on_grid and through plain calls at every address: equal tables."""
    header, table = streams.read_table(str(model_file), "model")
    model = from_stream(header, table)
    for spec in (RomSpec(22, width=16), RomSpec(23, address_bits=18, lsb=0.25)):
        fast = build_rom(model, spec)
        plain = build_rom(lambda deg: model(deg), spec)
        assert np.array_equal(fast.values, plain.values)
        assert fast.crc32 == plain.crc32 and fast.min_value == plain.min_value
        assert fast.max_quantisation_lsb == pytest.approx(plain.max_quantisation_lsb, abs=1e-9)


def test_nan_model_refused_from_any_chunk():
    nan_late = FourierModel(np.array([0]), np.array([np.nan]), np.array([0.0]))
    with pytest.raises(DataError, match="NaN or infinite"):
        build_rom(nan_late, RomSpec(22))
    with pytest.raises(DataError, match="NaN or infinite"):
        build_rom(lambda deg: np.where(deg > 300, np.inf, 0.0), RomSpec(22))


def test_text_readers_take_lines_by_columns_and_refuse_bad_digits(tmp_path):
    """The column readers of MIF/COE/mem: any width, odd digit counts, bad digits refused."""
    values = np.array([-5, 0, 7, -2048, 2047, 1], dtype=np.int16)
    for fmt in ("mif", "coe", "mem"):
        for width in (3, 8, 12, 16, 32):
            v = np.clip(values, -(1 << (width - 1)), (1 << (width - 1)) - 1)
            target = rf.Target(fmt, width)
            path = tmp_path / f"x{width}.{fmt}"
            rf.write_table(str(path), v, target, True, ["c"])
            assert np.array_equal(rf.read_table(str(path), target), v), (fmt, width)
        data = path.read_bytes()
        k = data.rindex(b"0000000") + 3  # a digit inside a value (32-bit words)
        path.write_bytes(data[:k] + b"G" + data[k + 1:])
        with pytest.raises(DataError, match=str(path)):
            rf.read_table(str(path), rf.Target(fmt, 32))
