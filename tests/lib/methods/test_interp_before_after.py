"""interp-check's results unchanged by the speed-ups of its fit (issue 18, item 1).

The code of the fit before them (the 2026-11-26 code, the revision the bench
``benchmarks/interp_fit.py`` compares with) is taken from git and run on the same
inputs as this code, each through ``enc interp-check`` in a child process: on
runs of three noise seeds, every curve and its u agree to 1e-12 arcsec, as do the
figures in the metadata. The paths covered: a continuous run at the paper's 3 ms
(seven heads against P1, fitted as one bank, X^T X from the samples per step), a
continuous run at 5.05 ms (H1 and H2 against P1 with P1's own harmonics fitted
alongside), and a sweep against the probes (a trend per run, runs interleaved).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, run

from enctools.data.streams import read_table

#: every test with the compiled kernel and with the numpy passes (conftest.kernel_path)
pytestmark = pytest.mark.usefixtures("kernel_path")

#: the revision before the fit's speed-ups (benchmarks/interp_fit.py's default)
BEFORE = "ec875cc~1"
ENC = "import sys; sys.argv[0] = 'enc'; from enctools.cli.main import main; main()"

CASES = {
    "3ms": ("--interval 0.003 --revolutions 2", "--reference P1"),
    "5ms": ("--interval 0.00505 --revolutions 2 --heads H1,H2,P1", "--reference P1"),
    "sweep": ("--mode sweep", ""),
}


@pytest.fixture(scope="module")
def before_code(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The enctools of :data:`BEFORE`, unpacked (skips where git or the revision is missing)."""
    try:
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", BEFORE, "enctools",
                                  "schemas"], check=True, capture_output=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip(f"no git history with {BEFORE} here")
    out = tmp_path_factory.mktemp("before")
    subprocess.run(["tar", "-x", "-C", str(out)], input=archive, check=True)
    return out


def check_with(code: Path, run_file: Path, options: str, out: Path) -> None:
    """enc interp-check of ``run_file`` by the enctools in ``code`` (run outside this
    checkout: ``python -c`` puts the current folder ahead of PYTHONPATH)."""
    r = subprocess.run([sys.executable, "-c", ENC, "interp-check", str(run_file), "-q",
                        *options.split(), "-o", str(out)], cwd=out.parent, capture_output=True,
                       env=dict(os.environ, PYTHONPATH=str(code)))
    assert r.returncode == 0, r.stderr.decode()


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("case", sorted(CASES))
def test_outputs_equal_the_fit_before_its_speed_ups(before_code, tmp_path, case, seed):
    acquire, options = CASES[case]
    raw = tmp_path / "run.arrows"
    r = run(f"enc acquire --rig sjtu-dual {acquire} --seed {seed} -q -o {raw}")
    assert r.returncode == 0, r.stderr.decode()
    outs = {}
    for name, code in (("after", ROOT), ("before", before_code)):
        outs[name] = tmp_path / f"{name}.parquet"
        check_with(code, raw, options, outs[name])
    (h_after, after), (h_before, before) = (read_table(outs[n]) for n in ("after", "before"))
    # (the uncertainty columns were named u(H) then, u_H now)
    assert after.column_names == [n.replace("u(", "u_").rstrip(")") for n in before.column_names]
    assert after.num_rows > 0
    for name, was in zip(after.column_names, before.column_names, strict=True):
        a, b = after[name].to_numpy(), before[was].to_numpy()
        assert np.all(np.isfinite(a)) and np.max(np.abs(a - b)) < 1e-12, name
    curves_a, curves_b = h_after.meta["curves"], h_before.meta["curves"]
    assert sorted(curves_a) == sorted(curves_b) and len(curves_a) >= (7 if case == "3ms" else 1)
    for device, meta in curves_a.items():
        was = curves_b[device]
        assert (meta["samples"], meta.get("windows")) == (was["samples"], was.get("windows"))
        assert meta["residual_rms_arcsec"] == pytest.approx(was["residual_rms_arcsec"],
                                                            rel=1e-12)
        for fig, value in meta["figures"].items():
            assert value == pytest.approx(was["figures"][fig], rel=1e-9, abs=1e-12), fig
