"""Limits on what a rig file or an option can make a command allocate or loop over.

Each value is refused before any work: one error line naming the key or option, the
value and the limit, exit status 2; never an internal error, never silently taken.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import ROOT, one_error_line, run_in_process

CIOMP = ROOT / "enctools" / "rigs" / "ciomp-23bit.toml"
SJTU = ROOT / "enctools" / "rigs" / "sjtu-dual.toml"


def rig_with(tmp_path: Path, old: str, new: str, base: Path = CIOMP) -> Path:
    text = base.read_text()
    assert old in text, old
    p = tmp_path / "rig.toml"
    p.write_text(text.replace(old, new, 1))
    return p


def acquire_line(rig: Path | str, tmp_path: Path, *opts: str) -> str:
    out = tmp_path / "o.parquet"
    r = run_in_process(["enc", "acquire", "--rig", str(rig), *opts, "-o", str(out)])
    line = one_error_line(r, 2)
    assert "internal error" not in line, line
    assert not out.exists()
    return line


@pytest.mark.parametrize("old, new, named", [
    ("count = 24", "count = 1000000000000", "acquire.steps.count must be 1..100000"),
    ("faces = 24", "faces = 1000000000", "polygon.faces must be 3..720"),
    ("max_harmonic = 48", "max_harmonic = 1000000000",
     "encoder[0].graduation.max_harmonic must be 2..2048"),
    ("max_harmonic = 48", "max_harmonic = 1", "graduation.max_harmonic must be 2..2048, not 1"),
    ("asynchronous_rms_nm = 10.0", "asynchronous_terms = 1000000000",
     "encoder[0].radial.asynchronous_terms must be 0..64"),
    ("diameter_mm = 200.0", "diameter_mm = inf", "encoder[0].diameter_mm must be 0.001..10000, "
     "not inf"),
    ("diameter_mm = 200.0", "diameter_mm = nan", "encoder[0].diameter_mm must be"),
    ("noise_arcsec = 0.05", "noise_arcsec = 1e308", "encoder[0].head[0].noise_arcsec must be "
     "0..3600, not 1e+308"),
    ("periods_per_rev = 4096 ", "periods_per_rev = 1000000000000000000 ",
     "encoder[0].periods_per_rev must be 1..134217728"),
    ("interpolation = 2048", "interpolation = 0", "encoder[0].interpolation must be"),
    ("seed = 1\n", "seed = -1\n", "backend.seed must be 0..9223372036854775807, not -1"),
    ("seed = 1\n", "seed = \"x\"\n", "backend.seed must be integer"),
    ("jitter_hz = [0.2]", "jitter_hz = [\"fast\"]", "motion.jitter_hz[0] must be a number"),
    ("jitter_hz = [0.2]", "jitter_hz = []", "jitter_arcsec and motion.jitter_hz"),
    ("measure_heads = [\"F1\", \"F2\"]", "measure_heads = [1]",
     "encoder[0].measure_heads[0] must be a string"),
    ("mode = \"steps\"", "mode = \"spin\"", "acquire.mode must be one of"),
    ("readings = 5", "readings = 100000000", "acquire.steps.readings must be 1..10000"),
    ("step_arcsec = 20.0", "step_arcsec = 1e-300", "acquire.sweep.step_arcsec must be"),
    ("readings = 5\n\n[acquire.sweep]", "readings = 0\n\n[acquire.sweep]",
     "acquire.closure.readings must be 1..10000, not 0"),
    ("name = \"ciomp-23bit\"", "name = 1979-05-27", "name must be string"),
    ("description = \"23-bit", "description = [1] #", "description must be string"),
    ("format = 1", "format = 0", "format must be 1..1000, not 0"),
])
def test_rig_values_out_of_range_are_one_line(old: str, new: str, named: str,
                                              tmp_path: Path) -> None:
    line = acquire_line(rig_with(tmp_path, old, new), tmp_path, "--mode", "steps")
    assert named in line and "rig.toml" in line, line


def test_probe_side_and_counts_of_tables(tmp_path: Path) -> None:
    line = acquire_line(rig_with(tmp_path, "side = 1", "side = 0", SJTU), tmp_path)
    assert "probe[0].side must be 1 or -1, not 0" in line, line
    heads = "".join(f'[[encoder.head]]\nname = "X{i}"\nangle_deg = 0\n' for i in range(70))
    big = rig_with(tmp_path, "[polygon]", heads + "[polygon]")
    assert "encoder[0].head must have 1..64 items, not 72" in acquire_line(big, tmp_path), big


def test_rig_must_be_a_small_regular_file(tmp_path: Path) -> None:
    assert "rig file /dev/zero: not a regular file" in acquire_line("/dev/zero", tmp_path)
    big = tmp_path / "big.toml"
    big.write_text(CIOMP.read_text() + "#" * (1 << 20))
    line = acquire_line(big, tmp_path)
    assert "more than a rig file may have (1048576)" in line, line


@pytest.mark.parametrize("levels", [20, 100_000])
def test_deeply_nested_rig_is_one_line(levels: int, tmp_path: Path) -> None:
    deep = tmp_path / "deep.toml"
    deep.write_text("a = " + "[" * levels + "]" * levels + "\n")
    line = acquire_line(deep, tmp_path)
    assert "nested deeper than 8 levels" in line, line


def test_shipped_rigs_are_within_the_limits() -> None:
    from enctools.data.rig import load_rig

    for path in [*sorted((ROOT / "enctools" / "rigs").glob("*.toml")),
                 *sorted((ROOT / "tests" / "rigs").glob("*.toml"))]:
        load_rig(str(path))


def test_every_range_is_in_the_man_page() -> None:
    from enctools.data.riglimits import RANGES, fmt

    man = (ROOT / "man" / "enc-rig.5").read_text().replace("\\-", "-").replace("\\&", "")
    for key, (lo, hi) in RANGES.items():
        assert key.rsplit(".", 1)[-1] in man, key
        span = f"{fmt(lo)}..{fmt(hi)}"
        assert span in man, f"{key}: {span} not in enc-rig(5)"


@pytest.mark.parametrize("opts, named", [
    ("--mode steps --count 1000000000", "--count must be 1..100000, not 1000000000"),
    ("--mode continuous --speed 1e308", "--speed must be non-zero and -6000..6000 r/min"),
    ("--mode continuous --speed 0", "--speed must be non-zero"),
    ("--mode steps --positions ,", "--positions"),
    ("--mode steps --positions 1e300", "--positions must be -360..360, not 1e+300"),
    ("--mode continuous --revolutions 1e308", "--revolutions must be 1e-06..100000"),
    ("--mode continuous --revolutions 1e-6 --speed 6000 --interval 1",
     "0 samples requested (--revolutions/--speed/--interval); must be 1..2000000000"),
    ("--mode continuous --interval 1e-300", "--interval must be 1e-07..3600"),
    ("--mode sweep --step 1e-300", "--step must be 1e-06..1296000"),
    ("--mode sweep --settle inf", "--settle must be 0..3600, not inf"),
    ("--mode steps --readings 100000000", "--readings must be 1..10000"),
    ("--mode steps --runs 1000 --count 100000 --bidirectional",
     "200000000 positions requested (positions x --runs x directions); must be at most 1000000"),
    ("--mode steps --overshoot 1e308", "--overshoot must be 0..360"),
    ("--mode steps --start 1e308", "--start must be -360..360"),
    ("--timeout 1e308", "--timeout"),
    ("--retries 1000000000", "--retries"),
])
def test_acquire_counts_and_sizes_are_bounded(opts: str, named: str, tmp_path: Path) -> None:
    line = acquire_line("ciomp-23bit", tmp_path, *opts.split())
    assert named in line, line


def test_backend_numbers_are_bounded(tmp_path: Path) -> None:
    from test_rig_safety import variant

    rig = variant(tmp_path / "rig", None, **{"timeout_s = 0.2": "timeout_s = 1e308"})
    line = acquire_line(rig, tmp_path)
    assert "backend.timeout_s must be 0.001..3600, not 1e+308" in line, line


@pytest.fixture(scope="module")
def sweep(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short sweep of sjtu-dual: 11 positions of 5 readings."""
    out = tmp_path_factory.mktemp("sweep") / "sweep.parquet"
    r = run_in_process(["enc", "acquire", "--rig", "sjtu-dual", "--mode", "sweep", "--range",
                        "5", "--step", "0.5", "-o", str(out)])
    assert r.returncode == 0, r.stderr.decode()
    return out


