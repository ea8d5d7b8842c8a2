"""enc make-rom's tables written a block at a time (the words scanned, then given to the
writers as :class:`~enctools.models.romformats.words.Words`) are the bytes the code before
it wrote from a table held whole: the SHA-256 of each file below (its first 16 digits) and
the CRC-32 of its image were recorded from commit 0345448, which built the table in one
array. Every memory and controller format of the registry, at 2^10 and 2^18 entries, of
12-, 16- and 24-bit words; a model evaluated on its uniform grid and one at any angles.
The blocks are made smaller here and the words kept between the scan and the writing
limited, so that tables are read back from what was kept and evaluated again alike."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

from enctools.models import rom, romformats
from enctools.models.fourier import FourierModel
from enctools.models.romformats.words import Words

#: (SHA-256 of the file, first 16 hex digits; CRC-32 of the image), from commit 0345448
BEFORE = {
    "bin-10-12-grid": ("57fbbe89ed41852d", "902d6a6e"),
    "bin-big-10-12-grid": ("4e78199ec4a5c477", "902d6a6e"),
    "ihex-10-12-grid": ("1aa9320ec5ead8c2", "902d6a6e"),
    "mif-10-12-grid": ("88425b744e369757", "902d6a6e"),
    "coe-10-12-grid": ("3ce2f6bf637fbf6c", "902d6a6e"),
    "mem-10-12-grid": ("8644ca2ed0d2e7d3", "902d6a6e"),
    "csv-10-12-grid": ("0c70e4dcea1ec23d", "902d6a6e"),
    "bin-10-12-plain": ("57fbbe89ed41852d", "902d6a6e"),
    "bin-big-10-12-plain": ("4e78199ec4a5c477", "902d6a6e"),
    "ihex-10-12-plain": ("1aa9320ec5ead8c2", "902d6a6e"),
    "mif-10-12-plain": ("88425b744e369757", "902d6a6e"),
    "coe-10-12-plain": ("3ce2f6bf637fbf6c", "902d6a6e"),
    "mem-10-12-plain": ("8644ca2ed0d2e7d3", "902d6a6e"),
    "csv-10-12-plain": ("0c70e4dcea1ec23d", "902d6a6e"),
    "bin-10-16-grid": ("57fbbe89ed41852d", "902d6a6e"),
    "bin-big-10-16-grid": ("4e78199ec4a5c477", "902d6a6e"),
    "ihex-10-16-grid": ("1aa9320ec5ead8c2", "902d6a6e"),
    "mif-10-16-grid": ("2dc9464f2818b3b4", "902d6a6e"),
    "coe-10-16-grid": ("57536b024aa985db", "902d6a6e"),
    "mem-10-16-grid": ("cb71e54c70501773", "902d6a6e"),
    "csv-10-16-grid": ("0c70e4dcea1ec23d", "902d6a6e"),
    "bin-10-16-plain": ("57fbbe89ed41852d", "902d6a6e"),
    "bin-big-10-16-plain": ("4e78199ec4a5c477", "902d6a6e"),
    "ihex-10-16-plain": ("1aa9320ec5ead8c2", "902d6a6e"),
    "mif-10-16-plain": ("2dc9464f2818b3b4", "902d6a6e"),
    "coe-10-16-plain": ("57536b024aa985db", "902d6a6e"),
    "mem-10-16-plain": ("cb71e54c70501773", "902d6a6e"),
    "csv-10-16-plain": ("0c70e4dcea1ec23d", "902d6a6e"),
    "bin-10-24-grid": ("f0803f8029f227d3", "282cadb7"),
    "bin-big-10-24-grid": ("5320fe9648735506", "282cadb7"),
    "ihex-10-24-grid": ("ad65dd86cc4caabe", "282cadb7"),
    "mif-10-24-grid": ("c5bb524098426364", "282cadb7"),
    "coe-10-24-grid": ("5b6ef575188c8231", "282cadb7"),
    "mem-10-24-grid": ("ce07adcee2cacf4f", "282cadb7"),
    "csv-10-24-grid": ("0c70e4dcea1ec23d", "282cadb7"),
    "bin-10-24-plain": ("f0803f8029f227d3", "282cadb7"),
    "bin-big-10-24-plain": ("5320fe9648735506", "282cadb7"),
    "ihex-10-24-plain": ("ad65dd86cc4caabe", "282cadb7"),
    "mif-10-24-plain": ("c5bb524098426364", "282cadb7"),
    "coe-10-24-plain": ("5b6ef575188c8231", "282cadb7"),
    "mem-10-24-plain": ("ce07adcee2cacf4f", "282cadb7"),
    "csv-10-24-plain": ("0c70e4dcea1ec23d", "282cadb7"),
    "bin-18-16-grid": ("68714061bedfc642", "4f0d0f7c"),
    "bin-big-18-16-grid": ("dae95601eb3a9dbc", "4f0d0f7c"),
    "ihex-18-16-grid": ("8c643ac9975bd274", "4f0d0f7c"),
    "mif-18-16-grid": ("acce7561777fe740", "4f0d0f7c"),
    "coe-18-16-grid": ("7ccacebc4d0406e6", "4f0d0f7c"),
    "mem-18-16-grid": ("08b3800ac9c4dd42", "4f0d0f7c"),
    "csv-18-16-grid": ("06039c963db01b01", "4f0d0f7c"),
    "bin-18-24-grid": ("28298aa89a18bc3d", "e16c85d9"),
    "bin-big-18-24-grid": ("50034b423f80d0a0", "e16c85d9"),
    "ihex-18-24-grid": ("357ad444da31ad74", "e16c85d9"),
    "mif-18-24-grid": ("0bd0a86dec5c527e", "e16c85d9"),
    "coe-18-24-grid": ("ba22d51fd5c396e2", "e16c85d9"),
    "mem-18-24-grid": ("38e5759167e7f27d", "e16c85d9"),
    "csv-18-24-grid": ("06039c963db01b01", "e16c85d9"),
    "acs-12": ("a8a5fc5c9efaaa45", "cf9cceb9"),
    # the punch tape name %_N_AX_EEC_INI moved to the first line since (the file of
    # 0345448, 2fa8a2c3d273eb5d, is these bytes with that line back after the comments)
    "siemens-12": ("7fb610af57f0d185", "ff9f9b8f"),
}
FORMATS = [("bin", {}), ("bin", {"endian": "big"}), ("ihex", {}), ("mif", {}), ("coe", {}),
           ("mem", {}), ("csv", {})]


def model() -> FourierModel:
    """A deviation [arcsec] of 40 harmonics, fixed."""
    n = np.arange(0, 40)
    rng = np.random.default_rng(7)
    return FourierModel(n, rng.normal(0, 30.0, n.size) / (1 + n),
                        rng.normal(0, 30.0, n.size) / (1 + n))


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16]


@pytest.mark.heavy
@pytest.mark.parametrize("kept", [rom.KEPT_BYTES, 20_000, 0])
def test_tables_written_by_block_are_the_bytes_written_whole(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kept: int) -> None:
    monkeypatch.setattr(rom, "CHUNK", 1 << 16)  # many blocks; kept or evaluated again
    monkeypatch.setattr(rom, "KEPT_BYTES", kept)
    m = model()
    for key, (sha, crc) in BEFORE.items():
        fmt, *rest = key.split("-")
        if fmt in ("acs", "siemens"):
            continue
        endian = rest.pop(0) if rest[0] == "big" else "little"
        bits, width, how = int(rest[0]), int(rest[1]), rest[2]
        if bits > 10 and kept != 20_000:  # 2^18 entries once: some blocks kept, some not
            continue
        table = rom.scan_rom(m if how == "grid" else (lambda x: m(x)),
                             rom.RomSpec(bits + 3, bits, width, 0.25))
        assert isinstance(table.values, Words) and f"{table.crc32:08x}" == crc, key
        path = tmp_path / f"t.{fmt}"
        target = romformats.Target(fmt, width, endian)
        romformats.write_table(str(path), table.values, target, force=True,
                               comment=["enctools make-rom: hash"])
        assert digest(path) == sha, key
        romformats.verify_table(str(path), table.values, target)


@pytest.mark.parametrize("fmt,decimals", [("acs", 6), ("siemens", 5)])
def test_controllers_tables_are_the_bytes_written_whole(tmp_path: Path, fmt: str,
                                                        decimals: int) -> None:
    step = 10.0 ** -decimals
    table = rom.scan_rom(model(), rom.RomSpec(20, 12, 32, step / (360.0 / 2 ** 20), "start"))
    path = tmp_path / f"t.{fmt}"
    target = romformats.Target(fmt, 32, decimals=decimals, count_deg=step)
    romformats.write_table(str(path), table.values, target, force=True,
                           comment=["enctools make-rom: hash"])
    assert (digest(path), f"{table.crc32:08x}") == BEFORE[f"{fmt}-12"]
