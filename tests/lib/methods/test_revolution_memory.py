"""The revolutions of a continuous run are cut with bounded memory: a batch is analysed in
slices of at most MAX_REVOLUTION_VALUES / 2 channel samples, the same revolutions as
whole; a revolution of more channel samples than that is refused in one line."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest

from enctools.data.readings import HeadInfo
from enctools.errors import DataError
from enctools.methods import revolutions as rv
from enctools.units import TWO_PI

CPR = 1 << 20


def _heads(n: int) -> tuple[HeadInfo, ...]:
    from enctools.data.readings import head_info
    from enctools.data.schemas import make_field

    fields = [make_field(f"G{k}", pa.int64(), "count", "head", encoder="A",
                         alpha_deg=repr(360.0 * k / n), counts_per_rev=CPR,
                         periods_per_rev=1024, interpolation=1024, radius_m="0.1",
                         zero_count=CPR * k // n) for k in range(n)]
    schema = pa.schema(fields)
    return tuple(head_info(schema, f"G{k}") for k in range(n))


def _batch(heads: tuple[HeadInfo, ...], samples: int, per_rev: int) -> pa.RecordBatch:
    """``samples`` readings of every head, ``per_rev`` a revolution, each head with its own
    small graduation error (a harmonic k + 1 of 1e-5 rad)."""
    i = np.arange(samples)
    theta = i * TWO_PI / per_rev
    cols = {"t": pa.array(i * 0.001)}
    for k, h in enumerate(heads):
        err = 1e-5 * np.sin((k + 1) * theta)
        cols[h.name] = pa.array(np.round((theta + err) * CPR / TWO_PI).astype(np.int64))
    return pa.RecordBatch.from_pydict(cols)


def _cut(batch: pa.RecordBatch, heads: tuple[HeadInfo, ...]) -> list[rv.Revolution]:
    cutter = rv.RevolutionCutter(rv.ChannelSpec(heads, heads[:1]))
    return cutter(batch) + cutter.finish()


def test_slices_give_the_revolutions_of_the_whole_batch(monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    heads = _heads(3)
    batch = _batch(heads, 3 * 430 + 7, 430)
    whole = _cut(batch, heads)
    monkeypatch.setattr(rv, "MAX_REVOLUTION_VALUES", 2 * 3 * 300)  # slices of 300 rows
    sliced = _cut(batch, heads)
    assert [r.index for r in whole] == [r.index for r in sliced] == [0, 1, 2]
    for a, b in zip(whole, sliced, strict=True):
        assert a.start == b.start
        np.testing.assert_array_equal(a.u, b.u)
        np.testing.assert_allclose(a.values, b.values, rtol=0, atol=1e-15)


def test_a_revolution_beyond_the_bound_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    heads = _heads(8)
    monkeypatch.setattr(rv, "MAX_REVOLUTION_VALUES", 8 * 300)
    with pytest.raises(DataError, match=r"holds at least \d+ samples of 8 channels; at most "
                                        r"2400 values"):
        _cut(_batch(heads, 1200, 1000), heads)


def test_selfcal_refuses_more_heads_than_its_spectra_can_hold() -> None:
    """The moments of a revolution (heads x bins x terms) are checked before any reading."""
    from enctools.methods.selfcal import check_width

    check_width(7, 100, "in")
    check_width(6, 2000, "in")
    check_width(170, 100, "in")
    with pytest.raises(DataError, match=r"in: 4000 heads up to harmonic 100 need 98304000 "
                                        r"values a revolution .* give at most 170 `?heads"):
        check_width(4000, 100, "in")
