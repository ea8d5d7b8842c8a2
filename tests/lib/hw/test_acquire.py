"""enc acquire and the virtual rig, scored against the ground truth it writes."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pytest
from conftest import one_error_line, run, run_in_process

from enctools.data import streams
from enctools.data.readings import head_info
from enctools.data.truth import Truth, signal_phase_error
from enctools.units import ARCSEC, TWO_PI

HEADS = ["P1", "P2", "H1", "H2", "H3", "H4", "H5", "H6", "H7"]


@pytest.fixture(scope="module")
def sjtu(sjtu_raw):
    return streams.read_table(str(sjtu_raw), "readings")


@pytest.mark.slow
def test_default_run_shape(sjtu):
    header, table = sjtu
    assert table.num_rows == 237_624  # 20 r at 1 r/min every 5.05 ms (1200 s / 5.05 ms)
    assert table.column_names == ["t"] + HEADS
    for h in HEADS:
        f = table.schema.field(h)
        assert f.type == pa.int64()
        info = head_info(table.schema, h)
        assert info.counts_per_rev == {"I": 180_000, "II": 52_000}[info.encoder] * 4096
    assert head_info(table.schema, "H7").alpha == pytest.approx(np.radians(228))
    assert head_info(table.schema, "P1").radius_m == pytest.approx(0.063)
    t = table.column("t").to_numpy()
    assert np.allclose(np.diff(t), 0.00505)
    assert header.meta["settings"]["revolutions"] == 20
    last = header.history[-1]
    assert last.endswith("enc acquire --rig sjtu-dual -o " + last.split(" -o ")[-1])


@pytest.mark.slow
def test_every_format_reads_back_identical(sjtu_raw, sjtu, tmp_path):
    _, ref = sjtu
    r = run(f"enc acquire --rig sjtu-dual | cat > {tmp_path}/raw.arrows && "
            f"enc acquire --rig sjtu-dual -o {tmp_path}/raw.h5 && "
            f"enc acquire --rig sjtu-dual -o {tmp_path}/raw.arrow")
    assert r.returncode == 0, r.stderr
    ref_header, _ = sjtu
    for name in ("raw.arrows", "raw.h5", "raw.arrow"):
        header, table = streams.read_table(str(tmp_path / name), "readings")
        assert table.equals(ref), name
        assert header.schema.equals(ref.schema, check_metadata=True), name
        assert header.meta["truth"] == ref_header.meta["truth"], name


def expected_reading(truth: Truth, info, theta: np.ndarray) -> np.ndarray:
    """Seed 000 eq. (1) evaluated from the truth, without noise [rad from the head's zero]."""
    x = truth.radial[info.encoder]["x"](theta)
    y = truth.radial[info.encoder]["y"](theta)
    ideal = (theta + truth.graduation[info.encoder](theta + info.alpha) * ARCSEC
             + (x * np.sin(info.alpha) - y * np.cos(info.alpha)) * 1e-9 / info.radius_m)
    phase = np.mod(ideal + info.alpha, TWO_PI) * info.periods_per_rev
    psi = signal_phase_error(truth.signals[info.name], phase) / info.periods_per_rev
    return ideal + psi


@pytest.mark.parametrize("head", HEADS)
@pytest.mark.slow
def test_truth_reproduces_the_readings(sjtu, head):
    """Counts minus the model from the truth leave noise + quantisation only.

    Tolerance: the residual's RMS is within 10 % of sqrt(noise^2 + LSB^2/6) (the rounding of
    the reading and of the model), its mean within 5 % of the noise, and no sample beyond
    6 noise sigma + 1 LSB."""
    header, table = sjtu
    truth = Truth.from_dict(header.meta["truth"])
    info = head_info(table.schema, head)
    rig_head = next(h for e in header.meta["rig"]["encoders"] for h in e["heads"]
                    if h["name"] == head)
    sigma = rig_head["noise_arcsec"]
    idx = slice(0, None, 7)  # every 7th sample: 57 000 per head is plenty
    t = table.column("t").to_numpy()[idx]
    counts = table.column(head).to_numpy()[idx]
    theta = truth.motion(t)
    model = np.rint((expected_reading(truth, info, theta) + info.alpha)
                    * info.counts_per_rev / TWO_PI) - info.zero_count
    lsb = 360 * 3600 / info.counts_per_rev
    resid = (counts - model) * lsb
    expect = np.sqrt(sigma**2 + lsb**2 / 6)
    assert abs(resid.std() - expect) < 0.1 * expect, (resid.std(), expect)
    assert abs(resid.mean()) < 0.05 * sigma
    assert np.abs(resid).max() < 6 * sigma + lsb


def _harmonics_over_turns(err: np.ndarray, theta: np.ndarray, nmax: int) -> np.ndarray:
    """Complex harmonics c_n (a - i b convention) of err(theta) over whole turns.

    A direct DFT at the true angles: the drive's speed is not exactly nominal, so
    samples are neither a whole number per turn nor exactly uniform."""
    turns = np.floor((theta[-1] - theta[0]) / TWO_PI)
    keep = theta - theta[0] < turns * TWO_PI
    e, th = err[keep], theta[keep]
    z = np.exp(-1j * th)
    zn = np.ones_like(z)
    out = np.zeros(nmax + 1, dtype=np.complex128)
    for n in range(nmax + 1):
        out[n] = 2 * np.mean(e * zn)
        zn *= z
    return out


@pytest.mark.slow
def test_four_equally_spaced_heads_keep_multiples_of_four(sjtu):
    """A sanity check of the simulator: mean(H1..H4) - theta has only multiples of 4.

    Tolerance 2e-3" per harmonic (noise averages to ~1e-5"; quantisation and the
    tabulated model stay below 1e-3")."""
    header, table = sjtu
    truth = Truth.from_dict(header.meta["truth"])
    t = table.column("t").to_numpy()
    theta = truth.motion(t)
    err = np.zeros_like(theta)
    for h in ("H1", "H2", "H3", "H4"):
        info = head_info(table.schema, h)
        reading = table.column(h).to_numpy() * (TWO_PI / info.counts_per_rev)
        r = reading - theta
        err += (r - r.mean()) / 4
    got = _harmonics_over_turns(err / ARCSEC, theta, 160)
    want = truth.graduation["II"].band(multiple_of=4).harmonics(160)
    n = np.arange(161)
    assert np.abs(got[n % 4 != 0]).max() < 2e-3
    assert np.abs(got[1:] - want[1:]).max() < 2e-3
    assert np.abs(want[4::4]).max() > 0.02  # the test has something to see


def test_interpolation_error_truth_is_heydemann():
    from enctools.data.truth import SignalFaults, interpolation_error

    f = SignalFaults(0.05, 0.0, 1.0, 0.0)
    x = np.linspace(0, 2 * np.pi / 52000, 2001)
    psi = interpolation_error(f, x, 52000)
    period = 360 * 3600 / 52000
    # a cosine offset o gives a 1st-harmonic phase error of amplitude ~o rad
    assert np.ptp(psi) == pytest.approx(2 * 0.05 * period / TWO_PI, rel=0.01)


def test_steps_run_on_the_polygon(ciomp_steps):
    header, table = streams.read_table(str(ciomp_steps), "readings")
    assert table.num_rows == 24 * 5
    assert set(table.column("step").to_numpy()) == set(range(24))
    truth = Truth.from_dict(header.meta["truth"])
    # the table stops where the encoder (mean of F1, F2) reads the target, so the
    # autocollimator sees minus the encoder's error there minus the face angle error (the
    # certificate's sign: face j is square j 15 deg + its error on from face 0)
    ac = table.column("AC").to_numpy()
    target = table.column("target").to_numpy()
    j = table.column("step").to_numpy()
    eps = truth.graduation["A"]
    enc_err = (eps(target) + eps(target + np.pi)) / 2
    predicted = -(enc_err - enc_err[0]) - truth.polygon[j]
    assert np.abs((ac - ac[0] - truth.polygon[0]) - predicted).max() < 0.25  # noise + servo
    assert np.std(enc_err[::5]) == pytest.approx(1.3, abs=0.25)  # seed 001: 1.30"


@pytest.mark.slow
def test_sweep_probes_follow_the_rotation(tmp_path):
    r = run(f"enc acquire --rig sjtu-dual --mode sweep --readings 1 -o {tmp_path}/s.parquet")
    assert r.returncode == 0, r.stderr
    _, table = streams.read_table(str(tmp_path / "s.parquet"))
    assert table.num_rows == 51  # 25" at 0.5"
    s1 = table.column("S1").to_numpy()
    s2 = table.column("S2").to_numpy()
    psi = (s1 - s2) / 2 / 0.2 / ARCSEC  # side * h / L, averaged
    assert psi[-1] == pytest.approx(25.0, abs=0.05)
    assert np.all(np.isfinite(s1)) and np.all(np.isfinite(s2))  # 24 um: within range


@pytest.mark.slow
def test_probes_beyond_their_range_read_nan(tmp_path):
    """A steps run round the circle (README: an ISO 230-2 run of a rig of your own) turns
    the 200 mm arm metres past the probes: they read NaN beyond 1 mm of their zero, as a
    real probe out of range does, and the run is kept."""
    out = tmp_path / "iso.parquet"
    r = run(f"enc acquire --rig sjtu-dual --mode steps --count 8 --readings 2 -o {out}")
    # the summary line only: no warning, no error
    assert r.returncode == 0 and r.stderr.decode().startswith("enc acquire: mode steps, rows 16,")
    assert len(r.stderr.splitlines()) == 1, r.stderr.decode()
    _, table = streams.read_table(str(out))
    step = table.column("step").to_numpy()
    for name in ("S1", "S2"):
        s = table.column(name).to_numpy()
        assert np.all(np.isfinite(s[step == 0])) and np.all(np.abs(s[step == 0]) < 1e-6)
        assert np.all(np.isnan(s[step > 0])), name
    assert np.all(table.column("H1").is_valid().to_numpy(zero_copy_only=False))


def test_counter_wrap_is_unwrapped():
    from enctools.hw.acquire import Unwrapper

    u = Unwrapper(8)
    raw = np.arange(0, 1000, 7) % 256
    assert np.array_equal(u(raw[:50]), np.arange(0, 350, 7))
    assert np.array_equal(u(raw[50:]), np.arange(350, 1000, 7))
    assert u(np.array([3]), expected=256 * 5.1)[0] == 256 * 5 + 3


@pytest.mark.slow
def test_replay_passes_the_recording_through(sjtu_raw, sjtu, tmp_path):
    r = run(f"enc acquire --replay {sjtu_raw} | enc acquire --replay - -o {tmp_path}/r.parquet")
    assert r.returncode == 0, r.stderr
    header, table = streams.read_table(str(tmp_path / "r.parquet"))
    assert table.equals(sjtu[1])
    assert len(header.history) == 3


def test_closed_pipe_ends_quietly():
    r = run("enc acquire --rig sjtu-dual | head -c 100 > /dev/null; echo ${PIPESTATUS[0]}")
    assert r.stderr == b""
    assert r.stdout.strip() == b"0"


@pytest.mark.slow
def test_seed_changes_noise_not_truth(tmp_path):
    run(f"enc acquire --rig sjtu-dual --revolutions 0.1 --seed 7 -o {tmp_path}/a.arrows")
    run(f"enc acquire --rig sjtu-dual --revolutions 0.1 --seed 8 -o {tmp_path}/b.arrows")
    run(f"enc acquire --rig sjtu-dual --revolutions 0.1 --seed 7 -o {tmp_path}/c.arrows")
    ha, a = streams.read_table(str(tmp_path / "a.arrows"))
    hb, b = streams.read_table(str(tmp_path / "b.arrows"))
    _, c = streams.read_table(str(tmp_path / "c.arrows"))
    assert a.equals(c) and not a.equals(b)
    assert ha.meta["truth"] == hb.meta["truth"]


@pytest.mark.parametrize("args, words", [
    ("--rig no-such-rig", "unknown rig 'no-such-rig'"),
    ("--rig sjtu-dual --revolutions 0", "--revolutions"),
    ("--rig sjtu-dual --mode spin", "--mode"),
    ("--rig sjtu-dual --heads H1,H9", "no head 'H9'"),
    ("--rig sjtu-dual --interval -1", "--interval"),
    ("--rig sjtu-dual --format hdf5", "cannot be written to a pipe"),
    ("", "give --rig"),
    ("--rig sjtu-dual --seed -5", "--seed"),
    ("--rig ciomp-23bit --mode steps --overshoot -1", "--overshoot"),
    ("--rig sjtu-dual --mode sweep --start nan", "--start"),
    ("--rig ciomp-23bit --mode steps --positions 0,nan", "finite"),
])
def test_bad_usage(tmp_path, args, words):
    out = tmp_path / "out.parquet"
    r = run(f"enc acquire {args} -o {out}" if "--format" not in args
            else f"set -o pipefail; enc acquire {args} | cat")
    err = r.stderr.decode()
    assert r.returncode == 2, err
    assert err.startswith("enc acquire: error: ") and err.count("\n") == 1, err
    assert words in err
    assert not out.exists()


def test_rig_file_typo_is_named(tmp_path):
    from importlib import resources
    text = (resources.files("enctools") / "rigs" / "sjtu-dual.toml").read_text()
    bad = tmp_path / "typo.toml"
    bad.write_text(text.replace("periods_per_rev = 52000", "periods_per_revs = 52000"))
    out = tmp_path / "x.parquet"
    r = run(f"enc acquire --rig {bad} -o {out}")
    err = r.stderr.decode()
    assert r.returncode == 2
    assert "unknown key 'periods_per_revs' in [encoder[1]]; did you mean 'periods_per_rev'?" in err
    assert not out.exists()


def test_existing_output_needs_force(tmp_path):
    out = tmp_path / "x.arrows"
    assert run(f"enc acquire --rig sjtu-dual --revolutions 0.01 -o {out}").returncode == 0
    r = run(f"enc acquire --rig sjtu-dual --revolutions 0.01 -o {out}")
    assert r.returncode == 2 and b"--force" in r.stderr
    assert run(f"enc acquire --rig sjtu-dual --revolutions 0.01 -o {out} --force").returncode == 0


def test_environment_defaults_and_precedence(tmp_path):
    out = tmp_path / "x.arrows"
    r = run(f"enc acquire --revolutions 0.02 -o {out}",
            env={"ENC_RIG": "sjtu-dual", "ENC_ACQUIRE_INTERVAL": "0.006"})
    assert r.returncode == 0, r.stderr
    header, table = streams.read_table(str(out))
    assert table.num_rows == 200  # 0.02 r = 1.2 s at 6 ms
    assert header.meta["settings"]["interval_s"] == 0.006
    r = run(f"enc acquire --revolutions 0.02 --interval 0.012 -o {out} --force",
            env={"ENC_RIG": "sjtu-dual", "ENC_ACQUIRE_INTERVAL": "0.006"})
    assert streams.read_table(str(out))[1].num_rows == 100


@pytest.mark.parametrize("args, line", [
    ("--rig sjtu-dual --readings 3", "--readings applies to Runs of positions (--mode steps, "
     "sweep or closure), not to Continuous runs (--mode continuous)"),
    ("--rig ciomp-23bit --revolutions 2", "--revolutions applies to Continuous runs "
     "(--mode continuous), not to Step runs (--mode steps)"),
    ("--rig ciomp-23bit --mode sweep --count 8", "--count applies to Step runs (--mode steps), "
     "not to Sweep runs (--mode sweep)"),
    ("--rig sjtu-dual --pace", "--pace applies to Replays (--replay FILE), not to Continuous "
     "runs (--mode continuous)"),
])
def test_an_option_of_another_kind_of_run_is_refused(tmp_path, args, line):
    """Options that a kind of run would have ignored: refused in one line, by the mode given
    or the rig's (ciomp-23bit's is steps); the help lists them under their kind."""
    out = tmp_path / "out.parquet"
    r = run_in_process(f"enc acquire {args} -o {out}")
    assert one_error_line(r, 2) == f"enc acquire: error: {line}"
    assert not out.exists()


def test_options_shared_by_kinds_of_run_apply_in_each(tmp_path):
    out = tmp_path / "out.parquet"
    r = run_in_process(f"enc acquire --rig sjtu-dual --mode sweep --range 1 --readings 1 "
                       f"--bidirectional -q -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    assert streams.read_table(str(out))[1].column("direction").to_pylist() == [1, 1, 1, -1, -1, -1]
    help_text = run_in_process("enc acquire --help").stdout.decode()
    for heading, option in (("Continuous runs", "--interval"), ("Runs of positions", "--settle"),
                            ("Step runs", "--positions"), ("Sweep runs", "--range"),
                            ("Replays", "--pace")):
        assert help_text.index(heading) < help_text.index(option), heading
