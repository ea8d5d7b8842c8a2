"""enc interp-check against the simulator's truth (seed 000 sec. 4, figs. 10-15).

Noise conditions (the sjtu-dual rig's): head noise 0.01" (P) and 0.02" (H) per
reading, probes 1 nm each on L = 200 mm arms, positioning noise 0.005"; sweep of
25" at 0.5" steps from 60 deg with 20 readings per step (1020 samples; the rig's
default of 5 readings gives max differences just under 0.01" for the H heads).
The counts are quantised to 1/4096 of a period (0.0018" for P, 0.0061" for H).
"""

from __future__ import annotations

import json
import re

import numpy as np
import pyarrow as pa
import pytest
from conftest import run

from enctools.data.readings import head_info, signal_phase
from enctools.data.schemas import make_field
from enctools.data.streams import Header, read_table, write_table
from enctools.data.truth import Truth, interpolation_error_read
from enctools.errors import SettingsError
from enctools.methods.interp import Settings
from enctools.methods.interp.curve import error_figures
from enctools.methods.interp.fit import fit_interpolation_error
from enctools.methods.interp.model import landing_harmonics
from enctools.methods.interp.readings import check_readings
from enctools.methods.interp.reference import probe_rotation
from enctools.methods.interp.settings import DEFAULT_WINDOW_ARCSEC
from enctools.units import ARCSEC, DEG, TWO_PI

#: every test with the compiled kernel and with the numpy passes (conftest.kernel_path)
pytestmark = pytest.mark.usefixtures("kernel_path")

HEADS = ["P1", "P2", "H1", "H2", "H3", "H4", "H5", "H6", "H7"]


