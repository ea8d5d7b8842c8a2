"""What enc make-rom writes, enc correct reads back: every memory format, word width, byte
order, address bits and contents, the corrections applied bit for bit on the same codes.

The property test runs in-process through the library calls the two commands make
(``rom.build_rom``, ``romformats.write_table`` with the table's comment, and
``correction.load`` with no option but what a raw image has no place for); a few cases
run the commands themselves. Contents include words whose image begins (and ends) with
another format's signature: ``FF FF FF FF`` (an Arrow stream's marker: words of -1),
``PAR1``, ``ARROW1`` and HDF5's.
"""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest
from conftest import DATA, run
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from enctools.data import streams
from enctools.data.curves import Column, deviations_table
from enctools.data.header import Header
from enctools.models import correction, rom, romformats

TURN_ARCSEC = 1_296_000.0
EXT = {"bin": ".bin", "ihex": ".hex", "mif": ".mif", "coe": ".coe", "mem": ".mem", "csv": ".csv"}
SIGNATURES = (b"\xff\xff\xff\xff", b"PAR1", b"ARROW1", b"\x89HDF\r\n\x1a\n")


def signature_words(sig: bytes, entries: int, width: int, endian: str) -> np.ndarray:
    """Words whose binary image begins and ends with ``sig`` (as far as the words hold it;
    the rest -1), each within the signed range of ``width`` bits."""
    size = 1 if width <= 8 else 2 if width <= 16 else 4
    image = np.full(entries * size, 0xFF, np.uint8)
    n = min(len(sig), image.size)
    image[:n] = np.frombuffer(sig[:n], np.uint8)
    image[image.size - n:] = np.frombuffer(sig[len(sig) - n:], np.uint8)
    words = image.view(f"{'<' if endian == 'little' else '>'}i{size}").astype(np.int64)
    lo, hi = -(1 << (width - 1)), (1 << (width - 1)) - 1
    return np.clip(words, lo, hi)  # a word wider than the width: the nearest it holds


@st.composite
def tables(draw: st.DrawFn) -> tuple[str, int, str, int, int, float, str, np.ndarray, bool]:
    """(format, width, endian, code bits n, address bits m, lsb, sample, words, named)."""
    fmt = draw(st.sampled_from(sorted(EXT)))
    width = draw(st.sampled_from([2, 3, 7, 8, 9, 12, 16, 17, 24, 31, 32]))
    endian = draw(st.sampled_from(["little", "big"]))
    n = draw(st.integers(1, 24))
    m = draw(st.integers(1, min(n, 9)))
    lsb = draw(st.sampled_from([1.0, 2.0, 0.5, 3.0]))
    sample = draw(st.sampled_from(["centre", "start"]))
    lo, hi = -(1 << (width - 1)), (1 << (width - 1)) - 1
    kind = draw(st.sampled_from(["-1", "0", "extremes", "random", "signature"]))
    entries = 1 << m
    if kind in ("-1", "0"):
        words = np.full(entries, int(kind), np.int64)
    elif kind == "extremes":
        pick = draw(st.lists(st.sampled_from([lo, hi, -1, 0]), min_size=entries,
                             max_size=entries))
        words = np.array(pick, np.int64)
    elif kind == "random":
        seed = draw(st.integers(0, 2 ** 32 - 1))
        words = np.random.default_rng(seed).integers(lo, hi, entries, endpoint=True)
    else:
        words = signature_words(draw(st.sampled_from(SIGNATURES)), entries, width, endian)
    named = fmt == "bin" or draw(st.booleans())  # else: a name without an extension
    return fmt, width, endian, n, m, lsb, sample, words, named


def model_of(words: np.ndarray, spec: rom.RomSpec):
    """A deviation model [deg -> arcsec] whose table under ``spec`` is ``words``."""
    first, step = spec.grid_deg()

    def deviation(deg: np.ndarray) -> np.ndarray:
        k = np.rint((np.asarray(deg) - first) / step).astype(np.int64)
        return -words[k] * spec.lsb_arcsec
    return deviation