@pytest.fixture(scope="module")
def model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("model") / "model.parquet"
    r = run_in_process(["enc", "fit-rbf", str(ROOT / "tests" / "data" / "seed001_table1.csv"),
                        "-o", str(out)])
    assert r.returncode == 0, r.stderr.decode()
    return out


def command_line(args: list[str], cmd: str) -> str:
    r = run_in_process(["enc", *args])
    line = one_error_line(r, 2, f"enc {cmd}")
    assert "internal error" not in line, line
    return line


@pytest.mark.parametrize("opts, named", [
    (["--band", "20000"], "--band must be 1..64 (at most 64, and half of --points 256), "
                          "not 20000"),
    (["--band", "8", "--points", "8"], "--band must be 1..4"),
    (["--keep", "1000000000"], "--keep: harmonic orders must be 1..64"),
    (["--window", "1e-300"], "--window must be 1..1296000 arcsec"),
    (["--arm", "1e308"], "--arm must be 1e-06..10 m"),
])
def test_interp_check_orders_and_spans_are_bounded(opts: list[str], named: str, sweep: Path,
                                                   tmp_path: Path) -> None:
    line = command_line(["interp-check", str(sweep), "--heads", "H1", *opts,
                         "-o", str(tmp_path / "d.parquet")], "interp-check")
    assert named in line, line


