"""Every step run enc acquire writes, through enc points, into every table enc make-rom
offers: from the points (controls and controllers: the means per target and direction)
and from the model fit-rbf makes of them (every target). Each combination gives a table
that reads back with the run's targets and means, or a documented one-line refusal
(exit 2, no file): a memory table from points (it needs a model), a bidirectional table
of a unidirectional run or of a model."""

from __future__ import annotations

import json
from collections import defaultdict

import numpy as np
import pyarrow.parquet as pq
import pytest
from conftest import one_error_line, run, run_in_process

from enctools.cli.make_rom import targets
from enctools.models import romformats as rf

RAD_ARCSEC = 206264.80624709636
#: the acquisitions (ciomp-23bit, polygon of 24 faces): options, targets, bidirectional
RUNS = {
    "single": ("--mode steps --count 8", 8, False),
    "runs": ("--mode steps --count 8 --runs 3", 8, False),
    "bidirectional": ("--mode steps --count 8 --bidirectional", 8, True),
    "runs-bidirectional": ("--mode steps --count 8 --runs 3 --bidirectional", 8, True),
    "closure": ("--mode closure", 24, False),
}
#: the options each target needs beyond the source (small memories: a 12-bit code)
OPTIONS = {"bin": "--bits 12", "ihex": "--bits 12", "mif": "--bits 12", "coe": "--bits 12",
           "mem": "--bits 12", "csv": "--bits 12", "stream": "--bits 12 --format parquet",
           "acs": "--address-bits 6 --resolution 0.0001 --sign correction",
           "siemens": "--address-bits 6 --resolution 0.0001", "linuxcnc": "", "twincat": "",
           "fanuc": "--sign error", "fanuc-param": "--sign error",
           "heidenhain": "--sign error --tnc 620",
           "twincat-nc": "--sign error"}
TARGETS = targets()
CONTROLS = rf.CONTROLS
MEMORIES = tuple(t for t in TARGETS if t not in CONTROLS + rf.CONTROLLER)
#: the matrix is of the tables' plumbing and means: a model through 8 targets cannot show
#: that it beats no correction, and Fanuc's 0.001 deg is coarse beside a 2" correction;
#: the guards of enc-make-rom(1) are waived here and tested in test_gain.py
GUARDS = "--allow-no-gain --allow-coarse"
SIGN = {"acs": "correction", "fanuc": "error", "fanuc-param": "error", "heidenhain": "error",
        "twincat-nc": "error"}


@pytest.fixture(scope="module")
def streams(tmp_path_factory):
    """Each run as readings, points and a model (made once for the module)."""
    d = tmp_path_factory.mktemp("matrix")
    for name, (opts, _, _) in RUNS.items():
        r = run(f"enc acquire --rig ciomp-23bit {opts} --readings 2 -q -o {d}/{name}-r.parquet"
                f" && enc points {d}/{name}-r.parquet -q -o {d}/{name}-p.parquet"
                f" && enc fit-rbf {d}/{name}-p.parquet -q -o {d}/{name}-m.parquet")
        assert r.returncode == 0, r.stderr.decode()
    return d


def target_means(points_path, m: int) -> dict[int, np.ndarray]:
    """Per direction the mean over runs of each run's mean deviation at each of the m
    equally spaced targets [arcsec], computed here with loops (a visit read just below
    360 deg is the 0 deg target)."""
    t = pq.read_table(points_path)
    deg = np.degrees(t.column("position").to_numpy())
    k = np.rint(np.mod(deg, 360.0) / (360.0 / m)).astype(int) % m
    dev, d, r = (t.column(c).to_numpy() for c in ("deviation", "direction", "run"))
    out = {}
    for sign in (1, -1):
        if not np.any(d == sign):
            continue
        means = np.empty(m)
        for j in range(m):
            runs = defaultdict(list)
            for x, rr in zip(dev[(k == j) & (d == sign)], r[(k == j) & (d == sign)],
                             strict=True):
                runs[rr].append(x)
            means[j] = np.mean([np.mean(v) for v in runs.values()])
        out[sign] = means
    return out


@pytest.mark.parametrize("name", list(RUNS))
def test_every_command_counts_the_targets(streams, name):
    _, m, _ = RUNS[name]
    meta = json.loads(pq.read_schema(streams / f"{name}-p.parquet").metadata[b"enctools"])
    visits = pq.read_metadata(streams / f"{name}-p.parquet").num_rows
    assert meta["targets"]["targets"] == m and meta["targets"]["visits"] == visits
    model = json.loads(pq.read_schema(streams / f"{name}-m.parquet").metadata[b"enctools"])
    assert model["model"]["targets"]["targets"] == m and model["model"]["domain"]["full_turn"]
    report = json.loads(run_in_process(f"enc report {streams}/{name}-p.parquet --json").stdout)
    assert report["sections"][0]["info"]["positions"] == m


