"""enc make-rom: correction tables from a model, in every format, read back equal."""

from __future__ import annotations

import re
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
    for _fmt, ext in (("bin", "bin"), ("ihex", "hex"), ("mif", "mif"), ("coe", "coe"),
                     ("mem", "mem"), ("csv", "csv"), ("acs", "prg"), ("siemens", "spf")):
        out = tmp_path / f"t.{ext}"
        control = {"acs": "--resolution 0.00001 --sign correction",
                   "siemens": "--resolution 0.00001"}.get(_fmt, "")
        r = run(f"enc make-rom {model_file} --bits 23 --address-bits 12 --verify {control} "
                f"--allow-no-gain "
                f"-o {out}")
        assert r.returncode == 0, r.stderr.decode()
        err = r.stderr.decode()
        assert "verified yes" in err and "max quantisation error" in err
        crcs.add(err.split("crc32: value ")[1].split(",")[0])
    # controller tables sample the start of each address range at the control's resolution,
    # memories the centre in LSBs of the code
    assert len(crcs) == 2
    data = (tmp_path / "t.bin").read_bytes()
    assert f"{zlib.crc32(data):08x}" in crcs and len(data) == 2 * 4096


@pytest.mark.slow
def test_siemens_rotary_rules(model_file, tmp_path):
    out = tmp_path / "c.spf"
    r = run(f"enc make-rom {model_file} --bits 23 --address-bits 8 --axis C1 --allow-no-gain "
            f"--resolution 0.0001 -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    lines = out.read_text().splitlines()
    comp = [ln for ln in lines if ln.startswith("$AA_ENC_COMP[")]
    assert len(comp) == 257  # 0 deg .. 360 deg, no gaps
    # printed at the control's resolution, 0.0001 deg: four digits after the point
    assert all(re.fullmatch(r"\$AA_ENC_COMP\[0,\d+,C1\]=-?\d\.\d{4}", ln) for ln in comp)
    assert len({ln.split("=")[1] for ln in comp}) > 3
    assert comp[0].startswith("$AA_ENC_COMP[0,0,C1]=")
    assert comp[-1].startswith("$AA_ENC_COMP[0,256,C1]=")
    assert comp[0].split("=")[1] == comp[-1].split("=")[1]  # 0 and 360 deg agree
    assert "$AA_ENC_COMP_STEP[0,C1]=1.40625" in lines and "$AA_ENC_COMP_MAX[0,C1]=360.0" in lines
    assert "$AA_ENC_COMP_IS_MODULO[0,C1]=1" in lines
    target = rf.Target("siemens", count_deg=1e-4, axis="C1", decimals=4)
    gap = tmp_path / "gap.spf"
    gap.write_text("\n".join(ln for ln in lines if not ln.startswith("$AA_ENC_COMP[0,7,")))
    with pytest.raises(Exception, match="gaps"):
        rf.read_table(str(gap), target)
    opened = tmp_path / "open.spf"
    opened.write_text("\n".join(ln if not ln.startswith("$AA_ENC_COMP[0,256,") else
                                "$AA_ENC_COMP[0,256,C1]=0.0043" for ln in lines))
    with pytest.raises(Exception, match="0 deg and 360 deg"):
        rf.read_table(str(opened), target)


def test_deviations_curve_as_model(tmp_path):
    theta = np.arange(3600) * 2 * np.pi / 3600
    schema = pa.schema([make_field("theta", pa.float64(), "rad"),
                        make_field("A", pa.float64(), "arcsec", "deviation")])
    table = pa.table([theta, 3.0 * np.sin(2 * theta)], schema=schema)
    streams.write_table(str(tmp_path / "d.parquet"), streams.Header("deviations", schema, {}),
                        table)
    r = run(f"enc make-rom {tmp_path}/d.parquet --bits 16 --width 8 --lsb 0.01 -o {tmp_path}/d.bin")
    assert r.returncode == 0, r.stderr.decode()
    v = np.fromfile(tmp_path / "d.bin", dtype=np.int8)
    lsb = 0.01 * 1_296_000 / 2 ** 16
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
    r = run(f"enc make-rom {model_file} --bits 23 --address-bits 10 --allow-no-gain -q | enc info")
    assert r.returncode == 0, r.stderr.decode()
    assert b"rom stream" in r.stdout and b"1024 rows" in r.stdout


@pytest.mark.slow
def test_acs_sign_as_given(model_file, tmp_path):
    """ACS's sign is not confirmed: --sign error writes minus the correction."""
    text = {}
    for sign in ("correction", "error"):
        r = run(f"enc make-rom {model_file} --bits 23 --address-bits 6 --resolution 0.0001 "
                f"--allow-no-gain "
                f"--sign {sign} --verify -o {tmp_path}/{sign}.prg")
        assert r.returncode == 0, r.stderr.decode()
        text[sign] = {int(i): float(v) for i, v in re.findall(
            r"^ENC_COMP\((\d+)\)=(\S+)$", (tmp_path / f"{sign}.prg").read_text(), re.M)}
    assert len(text["error"]) == 65 and any(v != 0 for v in text["error"].values())
    assert all(text["error"][i] == -v for i, v in text["correction"].items())


@pytest.mark.parametrize("args, what", [
    ("--bits 23 --width 4", "use --width"),               # corrections do not fit 4 bits
    ("--bits 32", "2^32 = 4294967296 entries"),   # 2^32 entries
    ("--bits 23 --target siemens --resolution 0.0001", "exceed the 5000"),
    ("--bits 23 --address-bits 8 --target siemens", "SINUMERIK: 1 / MD10210"),
    ("--bits 23 --address-bits 8 --target acs --sign correction", "ACS: the axis' position"),
    ("--bits 23 --address-bits 8 --target siemens --resolution 0.0002", "power of ten"),
    ("--bits 23 --address-bits 8 --target acs --resolution 0.0001", "--sign correction"),
    ("--bits 23 --address-bits 8 --target siemens --resolution 0.0001 --sign error",
     "not siemens"),
    ("--bits 23 --address-bits 24", "--address-bits"),
    ("--bits 23 --address-bits 10 --target acs --zone -3", "--zone"),
])
def test_make_rom_refuses(model_file, tmp_path, args, what):
    out = tmp_path / "t.bin"
    r = run(f"enc make-rom {model_file} {args} --allow-no-gain -q -o {out}")
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


# --------------------------------------------------------------------- settings


@pytest.mark.parametrize("kw, what", [
    ({"code_bits": 41}, "--bits must be 1..40, not 41"),
    ({"code_bits": 23, "address_bits": 24}, "--address-bits must be 1..23 (--bits), not 24"),
    ({"code_bits": 32}, "2^32 = 4294967296 entries requested"),
    ({"code_bits": 23, "width": 33}, "--width must be 2..32 bits, not 33"),
    ({"code_bits": 23, "width": 1}, "--width must be 2..32 bits, not 1"),
    ({"code_bits": 23, "lsb": 0.0}, "--lsb must be a positive number of counts, not 0.0"),
    ({"code_bits": 23, "lsb": float("nan")}, "--lsb must be a positive number"),
    ({"code_bits": 23, "sample": "middle"}, "--sample must be centre or start, not 'middle'"),
    ({"code_bits": 23, "target": "siemens", "resolution_deg": 1e-4},
     "siemens: 8388609 table points exceed the 5000"),
    ({"code_bits": 23, "address_bits": 14, "target": "acs", "max_entries": 10000,
      "resolution_deg": 1e-4, "sign": "correction"}, "acs: 16385 table points exceed the 10000"),
    ({"code_bits": 10, "target": "bin", "endian": "middle"}, "--endian must be little or big"),
    ({"code_bits": 10, "target": "xyz"}, "--target must be one of bin, ihex"),
])
def test_make_rom_settings_refuse(kw, what):
    from enctools.cli import make_rom, usage
    from enctools.errors import SettingsError
    from enctools.models.rom import Settings

    with pytest.raises(SettingsError) as err:
        Settings(**kw)
    said = usage.message(err.value, make_rom.command, "make-rom")  # as the command says it
    assert said.startswith(what) and "\n" not in said


def test_make_rom_settings_resolve_the_defaults():
    from enctools.models.rom import Settings

    acs = Settings(23, address_bits=8, target="acs", resolution_deg=1e-4, sign="error")
    assert acs.spec.sample == "start" and acs.table.axis == "0" and acs.table.fmt == "acs"
    assert acs.table.count_deg == 1e-4 and acs.table.decimals == 4 and acs.table.sign == -1
    assert acs.spec.lsb == pytest.approx(1e-4 / (360 / 2 ** 23))
    assert Settings(23, address_bits=8, target="siemens",
                    resolution_deg=1e-4).table.axis == "AX1"
    mif = Settings(23, address_bits=12, width=12, target="mif")
    assert mif.spec.sample == "centre" and mif.table.width == 12
    stream = Settings(23, address_bits=10)
    assert stream.to_meta() == {"code_bits": 23, "address_bits": 10, "width": 16, "lsb": 1.0,
                                "sample": "centre", "target": "stream", "endian": "little"}
    assert Settings(16).to_meta()["address_bits"] == 16  # all n bits when not given
    with pytest.raises(ValueError, match="not a table file"):
        _ = stream.table


# --------------------------------------------------------------------- general readers

VALUES = np.array([-5, 0, 7, -2048, 2047, 1, 3, -3], dtype=np.int16)


@pytest.mark.parametrize("fmt", rf.FORMATS)
def test_general_reader_reads_our_files_too(tmp_path, fmt):
    """Each format's general reader gives what its fast reader gives on a file written here."""
    target = rf.Target(fmt, 12, count_deg=0.25)
    path = tmp_path / f"x.{fmt}"
    rf.write_table(str(path), VALUES, target, comment=["a comment; with a semicolon"])
    fast, general = rf.READERS[fmt]
    data = path.read_bytes()
    if fast is not None:
        assert np.array_equal(fast(data, target, str(path)), VALUES)
    assert np.array_equal(general(data, target, str(path)), VALUES)


def _foreign(tmp_path, fmt: str, text: str | bytes, target: rf.Target) -> np.ndarray:
    """Read a file written by hand: its fast reader declines it, read_table reads it."""
    path = tmp_path / f"foreign.{fmt}"
    data = text.encode() if isinstance(text, str) else text
    path.write_bytes(data)
    fast, _ = rf.READERS[fmt]
    assert fast is None or fast(data, target, str(path)) is None
    return rf.read_table(str(path), target)


def _ihex_line(rtype: int, addr: int, payload: bytes) -> str:
    body = bytes([len(payload), (addr >> 8) & 255, addr & 255, rtype]) + payload
    return ":" + (body + bytes([-sum(body) & 255])).hex() + "\r\n"


def test_ihex_with_other_records_is_read(tmp_path):
    """32-byte records out of order, each after an 02 segment record, lower case, CRLF,
    blank lines: an image past 64 KiB."""
    values = np.random.default_rng(1).integers(-30000, 30000, 40_000).astype(np.int16)
    image = values.astype("<i2").tobytes()
    chunks = [(a, image[a:a + 32]) for a in range(0, len(image), 32)]
    order = np.random.default_rng(2).permutation(len(chunks))
    lines = [_ihex_line(2, 0, (chunks[k][0] >> 4).to_bytes(2, "big"))
             + _ihex_line(0, 0, chunks[k][1]) + "\r\n" for k in order]
    text = "".join(lines) + ":00000001FF\r\n"
    assert np.array_equal(_foreign(tmp_path, "ihex", text, rf.Target("ihex", 16)), values)


def test_mif_with_comments_radices_runs_and_ranges_is_read(tmp_path):
    text = ("% written by hand %\nWIDTH = 12 ;\nDEPTH = 10;\nADDRESS_RADIX = DEC;\n"
            "DATA_RADIX = HEX;\nCONTENT\nBEGIN\n    0  :   FFF;   -- minus one\n"
            "    [1..3] : 001 002;\n4 : 7FF 800 000;\n9 : 123;\n7 : 5;\n8 : a;\nEND;\n")
    got = _foreign(tmp_path, "mif", text, rf.Target("mif", 12))
    assert got.tolist() == [-1, 1, 2, 1, 2047, -2048, 0, 5, 10, 291]
    binary = ("WIDTH=4;\nDEPTH=3;\nADDRESS_RADIX=OCT;\nDATA_RADIX=BIN;\nCONTENT BEGIN\n"
              "0 : 1111 0111;\n2 : 1000;\nEND;\n")
    assert _foreign(tmp_path, "mif", binary, rf.Target("mif", 4)).tolist() == [-1, 7, -8]


@pytest.mark.parametrize("body, what", [
    ("0 : 1;\n1 : 2;\n", "1 of 3 addresses have no value"),
    ("0 : 1 2 3 4;\n", "an address is outside DEPTH=3"),
    ("0 : 1 2;\n2 ;\n", "cannot read the content statement"),
])
def test_mif_general_reader_names_the_fault(tmp_path, body, what):
    path = tmp_path / "bad.mif"
    path.write_text(f"WIDTH=8;\nDEPTH=3;\nCONTENT BEGIN\n{body}END;\n")
    with pytest.raises(DataError, match=what):
        rf.read_table(str(path), rf.Target("mif", 8))


def test_coe_with_line_breaks_and_other_radices_is_read(tmp_path):
    want = [-5, 0, 7, -2048, 2047, 1]
    hex_rows = ("; by hand\nmemory_initialization_radix=16;\nmemory_initialization_vector=\n"
                "FFB, 000, 007,\n800,7FF,\n001;\n")
    assert _foreign(tmp_path, "coe", hex_rows, rf.Target("coe", 12)).tolist() == want
    decimal = ("memory_initialization_radix = 10;\nmemory_initialization_vector =\n"
               "-5, 0, 7,\n-2048 2047\n1;\n")
    assert _foreign(tmp_path, "coe", decimal, rf.Target("coe", 12)).tolist() == want
    binary = "memory_initialization_radix=2;\nmemory_initialization_vector=1011 0111 1000;"
    assert _foreign(tmp_path, "coe", binary, rf.Target("coe", 4)).tolist() == [-5, 7, -8]


def test_mem_with_block_comments_and_jumps_is_read(tmp_path):
    text = ("/* a header\n   over lines */\n@0 FFFB 0000 // two words\n0007 F800\n@4\n07FF\n"
            "0001\n")
    got = _foreign(tmp_path, "mem", text, rf.Target("mem", 16))
    assert got.tolist() == [-5, 0, 7, -2048, 2047, 1]
    jumps = "@3 F800\n@0 FFFB 0000 0007\n"
    assert _foreign(tmp_path, "mem", jumps, rf.Target("mem", 16)).tolist() == [-5, 0, 7, -2048]
    gap = tmp_path / "gap.mem"
    gap.write_text("@0 0001\n@2 0002\n")
    with pytest.raises(DataError, match="gaps"):
        rf.read_table(str(gap), rf.Target("mem", 16))


def test_csv_without_comments_and_with_crlf_is_read(tmp_path):
    text = "address,correction\r\n0,-5\r\n1,0\r\n2,7\r\n"
    assert _foreign(tmp_path, "csv", text, rf.Target("csv", 16)).tolist() == [-5, 0, 7]


def test_controller_tables_in_any_order_are_read(tmp_path):
    """Entries in any order, blanks around = and inside brackets (lsb 0.25 deg)."""
    acs = ("GLOBAL REAL MAP(5)\nMAP(3) = 0.5\n  MAP(0)=-0.25\nMAP(4)= -0.25\nMAP(2) =0.25\n"
           "MAP(1)=5e-1\nERRORMAP1D 2, 0, 0, 90.0, MAP\nERRORMAPON 2, 0\n")
    target = rf.Target("acs", count_deg=0.25, name="MAP")
    assert _foreign(tmp_path, "acs", acs, target).tolist() == [-1, 2, 1, 2]
    siemens = ("$AA_ENC_COMP_IS_MODULO[0,C1]=1\n$AA_ENC_COMP_MAX[0,C1]=360.0\n"
               "$AA_ENC_COMP[ 0 , 2 , C1 ] = 0.25\n$AA_ENC_COMP[0,0,C1]=-0.25\n"
               "$AA_ENC_COMP[0,4,C1]=-0.25\n$AA_ENC_COMP[0,1,C1]=0.5\n$AA_ENC_COMP[0,3,C1]=0.5\n"
               "$AA_ENC_COMP_STEP[0,C1]=90\n$AA_ENC_COMP_MIN[0,C1]=0\nM17\n")
    target = rf.Target("siemens", count_deg=0.25, axis="C1")
    assert _foreign(tmp_path, "siemens", siemens, target).tolist() == [-1, 2, 1, 2]
