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