@pytest.mark.parametrize("opts, named", [
    (["--spread", "1e-300"], "--spread must be 0.001..360 deg, not 1e-300"),
    (["--spread", "1e308"], "--spread must be 0.001..360 deg"),
    (["--goal", "inf"], "--goal must be 0..3600 arcsec, not inf"),
    (["--kernel", "fourier", "--band", "1048576"], "--band must be 0..1024, not 1048576"),
    (["--kernel", "fourier", "--band", "30"],
     "--band 30: more harmonics than the 24 distinct positions can determine (at most 24)"),
])
def test_fit_rbf_spreads_and_orders_are_bounded(opts: list[str], named: str,
                                                tmp_path: Path) -> None:
    out = tmp_path / "m.parquet"
    line = command_line(["fit-rbf", str(ROOT / "tests" / "data" / "seed001_table1.csv"), *opts,
                         "-o", str(out)], "fit-rbf")
    assert named in line, line
    assert not out.exists()


@pytest.mark.parametrize("opts, named", [
    (["--curve", "X", "-o", "{d}/r.bin"], "--curve X chooses a curve of a deviations stream"),
    (["--lsb", "1e-300", "-o", "{d}/r.bin"], "--lsb must be a positive number of counts, "
                                             "1e-06..1099511627776"),
    (["--zone", "100000000000", "--target", "acs", "-o", "{d}/r.prg"],
     "--zone must be 0..2147483647"),
    (["--max-entries", "1000000000000", "--target", "acs", "-o", "{d}/r.prg"],
     "--max-entries must be 1..268435456"),
    (["--axis", "3", "-o", "{d}/r.bin"], "--axis applies to the controllers' targets"),
])
def test_make_rom_refuses_contradictions_and_absurd_sizes(opts: list[str], named: str,
                                                           model: Path, tmp_path: Path) -> None:
    args = [o.format(d=tmp_path) for o in opts]
    line = command_line(["make-rom", str(model), "--bits", "23", *args], "make-rom")
    assert named in line, line
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("args, named", [
    (["latency", "--bits", "23", "--delay", "inf"], "must be > 0 and <= 1 s, not inf"),
    (["latency", "--bits", "23", "--delay", "1e-3", "--speeds", "1e308"],
     "at most 1000 speeds, each -1000000..1000000 r/min"),
    (["latency", "--bits", "23", "--delay", "1e-3", "--speeds", ","], "expected numbers"),
    (["design", "--search", "4", "--band", "1048576"],
     "--band must be at most 4096 with --search"),
    (["design", "--angles", "0,60,135,228", "--mounting-error", "1e308"], "must be 0..10 deg"),
    (["design", "--search", "4", "--search-step", "1e-300"], "must be 0.01..60 deg"),
    (["design", "--search", "4", "--min-gap", "inf"], "must be 0..180 deg"),
    (["design", "--angles", ","], "expected numbers"),
    (["points", "--faces", "1000000000"], "--faces must be at most 720"),
    (["report", "--top", "1000000000"], "--top"),
])
def test_other_counts_and_spans_are_bounded(args: list[str], named: str,
                                            tmp_path: Path) -> None:
    line = command_line(args, args[0])
    assert named in line, line


@pytest.mark.parametrize("args", [
    ["report", "{m}", "--html", "{d}/x", "--pdf", "{d}/x"],
    ["report", "{m}", "--html", "{d}/x", "--pdf", "{d}/./x"],
    ["selfcal", "{s}", "-o", "{d}/x.parquet", "--spectrum", "{d}/x.parquet"],
    ["compare", "{s}", "--device", "H1", "--reference", "H3", "-o", "{d}/x.parquet",
     "--spectrum", "{d}/x.parquet"],
    ["interp-check", "{s}", "-o", "{d}/x.parquet", "--spectrum", "{d}/x.parquet"],
    ["interp-check", "{s}", "--signals", "-o", "{d}/x.parquet", "--corrected", "{d}/x.parquet"],
    ["acquire", "--rig", "sjtu-dual", "-o", "{d}/x.parquet", "--tee", "{d}/x.parquet"],
])
def test_two_outputs_never_share_a_path(args: list[str], sweep: Path, model: Path,
                                        tmp_path: Path) -> None:
    argv = [a.format(d=tmp_path, s=sweep, m=model) for a in args]
    r = run_in_process(["enc", *argv])
    line = one_error_line(r, 2, f"enc {args[0]}")
    assert "name the same file" in line, line
    assert not list(tmp_path.iterdir())


def test_feedback_names_an_encoder_and_seeds_are_bounded(tmp_path: Path) -> None:
    rig = rig_with(tmp_path, 'feedback = "II"', 'feedback = "III"', SJTU)
    assert "motion.feedback names no encoder: 'III'" in acquire_line(rig, tmp_path)
    line = acquire_line("sjtu-dual", tmp_path, "--seed", str(1 << 70))
    assert "--seed" in line, line


def test_min_arc_nan_is_refused() -> None:
    """The library names the field; the command line shows it as its option."""
    import re

    from enctools.cli import interp_check
    from enctools.cli.usage import message
    from enctools.errors import SettingsError
    from enctools.methods.interp import Settings

    with pytest.raises(SettingsError) as err:
        Settings(signals=True, min_arc_deg=float("nan"))
    assert re.search(r"--min-arc must be 10\.\.360 deg, not nan",
                     message(err.value, interp_check.command, "interp-check"))