# 800 examples, about 10 s (pytest --hypothesis-show-statistics gives the count and time)
@pytest.mark.slow  # 800 examples, 10-17 s: the slow tier
@settings(max_examples=800, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                 HealthCheck.function_scoped_fixture])
@given(case=tables())
def test_every_table_written_is_applied_bit_for_bit(tmp_path, case):
    fmt, width, endian, n, m, lsb, sample, words, named = case
    s = rom.Settings(n, m, width, lsb, sample, fmt, endian)
    table = rom.build_rom(model_of(words, s.spec), s.spec)
    assert np.array_equal(table.values, words)  # the model gives these words
    path = tmp_path / f"t{EXT[fmt] if named else ''}"
    for old in tmp_path.iterdir():
        old.unlink()
    romformats.write_table(str(path), table.values, s.table, True, table.file_comment())
    # a raw image states nothing: its width, LSB and byte order are given, its bits come from
    # the rig of the stream corrected; every other format states its layout
    given_ = correction.TableSettings(width=width, lsb=lsb, endian=endian) if fmt == "bin" \
        else correction.TableSettings()
    loaded = correction.load(str(path), given_, rig_bits=n if fmt == "bin" else None)
    assert isinstance(loaded, correction.MemoryTable)
    d = loaded.describe()
    assert (d["format"], d["code_bits"], d["address_bits"]) == (fmt, n, m)
    assert d["layout_from"] == {"bin": "rig", "ihex": "sidecar", "csv": "sidecar"}.get(
        fmt, "comment")
    assert fmt == "bin" or d["sample"] == sample
    rng = np.random.default_rng(int(words[0]) & 0xFFFF)
    edges = (np.arange(1 << m, dtype=np.int64) << (n - m))
    codes = np.r_[edges, edges + (1 << (n - m)) - 1, rng.integers(0, 1 << n, 64)]
    got = loaded.correction_counts(codes)
    want = words[codes >> (n - m)] * lsb
    assert np.array_equal(got, want)  # bit for bit, on the same codes


# ----------------------------------------------------------------- the commands themselves


def curve_file(path, words: np.ndarray, lsb_arcsec: float) -> None:
    """A deviations stream whose table (--sample start, 2^m addresses) is ``words``."""
    theta = np.arange(words.size) * (2 * np.pi / words.size)
    curve = deviations_table(theta, [Column("e", -words * lsb_arcsec)])
    streams.write_table(str(path), Header("deviations", curve.schema, {}), curve)


def points_file(path, position_deg: np.ndarray) -> None:
    rows = "".join(f"{p!r},0\n" for p in position_deg.tolist())
    path.write_text("position_deg,deviation_arcsec\n" + rows)


@pytest.mark.parametrize("name,extra", [("t.bin", "--bits 12 --endian big"),
                                        ("t.hex", ""), ("t.csv", ""), ("t", ""),
                                        ("t.mem", "")])
def test_a_table_of_minus_ones_reads_back_without_options(tmp_path, name, extra):
    """Words of -1 (FF FF FF FF...) first, the commonest small correction: make-rom's file
    applied by enc correct, only a raw image needing its layout named."""
    n, m = 12, 6
    words = np.r_[np.full(8, -1), np.arange(56) % 7 - 3]
    curve_file(tmp_path / "dev.parquet", words, TURN_ARCSEC / 2 ** n)
    target = "--target mif " if name == "t" else ""
    big = " --endian big" if name == "t.bin" else ""
    r = run(f"enc make-rom {tmp_path}/dev.parquet --curve e --bits {n} --address-bits {m} "
            f"--sample start {target}{big} -o {tmp_path}/{name} -q --verify")
    assert r.returncode == 0, r.stderr.decode()
    if name == "t.bin":
        assert (tmp_path / name).read_bytes()[:4] == b"\xff\xff\xff\xff"
    pos = np.arange(64) * 360.0 / 64 + 1e-3
    points_file(tmp_path / "p.csv", pos)
    r = run(f"enc correct {tmp_path}/p.csv --table {tmp_path}/{name} {extra} "
            f"-o {tmp_path}/c.parquet -q")
    assert r.returncode == 0, r.stderr.decode()
    after = pq.read_table(tmp_path / "c.parquet").column("deviation").to_numpy()
    assert np.array_equal(np.rint(after / (TURN_ARCSEC / 2 ** n)), words)