@pytest.fixture(scope="module")
def sweep(tmp_path_factory: pytest.TempPathFactory):
    d = tmp_path_factory.mktemp("interp")
    out = d / "sweep.parquet"
    r = run(f"enc acquire --rig sjtu-dual --mode sweep --readings 20 --signals -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    return out


#: truth [arcsec] as a function of the phase the head reads (phi_read = phi + e(phi))
read_phase_truth = interpolation_error_read


def zero_mean(x: np.ndarray) -> np.ndarray:
    return x - x.mean()


def check(args: str, out) -> tuple:
    r = run(f"enc interp-check {args} -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    return (*read_table(out, "deviations"), r)


@pytest.mark.slow
def test_every_head_against_probes_matches_truth(sweep, tmp_path):
    header, table, r = check(str(sweep), tmp_path / "ic.parquet")
    truth = Truth.from_dict(header.meta["truth"])
    theta = table["theta"].to_numpy()
    assert [c for c in table.column_names if not c.startswith(("theta", "u_"))] == HEADS
    for name in HEADS:
        curve = header.meta["curves"][name]
        ppr = curve["periods_per_rev"]
        want = zero_mean(read_phase_truth(truth.signals[name], theta, ppr))
        got = table[name].to_numpy()
        assert abs(got.mean()) < 1e-9
        diff = np.abs(got - want).max()
        assert diff < 0.01, f"{name}: {diff:.4f}\" from the truth"
        # the stated uncertainty is honest: within 4.5 u at every phase
        u = table[f"u_{name}"].to_numpy()
        assert np.all(np.abs(got - want) < 4.5 * u + 0.003), name
        fig = curve["figures"]
        assert fig["pp"] == pytest.approx(np.ptp(want), abs=0.015)
        assert curve["reference"] == "probes" and curve["probes"] == ["S1", "S2"]
    # summary on stderr: one line per head with +/- and p-p
    lines = r.stderr.decode().splitlines()
    assert len(lines) == len(HEADS) and all("p-p" in x for x in lines)


@pytest.mark.slow
def test_h1_against_p1_keeps_1st_2nd_harmonic(sweep, tmp_path):
    _, probes, _ = check(f"{sweep} --heads H1,H2", tmp_path / "cs.parquet")
    header, by_p1, r = check(f"{sweep} --heads H1,H2 --reference P1", tmp_path / "p1.parquet")
    meta = header.meta["curves"]["H1"]
    assert meta["period_ratio"] == pytest.approx(180000 / 52000)
    assert meta["kept"] == [1, 2]
    assert "lands" not in r.stderr.decode()
    theta = probes["theta"].to_numpy()
    # the probe result restricted to the same harmonics
    for name in ("H1", "H2"):
        cs = probes[name].to_numpy()
        c = np.fft.rfft(cs) / theta.size * 2
        cs12 = sum((c[n] * np.exp(1j * n * theta)).real for n in (1, 2))
        diff = np.abs(by_p1[name].to_numpy() - cs12).max()
        assert diff < 0.02, f"{name} by P1: {diff:.4f}\" from the probe result"
        assert np.abs(by_p1[name].to_numpy() - cs).max() < 0.02
    # the unfiltered difference H1 - P1 carries P1's error: clearly worse
    _, raw, _ = check(f"{sweep} --heads H1 --reference P1 --keep 1,2,3,4 "
                      "--reference-band 0", tmp_path / "raw.parquet")
    assert np.abs(raw["H1"].to_numpy() - probes["H1"].to_numpy()).max() > 0.03


@pytest.mark.slow
def test_reference_with_longer_period_warns(sweep, tmp_path):
    # the plain filter cannot remove H1's 2nd harmonic, at 0.578 of P1's period
    header, _, r = check(f"{sweep} --heads P1 --reference H1 --reference-band 0",
                         tmp_path / "w.parquet")
    err = r.stderr.decode()
    assert "WARNING" in err and "lands at 0.578" in err and "kept harmonic 1" in err
    assert header.meta["curves"]["P1"]["period_ratio"] == pytest.approx(52000 / 180000)
    # fitted alongside over 3.47 P1 periods it is separable (1.46 cycles apart): no warning,
    # and P1's error by H1 matches the probes' 1st/2nd harmonics
    header, by_h1, r = check(f"{sweep} --heads P1 --reference H1", tmp_path / "w2.parquet")
    assert "WARNING" not in r.stderr.decode()
    _, probes, _ = check(f"{sweep} --heads P1", tmp_path / "w3.parquet")
    assert np.abs(by_h1["P1"].to_numpy() - probes["P1"].to_numpy()).max() < 0.01
    # too many reference harmonics: H1's 3rd..8th crowd P1's 1st and 2nd
    out = tmp_path / "w4.parquet"
    r = run(f"enc interp-check {sweep} --heads P1 --reference H1 --reference-band 8 -o {out}")
    assert r.returncode == 2 and "undetermined" in r.stderr.decode()


@pytest.mark.parametrize("head, k", [("P1", 60), ("H1", 40)])
@pytest.mark.slow
def test_harmonics_beyond_the_sampling_are_refused(sweep, tmp_path, head, k):
    out = tmp_path / "o.parquet"
    r = run(f"enc interp-check {sweep} --heads {head} --band {k} -o {out}")
    assert "finely enough" in one_line_error(r, out)


@pytest.mark.slow
def test_head_average_matches_mean_of_truths(sweep, tmp_path):
    header, table, _ = check(f"{sweep} --heads H1,H2,H3,H4 --average", tmp_path / "a.parquet")
    name = "mean(H1,H2,H3,H4)"
    assert table.column_names == ["theta", name, f"u_{name}"]
    truth = Truth.from_dict(header.meta["truth"])
    _, raw = read_table(sweep)
    infos = [head_info(raw.schema, h) for h in ("H1", "H2", "H3", "H4")]
    phases = [signal_phase(raw[i.name].to_numpy(), i) for i in infos]
    want = np.mean([read_phase_truth(truth.signals[i.name], p, i.periods_per_rev)
                    for i, p in zip(infos, phases, strict=True)], axis=0)
    theta = table["theta"].to_numpy()
    got = np.interp(phases[0], theta, table[name].to_numpy(), period=TWO_PI)
    diff = zero_mean(got) - zero_mean(want)
    assert np.abs(diff).max() < 0.01


@pytest.mark.slow
def test_signals_mode_recovers_faults_and_error(sweep, tmp_path):
    header, table, _r = check(f"{sweep} --signals --spectrum {tmp_path / 's.parquet'} "
                             f"--corrected {tmp_path / 'c.parquet'}", tmp_path / "sig.parquet")
    truth = Truth.from_dict(header.meta["truth"])
    theta = table["theta"].to_numpy()
    for name in HEADS:
        fit = header.meta["signals"][name]["signals"]
        f = truth.signals[name]
        # noise-free simulated signals: the fit is exact
        assert fit["offset_cos"] == pytest.approx(f.offset_cos, abs=1e-9)
        assert fit["offset_sin"] == pytest.approx(f.offset_sin, abs=1e-9)
        assert fit["ratio"] == pytest.approx(f.ratio, abs=1e-9)
        assert fit["phase_rad"] == pytest.approx(f.phase, abs=1e-9)
        ppr = header.meta["curves"][name]["periods_per_rev"]
        want = zero_mean(read_phase_truth(f, theta, ppr))
        assert np.abs(table[name].to_numpy() - want).max() < 1e-6
        liss = header.meta["signals"][name]["lissajous"]
        assert liss["variation"] > 0.02
        # readings repeated at each position hold the extremes at one phase: no flat top
        assert header.meta["signals"][name]["screen"]["faults"] == []
    _spec_h, spec = read_table(tmp_path / "s.parquet", "spectrum")
    assert set(spec["curve"].to_pylist()) == set(HEADS)
    # counts re-interpolated from the corrected phase: interpolation error gone
    _, fixed, _ = check(f"{tmp_path / 'c.parquet'} --heads H1,P2", tmp_path / "f.parquet")
    for name in ("H1", "P2"):
        assert np.ptp(fixed[name].to_numpy()) < 0.01


@pytest.mark.slow
def test_check_tolerance_exit_1(sweep, tmp_path):
    r = run(f"enc interp-check {sweep} --heads P1 --max-pm 0.01 -o {tmp_path / 'k.parquet'}")
    assert r.returncode == 1
    assert r.stderr.decode().splitlines()[-1].startswith("enc interp-check: error: P1:")
    r = run(f"enc interp-check {sweep} --heads P1 --max-pm 0.5 -q > {tmp_path / 'k2.arrows'}")
    assert r.returncode == 0 and r.stderr == b""


@pytest.mark.slow
def test_pipeline_from_acquire(tmp_path):
    out = tmp_path / "p.arrows"
    r = run(f"enc acquire --rig sjtu-dual --mode sweep --range 8 --step 0.25 --heads P1,P2 "
            f"| enc interp-check | enc info > {out}")
    assert r.returncode == 0, r.stderr.decode()
    text = out.read_text()
    assert "deviations stream" in text and "u_P2" in text


# ----------------------------------------------------------------- bad input


def one_line_error(r, out) -> str:
    err = r.stderr.decode().strip().splitlines()
    assert r.returncode == 2, r.stderr.decode()
    assert len(err) == 1 and err[0].startswith("enc interp-check: error:"), err
    assert not out.exists()
    return err[0]


@pytest.mark.slow
def test_sweep_shorter_than_one_period(tmp_path):
    out = tmp_path / "o.parquet"
    r = run(f"enc acquire --rig sjtu-dual --mode sweep --range 10 --readings 1 --heads H1 -q "
            f"| enc interp-check -o {out}")
    assert "signal period is 24.92" in one_line_error(r, out)


@pytest.mark.slow
def test_reference_without_overlap_in_time(sweep, tmp_path):
    header, table = read_table(sweep)
    t = table["t"].to_numpy() + 1e6
    moved = table.set_column(0, table.schema.field("t"), pa.array(t))
    ref = tmp_path / "later.parquet"
    write_table(str(ref), header, moved)
    out = tmp_path / "o.parquet"
    r = run(f"enc interp-check {sweep} --heads H1 --reference P1 --reference-file {ref} -o {out}")
    assert "no overlap in time" in one_line_error(r, out)
    # the same file in time works (the reference matched by t)
    r = run(f"enc interp-check {sweep} --heads H1 --reference P1 --reference-file {sweep} -o {out}")
    assert r.returncode == 0, r.stderr.decode()


@pytest.mark.slow
def test_zero_arm_length(sweep, tmp_path):
    out = tmp_path / "o.parquet"
    assert "--arm" in one_line_error(run(f"enc interp-check {sweep} --arm 0 -o {out}"), out)
    header, table = read_table(sweep)
    fields = []
    for f in table.schema:
        if f.name == "S1":
            md = dict(f.metadata)
            md[b"arm_m"] = b"0"
            f = f.with_metadata(md)
        fields.append(f)
    bad = tmp_path / "arm0.parquet"
    schema = pa.schema(fields)
    write_table(str(bad), Header("readings", schema, header.meta), table.cast(schema))
    assert "L = 0" in one_line_error(run(f"enc interp-check {bad} -o {out}"), out)


@pytest.mark.parametrize("args, words", [
    ("--heads H9", "no head 'H9'"),
    ("--reference Q1", "no head 'Q1'"),
    ("--heads H1 --reference H1", "device itself"),
    ("--heads H1 --keep 7", "kept harmonic 7"),
    ("--signals --heads H1 --min-arc 400", "--min-arc"),
    ("--signals --heads H1 --allow-excluded 150", "--allow-excluded"),
    ("--signals --heads H1 --rails 1,-1", "--rails must be LOW,HIGH"),
    ("--rails -1,1", "--rails applies to Signals mode (--signals), not to Reference mode"),
    ("--corrected x.parquet", "--corrected applies to Signals mode (--signals)"),
])
@pytest.mark.slow
def test_bad_options(sweep, tmp_path, args, words):
    out = tmp_path / "o.parquet"
    assert words in one_line_error(run(f"enc interp-check {sweep} {args} -o {out}"), out)


@pytest.mark.slow
def test_wrong_kind_and_short_arc(sweep, tmp_path):
    dev = tmp_path / "dev.parquet"
    assert run(f"enc interp-check {sweep} --heads P1 -o {dev}").returncode == 0
    out = tmp_path / "o.parquet"
    assert "readings" in one_line_error(run(f"enc interp-check {dev} -o {out}"), out)
    r = run(f"enc acquire --rig sjtu-dual --mode sweep --range 1 --step 0.1 --readings 1 "
            f"--signals --heads H1 -q | enc interp-check --signals -o {out}")
    assert "head H1" in one_line_error(r, out) and "deg" in r.stderr.decode()


# ------------------------------------------------------------------ library


def test_landing_harmonics():
    assert landing_harmonics(180000 / 52000, [1, 2]) == []
    assert landing_harmonics(52000 / 180000, [1, 2]) == [(2, pytest.approx(0.5778, abs=1e-3), 1)]
    assert landing_harmonics(1.0, [1, 2]) == [(1, 1.0, 1), (2, 2.0, 2)]


def test_fit_recovers_synthetic_error_with_trend():
    rng = np.random.default_rng(3)
    ppr = 52000
    theta = np.linspace(0, 30 * ARCSEC, 400)
    phase = np.mod(theta * ppr + 0.3, TWO_PI)
    err = 0.1 * np.cos(phase + 0.2) + 0.05 * np.sin(2 * phase)
    dev = theta + (err + 0.02 + 3e-3 * theta / ARCSEC) * ARCSEC + rng.normal(0, 1e-3, 400) * ARCSEC
    r = fit_interpolation_error(dev, phase, theta, ppr, harmonics=3)
    g = np.linspace(0, TWO_PI, 100)
    want = 0.1 * np.cos(g + 0.2) + 0.05 * np.sin(2 * g)
    assert np.abs(r.error(g) - want).max() < 6 * r.error.uncertainty(g).max()
    assert r.error.amplitude[0] == pytest.approx(0.1, abs=5e-4)
    assert r.residual_rms == pytest.approx(1e-3, rel=0.2)
    assert error_figures(want)["pp"] == pytest.approx(r.figures()["pp"], abs=2e-3)


def test_probe_rotation_cancels_translation():
    rot = np.linspace(0, 1e-4, 11)
    y = 50e-9 * np.sin(np.arange(11))
    s1, s2 = 0.2 * rot + y, -0.2 * rot + y
    assert np.allclose(probe_rotation([s1, s2], [0.2, 0.2], [1, -1]), rot, atol=1e-15)
    with pytest.raises(Exception, match="L = 0"):
        probe_rotation([s1], [0.0], [1])


@pytest.mark.slow
def test_summary_meta_is_json(sweep, tmp_path):
    header, _, _ = check(f"{sweep} --heads P2", tmp_path / "j.parquet")
    json.dumps(header.meta)
    h = header.meta["curves"]["P2"]["harmonics"]
    assert [x["n"] for x in h] == [1, 2, 3, 4]


@pytest.mark.slow
def test_seed000_test1_p1_figures(tmp_path):
    """Seed 000 table 1, test 1 (7.2" at 0.2", 37 points) on P1 and P2; fig. 10/11 figures:
    P1 p-p 0.086-0.100" within +/-0.06", P2 p-p 0.124-0.140", encoder I within +/-0.1"."""
    out = tmp_path / "t1.parquet"
    r = run(f"enc acquire --rig sjtu-dual --mode sweep --range 7.2 --step 0.2 --heads P1,P2 "
            f"| enc interp-check -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    header, table = read_table(out)
    truth = Truth.from_dict(header.meta["truth"])
    theta = table["theta"].to_numpy()
    for name in ("P1", "P2"):
        want = zero_mean(read_phase_truth(truth.signals[name], theta, 180000))
        assert np.abs(table[name].to_numpy() - want).max() < 0.01
        assert header.meta["curves"][name]["periods_swept"] == pytest.approx(1.0, abs=0.01)
        assert header.meta["curves"][name]["figures"]["plus_minus"] < 0.1
    p1 = header.meta["curves"]["P1"]["figures"]
    assert 0.08 < p1["pp"] < 0.12 and p1["plus_minus"] < 0.065
    # P1 is dominated by its 1st harmonic, P2 has a clear 2nd (figs. 10, 11)
    h1 = [h["amplitude"] for h in header.meta["curves"]["P1"]["harmonics"]]
    h2 = [h["amplitude"] for h in header.meta["curves"]["P2"]["harmonics"]]
    assert h1[1] < 0.1 * h1[0] and h2[1] > 0.4 * h2[0]


@pytest.mark.slow
def test_missing_probe_readings_are_skipped(sweep, tmp_path):
    header, table = read_table(sweep)
    s1 = table["S1"].to_numpy().copy()
    s1[::7] = np.nan
    holed = table.set_column(table.schema.get_field_index("S1"), table.schema.field("S1"),
                             pa.array(s1))
    src = tmp_path / "holes.parquet"
    write_table(str(src), header, holed)
    _, t, _ = check(f"{src} --heads H1", tmp_path / "h.parquet")
    _, ref, _ = check(f"{sweep} --heads H1", tmp_path / "r.parquet")
    assert np.abs(t["H1"].to_numpy() - ref["H1"].to_numpy()).max() < 0.005


@pytest.mark.slow
def test_nan_probe_samples_are_skipped_and_said(sweep, tmp_path):
    """A probe that dropped out on a few samples (NaN): those samples are left out of
    the fit, the command says how many, and the result still matches the clean sweep."""
    header, table = read_table(sweep, "readings")
    s1 = table.column("S1").to_numpy().copy()
    bad = np.arange(5, s1.size, 97)[:12]
    s1[bad] = np.nan
    i = table.schema.get_field_index("S1")
    holed = table.set_column(i, table.schema.field(i), pa.array(s1))
    write_table(str(tmp_path / "holed.parquet"), header, holed)
    _, clean, _ = check(f"{sweep} --heads H1", tmp_path / "clean.parquet")
    _, got, r = check(f"{tmp_path}/holed.parquet --heads H1", tmp_path / "got.parquet")
    err = r.stderr.decode()
    assert f"{bad.size} of {s1.size} samples skipped" in err, err
    diff = got["H1"].to_numpy() - clean["H1"].to_numpy()
    assert np.max(np.abs(diff)) < 0.005  # arcsec: 12 of ~5000 samples fewer


# ------------------------------------------------------- settings and numerics in-process


@pytest.mark.parametrize("options, words", [
    ({"arm_m": 0.0}, "--arm must be 1e-06..10 m"),
    ({"arm_m": float("nan")}, "--arm must be 1e-06..10 m"),
    ({"corrected": True}, "--corrected needs --signals"),
    ({"signals": True, "average": True}, "--mean-of-heads does not apply to --signals"),
    ({"signals": True, "window_arcsec": 900.0}, "--window applies to the reference mode"),
    ({"rails_v": (-1.0, 1.0)}, "--rails needs --signals"),
    ({"signals": True, "rails_v": (1.0, -1.0)}, "--rails must be LOW,HIGH"),
    ({"signals": True, "rails_v": (1.0,)}, "--rails must be LOW,HIGH"),
    ({"signals": True, "rails_v": (-1.0, float("inf"))}, "--rails must be LOW,HIGH"),
    ({"signals": True, "allow_excluded_pct": float("nan")}, "--allow-excluded must be 0..100"),
    ({"signals": True, "allow_excluded_pct": 101.0}, "--allow-excluded must be 0..100"),
])
def test_settings_refuse_bad_combinations(options, words):
    """The library names fields; the command line shows them as its options."""
    from enctools.cli import interp_check
    from enctools.cli.usage import message

    with pytest.raises(SettingsError) as err:
        Settings(**options)
    assert re.search(words, message(err.value, interp_check.command, "interp-check"))


def test_settings_resolve_the_window_and_record_the_options():
    s = Settings(heads=["H1", "H2"], reference="P1", keep=[1, 2])
    assert s.heads == ("H1", "H2") and s.keep == (1, 2)
    assert s.trend_window_arcsec(continuous=False) is None
    assert s.trend_window_arcsec(continuous=True) == DEFAULT_WINDOW_ARCSEC
    assert Settings(window_arcsec=7200.0).trend_window_arcsec(continuous=False) == 7200.0
    assert s.to_meta(continuous=True) == {
        "heads": ["H1", "H2"], "average": False, "harmonics": None, "points": 256, "trend": 1,
        "mode": "reference", "window_arcsec": 1800.0, "reference": "P1",
        "reference_file": None, "probes": None, "arm_m": None, "keep": [1, 2],
        "reference_harmonics": 2}
    assert Settings(signals=True, corrected=True, min_arc_deg=45.0).to_meta(False) == {
        "heads": None, "average": False, "harmonics": None, "points": 256, "trend": 1,
        "mode": "signals", "min_arc_deg": 45.0, "allow_excluded_pct": 20.0, "rails_v": None}
    assert Settings(signals=True, rails_v=[-1, 1.5]).to_meta(False)["rails_v"] == [-1.0, 1.5]


def small_sweep(runs: int = 2, readings: int = 3) -> pa.Table:
    """A readings table of two runs over 26" at 0.5" (P1, H1, probes S1/S2), built in-process."""
    rng = np.random.default_rng(12)
    steps = np.arange(0.0, 26.5, 0.5) * ARCSEC
    target = np.tile(np.repeat(60 * DEG + steps, readings), runs)
    run_no = np.repeat(np.arange(runs, dtype=np.int32), steps.size * readings)
    theta = target + rng.normal(0, 0.005, target.size) * ARCSEC
    fields = [make_field("t", pa.float64(), "s")]
    arrays = [pa.array(np.arange(theta.size) * 0.1)]
    for name, ppr, a1, a2 in (("P1", 180000, 0.3, 0.05), ("H1", 52000, 0.12, 0.06)):
        cpr = ppr * 4096
        phase = np.mod(theta * ppr, TWO_PI)
        err = a1 * np.cos(phase + 0.4) + a2 * np.sin(2 * phase) + rng.normal(0, 0.01, theta.size)
        counts = np.rint((theta + err * ARCSEC) * (cpr / TWO_PI)).astype(np.int64)
        fields.append(make_field(name, pa.int64(), "count", "head", encoder=name[0],
                                 alpha_deg=0.0, counts_per_rev=cpr, periods_per_rev=ppr,
                                 interpolation=4096, radius_m=0.1, zero_count=0))
        arrays.append(pa.array(counts))
    for name, side in (("S1", 1), ("S2", -1)):
        rotation = theta - 60 * DEG
        h = side * 0.2 * rotation + 0.003 * rotation + rng.normal(0, 1e-9, theta.size)
        fields.append(make_field(name, pa.float64(), "m", "probe", arm_m=0.2, side=side))
        arrays.append(pa.array(h))
    fields += [make_field("target", pa.float64(), "rad"), make_field("run", pa.int32(), "")]
    arrays += [pa.array(target), pa.array(run_no)]
    return pa.Table.from_arrays(arrays, schema=pa.schema(fields))


#: the error curves [arcsec] at 8 phases and the residual rms [arcsec] that check_readings
#: gave on small_sweep() before interp.py became a package (the refactoring kept them).
#: "windows" holds a window of two samples 2e-13 apart in the trend's coordinate: its
#: trend counts as a constant, which the closed-form projection removes exactly; the
#: eigenvector projection it replaced tilted by that 2e-13 (the curve moved by 1e-10").
RECORDED = {
    ("probes", "P1"): ([0.27020119968864276, 0.20751201948859999, -0.16493150204576815,
                        -0.34748903446869445, -0.2283233822352525, -0.0477134037821797,
                        0.09832670285683169, 0.21241740049782032], 0.010814666657157012),
    ("probes", "H1"): ([0.10795079145878446, 0.10952358510234785, -0.04678644987995346,
                        -0.17425185902570614, -0.10226034199408437, 0.01331240561970819,
                        0.04690240812150762, 0.04560946059739581], 0.01001407102780895),
    ("p1_by_h1", "P1"): ([0.2984819132166921, 0.18546751444930332, -0.14543708228052937,
                          -0.35115581923228845, -0.24192639640633792, -0.03097056111171545,
                          0.0888815654701752, 0.19665886589470058], 0.023743970672893227),
    ("h1_by_p1_file", "H1"): ([0.10892143652201546, 0.10651319575215171, -0.04663166941633392,
                               -0.17017338767992363, -0.10568720449687688, 0.018422162314235394,
                               0.043397437391195344, 0.04523802961353651], 0.023739559042603057),
    ("windows", "H1"): ([0.10907026381058672, 0.10751916026842359, -0.04657254897162415,
                         -0.17079840963215281, -0.10541553853431337, 0.019134044325836472,
                         0.0429178236953508, 0.04414520503789275], 0.010338231319829147),
}


@pytest.mark.parametrize("case, options, by_file", [
    ("probes", {}, False),
    ("p1_by_h1", {"heads": ["P1"], "reference": "H1"}, False),
    ("h1_by_p1_file", {"heads": ["H1"], "reference": "P1"}, True),
    ("windows", {"heads": ["H1"], "window_arcsec": 100.0, "harmonics": 2}, False),
])
def test_check_readings_gives_the_recorded_curves(case, options, by_file):
    table = small_sweep()
    curves = check_readings(table, Settings(points=8, **options), table if by_file else None)
    assert [c.name for c in curves] == [name for (k, name) in RECORDED if k == case]
    for c in curves:
        error, rms = RECORDED[case, c.name]
        assert c.error.tolist() == pytest.approx(error, rel=1e-12, abs=1e-12)
        assert c.meta["residual_rms_arcsec"] == pytest.approx(rms, rel=1e-12)
