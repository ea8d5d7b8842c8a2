"""A self-calibration method is one strategy object in the library's registry.

The fixture below is a whole new method written in this test alone: ``opposed``, two
heads 180 deg apart, whose difference H2 - H1 has W(n) = exp(i n pi) - 1 (-2 at odd
orders, 0 at even ones: the even harmonics are blind). Registered, it is offered by
``enc selfcal --method`` and ``enc design --method`` (their help lists it), solves a
simulated run scored against the simulator's truth, and is analysed by enc design;
unregistered, both commands refuse it. Nothing in enctools names it.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import run_in_process
from test_selfcal import K, quiet_rig, rms, spectrum, truth_of

from enctools.errors import SettingsError
from enctools.methods import selfcal_methods
from enctools.methods.selfcal_methods.base import Bound, SelfcalMethod, Solution
from enctools.units import DEG


def _apart(alpha_ref: float, alpha: float) -> float:
    """The angle [deg] from the reference to the other head, in [0, 360)."""
    return float(np.mod(alpha - alpha_ref, 2 * np.pi) / DEG)


@dataclass(frozen=True)
class Opposed(SelfcalMethod):
    """Two opposed heads: F(n) = (G_2(n) - G_1(n)) / (exp(i n pi) - 1) at odd n."""

    def prepare(self, alpha_ref: float, alphas: np.ndarray, names: list[str]) -> Any:
        if abs(_apart(alpha_ref, alphas[0]) - 180.0) > 0.05:
            msg = f"opposed: heads {', '.join(names)} are not 180 deg apart"
            raise SettingsError(msg)
        return None

    def check_angles(self, alphas: np.ndarray, angles_deg: list[float]) -> None:
        super().check_angles(alphas, angles_deg)
        self.prepare(alphas[0], alphas[1:], [f"{a:g}" for a in angles_deg])

    def transfer(self, alpha_ref: float, alphas: np.ndarray,
                 n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = np.abs(np.exp(1j * n * np.pi) - 1.0)  # |W(n)|: 2 at odd n, 0 at even
        return w / np.sqrt(2), w / np.sqrt(2)     # the noise of a difference: sqrt(2)

    def solve(self, bound: Bound, spectra: np.ndarray,
              table: dict[str, np.ndarray]) -> Solution:
        n = np.arange(spectra.shape[1])
        w = np.exp(1j * n * np.pi) - 1.0
        odd = n % 2 == 1
        f = np.zeros(n.size, dtype=np.complex128)
        f[odd] = (spectra[1, odd] - spectra[0, odd]) / w[odd]
        return Solution(f)


OPPOSED = Opposed("opposed", "two heads 180 deg apart: their difference (odd orders)",
                  listed={"selfcal": 9, "design": 9}, heads=2)


@pytest.fixture
def opposed() -> Iterator[SelfcalMethod]:
    selfcal_methods.register(OPPOSED)
    try:
        yield OPPOSED
    finally:
        selfcal_methods.unregister("opposed")


@pytest.fixture(scope="module")
def quiet_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """2 revolutions of sjtu-dual without noise or radial motion, band-limited to K."""
    d = tmp_path_factory.mktemp("opposed")
    rig = quiet_rig(d, radial=False, max_harmonic=K)
    r = run_in_process(f"enc acquire --rig {rig} --revolutions 2 --interval 0.012 -q "
                       f"-o {d}/raw.arrows")
    assert r.returncode == 0, r.stderr.decode()
    return d / "raw.arrows"


def test_the_methods_of_enctools_are_records_of_the_registry() -> None:
    assert selfcal_methods.names("selfcal") == ("fourier", "eda", "esa")
    assert selfcal_methods.names("design") == ("esa", "fourier", "average")
    assert selfcal_methods.default(4, "selfcal").name == "esa"
    assert selfcal_methods.default(3, "selfcal").name == "fourier"
    with pytest.raises(SettingsError, match="method must be one of fourier, eda, esa"):
        selfcal_methods.get("average", "selfcal")


def test_a_method_registered_from_a_test_is_offered_and_solves(opposed: SelfcalMethod,
                                                               quiet_run: Path,
                                                               tmp_path: Path) -> None:
    for cmd in ("selfcal", "design"):
        help_text = run_in_process(f"enc {cmd} --help").stdout.decode()
        assert "opposed" in help_text and "two heads 180 deg apart" in help_text
    out, spec = tmp_path / "g.parquet", tmp_path / "s.parquet"
    r = run_in_process(f"enc selfcal --method opposed --ref-head H1 --heads H3 {quiet_run} "
                       f"-o {out} --spectrum {spec}")
    assert r.returncode == 0, r.stderr.decode()
    assert "enc selfcal: method opposed" in r.stderr.decode()
    c, _ = spectrum(spec)
    want = truth_of(out).graduation["II"].harmonics(K)[1:]
    odd = np.arange(1, K + 1) % 2 == 1
    assert rms(c[odd] - want[odd]) <= 1e-3  # against the simulator's truth
    assert np.all(c[~odd] == 0)  # the even orders: blind, named, set to 0
    assert "blind harmonics (|W(n)| = 0): 2, 4, ..., 100" in r.stderr.decode()
    # an independent solution: the basic least squares over the same two heads
    ref = tmp_path / "f.parquet"
    r = run_in_process(f"enc selfcal --method fourier --ref-head H1 --heads H3 {quiet_run} "
                       f"-o {tmp_path}/fg.parquet --spectrum {ref}")
    assert r.returncode == 0, r.stderr.decode()
    assert np.max(np.abs(spectrum(ref)[0][odd] - c[odd])) <= 1e-9
    # its settings checked by the method itself, its fields named as options
    r = run_in_process(f"enc selfcal --method opposed --ref-head H1 --heads H2 {quiet_run} "
                       f"-o {tmp_path}/bad.parquet")
    assert r.returncode == 2 and "not 180 deg apart" in r.stderr.decode()
    r = run_in_process(f"enc selfcal --method opposed --ref-head H1 --heads H2,H3 {quiet_run} "
                       f"-o {tmp_path}/bad.parquet")
    assert r.returncode == 2
    assert "opposed needs the reference and exactly 1 more heads" in r.stderr.decode()
    assert "use --method fourier" in r.stderr.decode()


def test_a_method_registered_from_a_test_is_designed(opposed: SelfcalMethod) -> None:
    r = run_in_process("enc design --method opposed --angles 0,180 --band 10 --json")
    assert r.returncode == 0, r.stderr.decode()
    import json

    got = json.loads(r.stdout)
    assert got["method"] == "opposed" and got["blind"] == [2, 4, 6, 8, 10]
    assert got["min_transfer"] == pytest.approx(np.sqrt(2))
    r = run_in_process("enc design --method opposed --angles 0,90")
    assert r.returncode == 2 and "not 180 deg apart" in r.stderr.decode()


def test_a_method_unregistered_is_refused(quiet_run: Path, tmp_path: Path) -> None:
    selfcal_methods.register(OPPOSED)
    selfcal_methods.unregister("opposed")
    assert "opposed" not in selfcal_methods.names("selfcal")
    for cmd in ("selfcal", "design"):
        assert "opposed" not in run_in_process(f"enc {cmd} --help").stdout.decode()
    r = run_in_process(f"enc selfcal --method opposed --ref-head H1 --heads H3 {quiet_run} "
                       f"-o {tmp_path}/g.parquet")
    assert r.returncode == 2 and "'opposed' is not one of" in r.stderr.decode()
    r = run_in_process("enc design --method opposed --angles 0,180")
    assert r.returncode == 2 and "'opposed' is not one of" in r.stderr.decode()