@pytest.mark.parametrize("target", TARGETS)
@pytest.mark.parametrize("name", list(RUNS))
def test_model_into_every_target(streams, tmp_path, name, target):
    out = tmp_path / f"table.{target}"
    r = run_in_process(f"enc make-rom {streams}/{name}-m.parquet --target {target} "
                       f"{OPTIONS[target]} {GUARDS} --verify --json -o {out}")
    assert r.returncode == 0, r.stderr.decode()
    doc = json.loads(r.stdout)
    assert doc["measured_range"] == "the full turn"
    if target in CONTROLS:
        assert doc["points"] >= 9 and doc["direction"] == "unidirectional"
    else:
        assert doc["table"]["entries"] == (64 if target in rf.CONTROLLER else 4096)


@pytest.mark.parametrize("target", TARGETS)
@pytest.mark.parametrize("name", list(RUNS))
def test_points_into_every_target(streams, tmp_path, name, target):
    """Controls: one point per target (and the closing 360 deg) holding minus the mean of
    both directions, read back as the control reads it; controllers: their 64-point
    table; memories: refused, one line (a memory table is a model's)."""
    _, m, _ = RUNS[name]
    out = tmp_path / f"table.{target}"
    points = streams / f"{name}-p.parquet"
    r = run_in_process(f"enc make-rom {points} --target {target} {OPTIONS[target]} "
                       f"{GUARDS} --verify --json -o {out}")
    if target in MEMORIES:
        assert "is a points stream" in one_error_line(r, 2, "enc make-rom")
        assert not out.exists()
        return
    assert r.returncode == 0, r.stderr.decode()
    doc = json.loads(r.stdout)
    assert doc["measured_range"] == "the full turn"
    if target in rf.CONTROLLER:
        assert doc["table"]["entries"] == 64
        return
    assert doc["points"] == m + 1 and doc["spacing_deg"] == pytest.approx(360.0 / m)
    means = target_means(points, m)
    want = -np.mean(list(means.values()), axis=0)
    table = rf.read_control_table(str(out), target, SIGN.get(target))
    got = table.correction(np.radians(np.arange(m) * 360.0 / m)) * RAD_ARCSEC
    if target.startswith("fanuc"):  # the compensation is 0 at the reference position
        want = want - want[0]
    resolution = doc["resolution_arcsec"]
    assert np.max(np.abs(got - want)) <= resolution / 2 + 1e-6


@pytest.mark.parametrize("target", ["linuxcnc", "twincat"])
@pytest.mark.parametrize("name", list(RUNS))
def test_bidirectional_tables(streams, tmp_path, name, target):
    """A table per direction from a bidirectional run (each direction's means); refused,
    one line, from a unidirectional run and from a model."""
    _, m, both = RUNS[name]
    out = tmp_path / f"table.{target}"
    points = streams / f"{name}-p.parquet"
    r = run_in_process(f"enc make-rom {points} --target {target} --bidirectional --verify "
                       f"{GUARDS} --json -o {out}")
    if not both:
        assert "both directions" in one_error_line(r, 2, "enc make-rom")
        assert not out.exists()
        return
    assert r.returncode == 0, r.stderr.decode()
    table = rf.read_control_table(str(out), target)
    means = target_means(points, m)
    angles = np.radians(np.arange(m) * 360.0 / m)
    resolution = json.loads(r.stdout)["resolution_arcsec"]
    for sign in (1, -1):
        got = table.correction(angles, sign) * RAD_ARCSEC
        assert np.max(np.abs(got + means[sign])) <= resolution / 2 + 1e-6, sign
    r = run_in_process(f"enc make-rom {streams}/{name}-m.parquet --target {target} "
                       f"--bidirectional -o {tmp_path}/model.{target}")
    assert "both directions" in one_error_line(r, 2, "enc make-rom")


@pytest.mark.parametrize("name", ["single", "closure"])
def test_readings_are_refused(streams, tmp_path, name):
    r = run_in_process(f"enc make-rom {streams}/{name}-r.parquet --target linuxcnc "
                       f"-o {tmp_path}/t.comp")
    assert "readings" in one_error_line(r, 2, "enc make-rom")
