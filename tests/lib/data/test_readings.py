"""Head geometry (enctools.data.readings), in process: the angles against the formula of
seed 000 eq. (1) evaluated exactly, the head field metadata written by acquisition read
back to the rig's geometry, and the rig read back from the metadata of enc acquire."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pyarrow as pa
import pytest

from enctools.data import readings
from enctools.data.readings import (
    HeadInfo,
    head_angle,
    head_field,
    head_info,
    head_offset,
    head_reading,
    mean_head_angle,
    mean_head_reading,
    measuring_heads,
    rig_encoder,
    rig_encoders,
    rig_measure_heads,
)
from enctools.data.rig import load_rig
from enctools.data.streams import read_table
from enctools.errors import DataError
from enctools.units import DEG, TWO_PI

#: 2 pi as the library holds it: the reference below is exact given this constant
PI2 = Fraction(TWO_PI)


def exact_spindle_reading(c: int, z: int, cpr: int, alpha: float) -> Fraction:
    """(c + z) 2 pi / cpr - alpha [rad], in exact rational arithmetic."""
    return (c + z) * PI2 / cpr - Fraction(alpha)


CASES = [  # counts per rev, zero count, alpha [deg]
    (180_000 * 4096, 90_000 * 4096, 180.0),      # sjtu-dual P2
    (52_000 * 4096, 32_933 * 4096, 228.0),       # sjtu-dual H7: zero at the nearest line
    (1 << 23, 3 << 21, 270.0),
    (4096 * 2048, 0, 0.0),
]


@pytest.mark.parametrize("cpr, z, alpha_deg", CASES)
def test_head_reading_is_the_scale_angle_minus_alpha(cpr, z, alpha_deg):
    """Spindle reading = (c + z) 2 pi / cpr - alpha, to a few ulp of a turn, over +-3 turns."""
    rng = np.random.default_rng(cpr % 1000)
    alpha = alpha_deg * DEG
    counts = rng.integers(-3 * cpr, 3 * cpr, 2000)
    got = head_reading(counts, cpr, z, alpha)
    want = np.array([float(exact_spindle_reading(int(c), z, cpr, alpha)) for c in counts])
    assert np.max(np.abs(got - want)) <= 4 * np.spacing(6 * np.pi)


@pytest.mark.parametrize("cpr, z, alpha_deg", CASES)
def test_zero_based_angle_and_offset(cpr, z, alpha_deg):
    """head_angle = c 2 pi / cpr; head_angle - head_reading = alpha - z 2 pi / cpr."""
    alpha = alpha_deg * DEG
    info = HeadInfo("H", "E", alpha, cpr, cpr // 4096, 4096, 0.1, z)
    counts = np.array([-cpr, -1, 0, 1, 12345, cpr // 3, 2 * cpr + 7])
    want = [float(int(c) * PI2 / cpr) for c in counts]
    assert np.allclose(head_angle(counts, info), want, rtol=0, atol=1e-15)
    assert head_offset(cpr, z, alpha) == pytest.approx(float(Fraction(alpha) - z * PI2 / cpr),
                                                       abs=1e-15)
    diff = head_angle(counts, info) - head_reading(counts, cpr, z, alpha)
    assert np.allclose(diff, head_offset(cpr, z, alpha), rtol=0, atol=1e-14)
    # Arrow arrays read the same as numpy arrays
    assert np.array_equal(head_angle(pa.array(counts), info), head_angle(counts, info))
    assert np.array_equal(head_reading(pa.chunked_array([counts]), cpr, z, alpha),
                          head_reading(counts, cpr, z, alpha))


def test_means_of_heads():
    """The mean spindle reading and the mean zero-based angle of diametral heads."""
    cpr = 1 << 23
    a = HeadInfo("F1", "E", 0.0, cpr, 4096, 2048, 0.1, 0)
    b = HeadInfo("F2", "E", np.pi, cpr, 4096, 2048, 0.1, cpr // 2)
    c1 = np.array([0, 1000, cpr // 4])
    c2 = np.array([5, 995, cpr // 4 - 3])
    want = [float(sum((exact_spindle_reading(int(x), h.zero_count, cpr, h.alpha)
                       for x, h in ((x1, a), (x2, b)))) / 2) for x1, x2 in zip(c1, c2, strict=True)]
    assert np.allclose(mean_head_reading([c1, c2], [a, b]), want, rtol=0, atol=1e-15)
    angle = mean_head_angle([pa.array(c1), pa.array(c2)], [a, b])
    assert np.allclose(angle, (c1 + c2) * TWO_PI / cpr / 2, rtol=0, atol=1e-15)
    with pytest.raises(ValueError):
        mean_head_reading([c1, c2], [a])


def test_head_field_round_trips_through_head_info():
    f = head_field("H7", "II", 228.0, 52_000 * 4096, 52_000, 4096, 0.165655, 32_933 * 4096,
                   average_of="H1,H2")
    assert f.type == pa.int64()
    schema = pa.schema([pa.field("t", pa.float64()), f])
    info = head_info(schema, "H7")
    assert info == HeadInfo("H7", "II", 228.0 * DEG, 52_000 * 4096, 52_000, 4096, 0.165655,
                            32_933 * 4096)
    md = {k.decode(): v.decode() for k, v in f.metadata.items()}
    assert md["unit"] == "count" and md["role"] == "head" and md["average_of"] == "H1,H2"
    assert readings.heads(schema) == [info]
    with pytest.raises(DataError, match=r"no head 'H1'.*heads: H7"):
        head_info(schema, "H1", "run.parquet")
    with pytest.raises(DataError, match="column 't' is not a head"):
        head_info(schema, "t")


@pytest.mark.parametrize("rig_name", ["sjtu-dual", "ciomp-23bit"])
def test_acquired_head_fields_decode_to_the_rigs_geometry(rig_name):
    """The columns acquisition writes give back each head's encoder, angle, counts and zero."""
    from enctools.hw import acquire as acq
    from enctools.hw import open_session
    from enctools.hw.sim import zero_count

    rig = load_rig(rig_name)
    with open_session(rig) as session:
        schema = acq.readings_schema(rig, session, acq.resolve(rig, {"mode": "steps"}))
    assert [i.name for i in readings.heads(schema)] == rig.head_names
    for enc, h in rig.heads:
        info = head_info(schema, h.name)
        assert (info.encoder, info.counts_per_rev, info.periods_per_rev, info.interpolation) == \
            (enc.name, enc.counts_per_rev, enc.periods_per_rev, enc.interpolation)
        assert info.alpha == pytest.approx(h.angle, abs=1e-14)
        assert info.radius_m == enc.radius_m
        assert info.zero_count == zero_count(enc, h.angle)


