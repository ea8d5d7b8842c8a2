"""enc design: |W(n)| of head arrangements, blind harmonics, search, mounting sensitivity.

Figures from ../shared/DESIGN.md and seed 000: for 0/60/135/228 deg, min |W| over
2..100 is about 1.18 at n = 42, and W(n) = 0 at n = 120 (all angles multiples of 3 deg).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run

from enctools.methods import design
from enctools.methods.selfcal import esa_transfer, esa_weights


def test_paper_arrangement() -> None:
    a = design.analyse([0, 60, 135, 228], 100)
    w, n = a.worst
    assert abs(w - 1.18) < 0.01 and n == 42
    assert a.blind == [] and a.ill == []
    a = design.analyse([0, 60, 135, 228], 130)
    assert 120 in a.blind and set(a.blind) == {119, 120, 121}


def test_cli_names_blind_and_strict() -> None:
    r = run("enc design --angles 0,60,135,228 --band 130")
    assert r.returncode == 0
    out = r.stdout.decode()
    assert "min |W(n)| over 2..130: 1.176 at n = 42" in out
    assert "blind harmonics: 119, 120, 121" in out
    r = run("enc design --angles 0,60,135,228 --band 130 --strict")
    assert r.returncode == 2
    lines = r.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("enc design: error:") and "120" in lines[0]


def test_table_output() -> None:
    r = run("enc design --angles 0,60,135,228 --band 50 --tsv")
    rows = [line.split("\t") for line in r.stdout.decode().splitlines()]
    assert rows[0][0] == "n" and len(rows) == 51
    assert abs(float(rows[42][1]) - 1.176) < 0.001


def test_average_transfer_of_four_equal_heads() -> None:
    a = design.analyse([0, 90, 180, 270], 12, method="average")
    np.testing.assert_allclose(a.transfer[1:], [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1], atol=1e-12)


@pytest.mark.slow
def test_search_beats_or_matches_the_paper() -> None:
    res = design.search(4, 100)
    a = design.analyse(list(res.angles_deg), 100)
    assert a.worst[0] >= 1.176 - 1e-3
    assert not a.blind
    gaps = np.diff([*res.angles_deg, 360.0])
    assert np.all(gaps >= 10 - 1e-9)


def test_mounting_sensitivity_first_order() -> None:
    """Relative error of F(n) from random head-angle errors: Monte Carlo vs first order."""
    angles = np.radians([0.0, 60.0, 135.0, 228.0])
    n = np.arange(2, 101)
    a = esa_weights(0.0, angles[1:])
    w = esa_transfer(0.0, angles[1:], n)
    rng = np.random.default_rng(5)
    sigma = np.radians(0.01)
    rel = []
    for _ in range(400):
        true = angles[1:] + rng.normal(0, sigma, 3)
        # the data follow the true angles, the method the nominal ones
        w_true = (a[None, :] * (np.exp(1j * np.outer(n, true)) - 1)).sum(axis=1)
        rel.append(np.abs(w_true / w - 1))
    mc = np.sqrt(np.mean(np.square(rel), axis=0))
    predicted = design.analyse([0, 60, 135, 228], 100).sensitivity[2:] * sigma
    assert np.all(np.abs(mc / predicted - 1) < 0.25)


@pytest.mark.parametrize("opts,expect", [("", "give --angles"),
                                         ("--angles 0,60,60,228", "same angle"),
                                         ("--angles 0,90,180 --method esa", "esa needs 4"),
                                         ("--search 3 --method esa", "esa arrangements have 4"),
                                         ("--angles 0,nan,90", "finite numbers"),
                                         ("--angles 0,60,135,228 --mounting-error -1", "0..10 deg"),
                                         ("--angles 0,60,135,228 --mounting-error nan", "0..10"),
                                         ("--search 4 --min-gap -5", "must be 0..180 deg")])
def test_bad_usage(opts: str, expect: str) -> None:
    r = run(f"enc design {opts}")
    assert r.returncode == 2
    lines = r.stderr.decode().strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("enc design: error:") and expect in lines[0]


# In-process: the settings object, no subprocess.

@pytest.mark.parametrize("given,expect", [
    ({}, "give --angles DEG,... to analyse, or --search M to search"),
    ({"angles_deg": (0.0,)}, "give at least 2 head angles"),
    ({"angles_deg": (0.0, 60.0, 60.0, 228.0)}, "--angles: two heads at the same angle"),
    ({"angles_deg": (0.0, 90.0, 180.0), "method": "esa"}, "esa needs 4 head angles, not 3"),
    ({"angles_deg": (0.0, 90.0), "method": "lsq"}, "--method must be esa, fourier or average"),
    ({"search_heads": 3, "method": "esa"}, "esa arrangements have 4 heads, not 3"),
    ({"search_heads": 9}, "--search: 2 to 8 heads, not 9"),
    ({"search_heads": 4, "min_gap_deg": 100.0}, "--min-gap 100.0 deg leaves no room for 4"),
    ({"search_heads": 4, "criterion": "max"}, "--criterion must be w or gain, not 'max'"),
])
def test_settings_refuse_bad_combinations(given: dict, expect: str) -> None:
    """The library names fields; the command line shows them as its options."""
    from enctools.cli import design as design_cli
    from enctools.cli.usage import message
    from enctools.errors import SettingsError

    with pytest.raises(SettingsError) as err:
        design.Settings(**given)
    assert expect in message(err.value, design_cli.command, "design")


def test_run_searches_then_analyses() -> None:
    from enctools.errors import SettingsError

    settings = design.Settings(search_heads=3, band=20, method="fourier", step_deg=3.0)
    assert settings.search_method == "fourier"
    res = design.run(settings)
    assert res.search is not None and res.analysis.angles_deg == res.search.angles_deg
    res = design.run(design.Settings(angles_deg=(0, 60, 135, 228), band=130, strict=True))
    assert res.search is None and res.analysis.blind == [119, 120, 121]
    assert res.analysis.blind_radial == [119, 120, 121]
    with pytest.raises(SettingsError, match=r"blind harmonics 119, 120, 121; radial motion x, y "
                                           r"blind at 119, 120, 121 \(strict\)"):
        design.refuse_or_warn(res.analysis, strict=True)
