"""A table quantised from a Fourier series' cheap evaluation (a cubic a segment of the grid,
:meth:`~enctools.models.fourier.GridSeries.near`) has the words, CRC-32, range, largest
quantisation error and largest correction of the table quantised from the exact
evaluation, bit for bit: each block's words are taken from the cubic only where no
correction is within the cubic's bound of a half LSB, and the blocks that may hold a
largest figure are evaluated again exactly."""

from __future__ import annotations

import numpy as np
import pytest

from enctools.models import rom, romquantise
from enctools.models.fourier import FourierModel


def _series(orders: int, scale: float = 1.0) -> FourierModel:
    rng = np.random.default_rng(orders)
    n = np.arange(orders + 1)
    return FourierModel(n, scale * rng.normal(size=n.size) / (1.0 + n),
                        scale * rng.normal(size=n.size) / (1.0 + n))


@pytest.mark.parametrize(("orders", "bits"), [(54, 20), (54, 26), (200, 22), (3, 12)])
def test_the_cubic_is_within_its_bound_of_the_exact_values(orders: int, bits: int) -> None:
    spec = rom.RomSpec(bits)
    grid = _series(orders).on_grid(*spec.grid_deg())
    for start in (0, (1 << bits) // 2, (1 << bits) - rom.CHUNK):
        start = max(start, 0)
        stop = min(1 << bits, start + rom.CHUNK)
        near, bound = grid.near(start, stop)
        exact = grid(start, stop)
        assert near.shape == exact.shape
        assert np.max(np.abs(near - exact)) <= bound
    if bits >= 20:  # fine enough to quantise from
        assert bound / spec.lsb_arcsec < romquantise.NEAR_LSB


def _tables(model: FourierModel, spec: rom.RomSpec, monkeypatch: pytest.MonkeyPatch
            ) -> tuple[rom.Rom, rom.Rom, dict[str, int]]:
    """The table from the cheap evaluation (counting how its blocks went) and from the
    exact one alone."""
    count = {"near": 0, "doubt": 0, "exact": 0}
    near, exact = romquantise.quantise_near, romquantise.quantise_exact

    def counted_near(*a: object) -> object:
        got = near(*a)  # type: ignore[arg-type]
        count["near" if got is not None else "doubt"] += 1
        return got

    def counted_exact(*a: object) -> object:
        count["exact"] += 1
        return exact(*a)  # type: ignore[arg-type]

    monkeypatch.setattr(romquantise, "quantise_near", counted_near)
    monkeypatch.setattr(romquantise, "quantise_exact", counted_exact)
    cheap = rom.scan_rom(model, spec)
    monkeypatch.setattr(romquantise, "quantise_near", lambda *a: None)
    return cheap, rom.scan_rom(model, spec), count


def _same(a: rom.Rom, b: rom.Rom) -> None:
    assert np.array_equal(np.asarray(a.values), np.asarray(b.values))
    assert (a.crc32, a.min_value, a.max_value) == (b.crc32, b.min_value, b.max_value)
    assert a.max_quantisation_lsb == b.max_quantisation_lsb
    assert a.max_abs_correction_lsb == b.max_abs_correction_lsb
    assert a.rms_quantisation_lsb == pytest.approx(b.rms_quantisation_lsb, rel=1e-9)
    assert a.rms_correction_lsb == pytest.approx(b.rms_correction_lsb, rel=1e-9)


@pytest.mark.parametrize("lsb", [1.0, 0.37, 64.0])
def test_a_table_from_the_cubic_is_the_table_from_the_exact_series(
        lsb: float, monkeypatch: pytest.MonkeyPatch) -> None:
    spec = rom.RomSpec(21, lsb=lsb, width=20)
    cheap, exact, count = _tables(_series(54, 40.0), spec, monkeypatch)
    _same(cheap, exact)
    assert count["near"] + count["doubt"] == spec.entries // rom.CHUNK
    # the cubic gave most blocks' words; a few blocks were evaluated again for the extremes
    assert count["near"] >= count["doubt"]
    assert 0 < count["exact"] <= count["doubt"] + 2 * spec.entries // rom.CHUNK


def test_corrections_on_a_half_lsb_are_quantised_from_the_exact_series(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A constant deviation of 3.5 LSB: every correction is a half LSB from two words, so
    no block's words are taken from the cubic."""
    spec = rom.RomSpec(20)
    model = FourierModel(np.arange(2), np.array([-3.5 * spec.lsb_arcsec, 0.0]), np.zeros(2))
    cheap, exact, count = _tables(model, spec, monkeypatch)
    _same(cheap, exact)
    assert count["near"] == 0
    assert count["doubt"] == spec.entries // rom.CHUNK


def _by_segments(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Count how quantise_segments went: blocks taken, left (UNSUITED) or in doubt."""
    count = {"taken": 0, "left": 0, "doubt": 0}
    inner = romquantise.quantise_segments

    def counted(*a: object) -> object:
        got = inner(*a)  # type: ignore[arg-type]
        key = "left" if got is romquantise.UNSUITED else "doubt" if got is None else "taken"
        count[key] += 1
        return got

    monkeypatch.setattr(romquantise, "quantise_segments", counted)
    return count


@pytest.mark.parametrize(("orders", "scale", "lsb", "bits"),
                         [(54, 40.0, 1.0, 22), (54, 40.0, 0.37, 21), (200, 5.0, 4.0, 22),
                          (3, 400.0, 1.0, 20)])
def test_a_table_quantised_a_segment_at_a_time_is_the_exact_table(
        orders: int, scale: float, lsb: float, bits: int,
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Words, CRC-32, range, largest figures equal to the exact table's, the blocks taken
    a segment at a time (the segments of one word summed in closed form)."""
    spec = rom.RomSpec(bits, lsb=lsb, width=24)
    count = _by_segments(monkeypatch)
    cheap, exact, _ = _tables(_series(orders, scale), spec, monkeypatch)
    _same(cheap, exact)
    assert count["taken"] >= spec.entries // rom.CHUNK // 2


def test_a_flat_table_is_left_to_the_whole_block() -> None:
    """A constant deviation of 3.2 LSB: every segment holds the largest correction, so
    every one would be evaluated point by point; the block is left to quantise_near's
    whole-block evaluation, which gives the same words."""
    spec = rom.RomSpec(20)
    model = FourierModel(np.arange(2), np.array([-3.2 * spec.lsb_arcsec, 0.0]), np.zeros(2))
    grid = model.on_grid(*spec.grid_deg())
    assert romquantise.quantise_segments(grid, spec, np.dtype(np.int16), 0, rom.CHUNK) \
        is romquantise.UNSUITED
    part, words = romquantise.quantise(grid, spec, np.dtype(np.int16), 0, rom.CHUNK)
    assert words is not None and np.all(words == 3)
    assert part[5] == pytest.approx(3.2, abs=1e-9)


def test_a_segment_near_a_half_lsb_is_evaluated_point_by_point() -> None:
    """A slope crossing half LSBs within segments: those segments' words change inside
    them, and come from each point's value, the others' from the segment's centre."""
    spec = rom.RomSpec(20)
    model = _series(54, 40.0)
    grid = model.on_grid(*spec.grid_deg())
    for start in (0, 5 * rom.CHUNK // 2):
        got = romquantise.quantise_segments(grid, spec, np.dtype(np.int32), start,
                                            start + rom.CHUNK)
        assert got is not None and got is not romquantise.UNSUITED
        exact = np.rint(-grid(start, start + rom.CHUNK) / spec.lsb_arcsec)
        assert np.array_equal(got[1], exact.astype(np.int32))
        assert np.any(np.diff(got[1]) != 0)