def test_rig_read_back_from_enc_acquire_metadata(ciomp_steps):
    """The encoders of meta["rig"] written by enc acquire are the rig file's encoders."""
    header, _ = read_table(str(ciomp_steps), "readings")
    rig = load_rig("ciomp-23bit")
    assert rig_encoders(header.meta) == rig.encoders
    enc = rig_encoder(header.meta, "A")
    assert enc is not None and enc.counts_per_rev == 1 << 23
    assert rig_measure_heads(header.meta, "A") == ("F1", "F2")
    assert measuring_heads(header.schema, header.meta) == ["F1", "F2"]
    assert rig_encoder(header.meta, "B") is None and rig_measure_heads(header.meta, "B") == ()


def test_rig_accessor_without_a_rig():
    assert rig_encoders({}) == () and rig_encoders({"rig": {"name": "x"}}) == ()
    assert rig_measure_heads({"rig": None}, "A") == ()
    enc = rig_encoders({"rig": {"encoders": [{"name": "E", "periods_per_rev": 10}]}})[0]
    assert (enc.name, enc.periods_per_rev, enc.counts_per_rev, enc.measure_heads) == \
        ("E", 10, 0, ())
    with pytest.raises(DataError, match="malformed encoder"):
        rig_encoders({"rig": {"encoders": [{"name": "E", "periods_per_rev": "many"}]}})


@pytest.mark.parametrize("interpolation", [4096, 1000, 1])
def test_signal_step_is_the_floor_modulo(interpolation):
    """The step within the period: a mask for a power of two, a modulo otherwise; the
    floor modulo either way, for counts below zero too."""
    from enctools.data.readings import signal_step
    counts = np.array([-2**40 - 3, -4097, -1, 0, 1, 4095, 4096, 123_456_789, 2**50 + 7])
    info = HeadInfo("H", "E", 0.0, interpolation * 100, 100, interpolation, 0.1, 77)
    step = signal_step(counts, info)
    assert np.array_equal(step, np.mod(counts + 77, interpolation))
    assert step.min() >= 0 and step.max() < interpolation
    assert np.array_equal(counts[:2], [-2**40 - 3, -4097])  # the input is left alone