def test_a_raw_image_names_the_options_it_needs(tmp_path):
    """No rig to say the code's bits: the error names every option a raw image needs, and
    the command it suggests works."""
    words = np.full(64, -1)
    curve_file(tmp_path / "dev.parquet", words, TURN_ARCSEC / 2 ** 12)
    assert run(f"enc make-rom {tmp_path}/dev.parquet --curve e --bits 12 --address-bits 6 "
               f"-o {tmp_path}/t.bin -q").returncode == 0
    r = run(f"enc correct {DATA}/seed001_table1.csv --table {tmp_path}/t.bin")
    err = r.stderr.decode()
    assert r.returncode == 2 and err.count("\n") == 1, err
    for option in ("--bits", "--width", "--lsb", "--endian"):
        assert option in err
    r = run(f"enc correct {DATA}/seed001_table1.csv --table {tmp_path}/t.bin --bits 12 "
            "--width 16 --lsb 1 --endian little -q")
    assert r.returncode == 0, r.stderr.decode()


@pytest.mark.slow
def test_the_demos_raw_image_corrects_the_dense_turn_as_its_mif_does(tmp_path):
    """make demo's campaign (examples/ciomp-23bit.mk): the 23-bit table as a MIF and as a
    raw image, whose first words are -1 (FF FF FF FF, an Arrow stream's marker). The raw
    image, given no option, is read as one (its name says so) with the code's bits from
    the dense turn's rig: the same corrected stream and figures as the MIF."""
    d = tmp_path
    r = run(f"enc acquire --rig ciomp-23bit --mode steps | enc points | enc fit-rbf -q "
            f"-o {d}/model.parquet && "
            f"enc make-rom {d}/model.parquet --width 16 -o {d}/correction.mif -q && "
            f"enc make-rom {d}/model.parquet --width 16 -o {d}/correction.bin -q && "
            f"enc acquire --rig ciomp-23bit --mode continuous --revolutions 1 --interval 0.005 "
            f"-o {d}/dense.parquet -q")
    assert r.returncode == 0, r.stderr.decode()
    assert (d / "correction.bin").read_bytes()[:4] == b"\xff\xff\xff\xff"
    out = {}
    for t in ("mif", "bin"):
        r = run(f"enc correct {d}/dense.parquet --table {d}/correction.{t} "
                f"-o {d}/residual-{t}.parquet --json")
        assert r.returncode == 0, r.stderr.decode()
        out[t] = json.loads(r.stdout)
    assert out["bin"]["table"]["layout_from"] == "rig"
    assert out["bin"]["table"]["code_bits"] == 23
    for key in ("before", "after", "constant", "s_ratio", "pp_ratio"):
        assert out["bin"][key] == out["mif"][key]
    a, b = (pq.read_table(d / f"residual-{t}.parquet") for t in ("mif", "bin"))
    assert a.column_names == ["theta", "before", "after"] and a.equals(b)
    assert out["mif"]["after"]["s_bessel_arcsec"] < 0.7 * out["mif"]["before"]["s_bessel_arcsec"]


def test_a_hostile_sidecar_is_one_line(tmp_path):
    """A table's sidecar is read within the limits of a stream's header: nested past
    them, it is refused in one line (exit 2), not parsed into a recursion error."""
    (tmp_path / "t.csv").write_text("0,1\n1,2\n")
    (tmp_path / "t.csv-metadata.json").write_text("[" * 100000 + "]" * 100000)
    r = run(f"enc correct {DATA}/seed001_table1.csv --table {tmp_path}/t.csv")
    err = r.stderr.decode()
    assert r.returncode == 2 and err.count("\n") == 1 and "nested" in err, err
