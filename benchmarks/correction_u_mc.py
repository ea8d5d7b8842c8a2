"""The U of the correction at any angle checked against the simulator's truth.

Each trial is seed 001's calibration (ciomp-23bit: 24 polygon faces every 15 deg, 5
readings each) on a graduation drawn anew (the rig's graduation seed 301 + trial, the
noise seed the trial): ``enc points``, ``enc fit-rbf``, then a dense turn of the same
rig (one reading every 0.01 s at 1 r/min: 6000 angles) whose error against the
simulator's motion, less the model, is the true residual after correction, taken about
its mean (the datum is the encoder's zero). Printed: per trial the share of angles
within U (the model's terms, k = 2), the same with the leave-one-out term alone, the
terms and the residual's RMS; then both pooled and the worst trial.

    .venv/bin/python benchmarks/correction_u_mc.py               # 30 trials
    .venv/bin/python benchmarks/correction_u_mc.py --trials 10

tests/lib/models/test_correction_u.py checks the same on synthetic graduations.
Units: arcsec.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from enctools.data import streams  # noqa: E402
from enctools.data.readings import head_angle, head_info  # noqa: E402
from enctools.data.truth import Motion  # noqa: E402
from enctools.models.correction_u import CorrectionU  # noqa: E402
from enctools.models.curve_model import from_stream  # noqa: E402
from enctools.units import ARCSEC, DEG  # noqa: E402

ENC = str(Path(sys.executable).parent / "enc")


def trial(seed: int, tmp: Path) -> tuple[np.ndarray, CorrectionU]:
    """The true residual after correction at a dense turn's angles [arcsec] (about its
    mean) and the model's stated terms, for one graduation and noise seed."""
    rig = (ROOT / "enctools/rigs/ciomp-23bit.toml").read_text()
    (tmp / "rig.toml").write_text(re.sub(r"seed = 301", f"seed = {301 + seed}", rig))
    for cmd in (f"acquire --rig rig.toml --mode steps --seed {seed} -q -o steps.parquet",
                "points steps.parquet -q -o points.parquet",
                "fit-rbf points.parquet -q -o m.parquet",
                "acquire --rig rig.toml --mode continuous --revolutions 1 --speed 1 "
                f"--interval 0.01 --seed {seed} -q -o dense.parquet"):
        subprocess.run([ENC, *cmd.split()], cwd=tmp, check=True, capture_output=True)
    header, table = streams.read_table(str(tmp / "dense.parquet"), "readings")
    mh, mt = streams.read_table(str(tmp / "m.parquet"), "model")
    lat = header.meta["rig"]["encoders"][0]["latency_s"]
    theta = Motion.from_dict(header.meta["truth"]["motion"])(table["t"].to_numpy() - lat)
    reading = np.mean([head_angle(table[h], head_info(header.schema, h))
                       for h in ("F1", "F2")], axis=0)
    after = (reading - theta) / ARCSEC - from_stream(mh, mt)(np.mod(reading / DEG, 360.0))
    cu = CorrectionU.from_meta(mh.meta["residuals"].get("correction_u"))
    assert cu is not None
    return after - after.mean(), cu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=30)
    args = ap.parse_args()
    share, alone = [], []
    for seed in range(args.trials):
        with tempfile.TemporaryDirectory() as d:
            r, cu = trial(seed, Path(d))
        share.append(float(np.mean(np.abs(r) <= cu.U)))
        alone.append(float(np.mean(np.abs(r) <= cu.k * cu.held_out)))
        print(f"{seed:3d}  within U {share[-1]:.4f}  leave-one-out alone {alone[-1]:.4f}  "
              f"U {cu.U:.3f}  held-out {cu.held_out:.3f}  band {cu.band:.3f}  "
              f"true RMS {r.std():.3f}", flush=True)
    print(f"pooled: within U {np.mean(share):.4f} (worst {min(share):.4f}); "
          f"leave-one-out alone {np.mean(alone):.4f} (worst {min(alone):.4f})")


if __name__ == "__main__":
    main()
