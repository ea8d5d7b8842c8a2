"""What a table file claims of its size is checked before it is believed: a MIF's DEPTH,
a binary image's length, against the code's addresses and the largest table; the words
of a table in a layout enctools writes read a block at a time, equal to the whole read."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import one_error_line, run_in_process

from enctools.errors import DataError
from enctools.models import romformats
from enctools.models.romformats import blockread, readers
from enctools.models.romformats.words import Target

HEADER = "WIDTH=16;\nDEPTH={depth};\nADDRESS_RADIX=HEX;\nDATA_RADIX=HEX;\nCONTENT BEGIN\n"


def _points(tmp_path: Path) -> Path:
    p = tmp_path / "points.csv"
    p.write_text("position_deg,deviation_arcsec\n0,1\n90,2\n180,-1\n270,0.5\n")
    return p


def test_a_mif_depth_beyond_the_code_is_refused_before_it_is_allocated(tmp_path: Path) -> None:
    table = tmp_path / "huge.mif"
    table.write_text(HEADER.format(depth=1 << 40) + "\t0 : 0001;\n\t1 : 0002;\nEND;\n")
    r = run_in_process(f"enc correct {_points(tmp_path)} --table {table} --bits 23")
    line = one_error_line(r, 2, "enc correct")
    assert f"{table}: DEPTH=1099511627776 entries do not address a 23-bit code" in line
    assert "2^23 = 8388608" in line and "--bits" in line


def test_a_mif_depth_beyond_the_largest_table_is_refused(tmp_path: Path) -> None:
    table = tmp_path / "huge.mif"
    table.write_text(HEADER.format(depth=1 << 40) + "\t0 : 0001;\nEND;\n")
    with pytest.raises(DataError, match=r"DEPTH=1099511627776 entries, more than the 2\^28"):
        romformats.read_table(str(table), Target("mif", 16))


def test_a_mif_whose_lines_do_not_fill_its_depth_is_refused_before_allocating(
        tmp_path: Path) -> None:
    table = tmp_path / "short.mif"
    table.write_text(HEADER.format(depth=1 << 28) + "\t0 : 0001;\n\t1 : 0002;\nEND;\n")
    with pytest.raises(DataError, match="268435454 of 268435456 addresses have no value"):
        readers.read_mif(table.read_bytes(), Target("mif", 16), str(table))


def test_mif_ranges_are_counted_before_they_are_spread(tmp_path: Path) -> None:
    text = HEADER.format(depth=8) + "[0..7] : 1 2;\n[0..FFFFFFFFFF] : 3;\nEND;\n"
    with pytest.raises(DataError, match="an address is outside DEPTH=8"):
        readers.read_mif(text.encode(), Target("mif", 16), "t.mif")
    text = HEADER.format(depth=8) + "[0..7] : 1 2;\n[0..3] : 3;\nEND;\n"
    with pytest.raises(DataError, match="the content gives 12 values, more than DEPTH=8"):
        readers.read_mif(text.encode(), Target("mif", 16), "t.mif")
    text = HEADER.format(depth=8) + "[0..5] : 1 2;\n6 : 3 4;\nEND;\n"
    got = readers.read_mif(text.encode(), Target("mif", 16), "t.mif")
    assert got.tolist() == [1, 2, 1, 2, 1, 2, 3, 4]


def test_a_binary_image_longer_than_the_code_is_refused_unread(tmp_path: Path) -> None:
    table = tmp_path / "big.bin"
    with table.open("wb") as f:  # 1 GiB, sparse: refused from its length, never read
        f.truncate(1 << 30)
    r = run_in_process(f"enc correct {_points(tmp_path)} --table {table} --bits 23")
    line = one_error_line(r, 2, "enc correct")
    assert f"{table}: 536870912 entries do not address a 23-bit code" in line


@pytest.mark.heavy
@pytest.mark.parametrize("fmt", ["bin", "mif", "coe", "mem", "csv", "ihex"])
@pytest.mark.parametrize("width", [8, 12, 16, 24, 32])
def test_block_reading_equals_the_whole_read(tmp_path: Path, fmt: str, width: int,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(width)
    lo, hi = -(1 << (width - 1)), (1 << (width - 1)) - 1
    values = np.repeat(rng.integers(lo, hi + 1, 300), 7)[:2048]
    values[:3] = [lo, hi, 0]
    path = tmp_path / f"t.{fmt}"
    t = Target(fmt, width)
    romformats.write_table(str(path), values, t, comment=["enctools make-rom: a test"])
    monkeypatch.setattr(blockread, "READ", 1000)  # many blocks, of whole lines
    words = blockread.read_words(str(path), t)
    assert words is not None and words.dtype.itemsize == t.storage_bytes
    assert np.array_equal(words, values)
    assert blockread.same_words(str(path), t, values)
    assert not blockread.same_words(str(path), t, np.r_[values[:-1], values[-1] ^ 1])
    romformats.verify_table(str(path), values, t)


def test_an_intel_hex_end_address_beyond_its_file_is_not_believed(tmp_path: Path) -> None:
    """A 4-line file whose last record sits at 0xFFFF0000: its image is not allocated from
    that address (read whole, where the gap is refused before the image is made)."""
    lines = [":020000040000FA", ":0100000001FE", ":02000004FFFFFC", ":01000000" + "01FE",
             ":00000001FF"]
    path = tmp_path / "t.hex"
    path.write_text("\n".join(lines) + "\n")
    assert blockread.blocks(str(path), Target("ihex", 8)) is None
    with pytest.raises(DataError, match="gaps in the image"):
        romformats.read_table(str(path), Target("ihex", 8))


@pytest.mark.parametrize("fmt", ["csv", "coe", "mem", "ihex"])
def test_counted_entries_are_held_to_the_code_before_they_are_allocated(
        tmp_path: Path, fmt: str) -> None:
    path = tmp_path / f"t.{fmt}"
    t = Target(fmt, 16)
    romformats.write_table(str(path), np.zeros(4096, np.int16), t)
    with pytest.raises(DataError, match=f"{path}: 4096 entries do not address a 10-bit code"):
        romformats.read_table(str(path), t, code_bits=10)
    assert romformats.read_table(str(path), t, code_bits=12).size == 4096
