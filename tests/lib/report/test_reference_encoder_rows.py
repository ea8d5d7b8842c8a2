"""A reference encoder's declared row is of the encoder it names (enc-rig(5) ``encoder``).

sjtu-dual declares encoder I's calibration (0.06", k = 2) and its accuracy as read (0.37")
with ``encoder = "I"``. A comparison against encoder II's heads (P against H, with or
without H's curve from the self-calibration) took encoder I's rows before: the 0.06" of
encoder I's certificate stood for the self-calibration's curve of encoder II. It now
gets no U and one note naming the encoder the row is declared for; H - P keeps its
budget, and a curve made before the comparison recorded its reference's encoder takes the
row as declared.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_certified_u import certified, enc, rig

from enctools.data.header import Header
from enctools.data.rig import load_rig
from enctools.data.streams import read_table, write_table
from enctools.errors import DataError


@pytest.fixture(scope="module")
def curves(tmp_path_factory) -> Path:
    """A short sjtu-dual run compared both ways, and a step run read on encoder I."""
    d = tmp_path_factory.mktemp("refrows")
    path = rig(1, d)
    enc(f"acquire --rig {path} --revolutions 2 --interval 0.012 -q -o raw.arrow", d)
    enc("selfcal raw.arrow --method esa --ref-head H1 --heads H5,H6,H7 -q -o grad.parquet", d)
    enc("average-heads raw.arrow -q -o avg.arrow", d)
    enc("compare avg.arrow --device H --reference P -q -o h-p.parquet", d)
    enc("compare avg.arrow --device P --reference H -q -o p-h.parquet", d)
    enc("compare avg.arrow --device P --reference H --reference-curve grad.parquet --name P "
        "-q -o p.parquet", d)
    return d


def _refused(section: dict, quantity: str) -> None:
    said = [n for n in section["notes"] if n.startswith("no expanded uncertainty U")]
    assert len(said) == 1, section["notes"]
    assert f"[uncertainty.{quantity}] for encoder I only" in said[0]
    assert "heads are of encoder II" in said[0]
    assert "budget" not in section


def test_a_comparison_against_encoder_ii_takes_no_row_of_encoder_i(curves):
    for name, quantity in (("p-h.parquet", "reference_encoder_uncorrected"),
                           ("p.parquet", "reference_encoder")):
        settings = read_table(curves / name)[0].meta["settings"]
        assert settings["ref_encoder"] == "II", name
        _, _, u, s = certified(enc(f"report --json {name}", curves))
        assert np.all(np.isnan(u)), name
        _refused(s, quantity)


def test_the_comparison_against_encoder_i_keeps_its_budget(curves):
    _, _, u, s = certified(enc("report --json h-p.parquet", curves))
    rows = s["budget"]["contributions"]
    assert rows[1]["name"].startswith("accuracy of the reference encoder")
    assert np.all(u > 0.4) and np.all(u < 0.45)  # 1.96 x 0.37 / sqrt 3 = 0.419"


def test_a_curve_made_before_ref_encoder_was_recorded_takes_the_row(curves, tmp_path):
    """The same P - H curve without ``settings.ref_encoder``: its reference's encoder is
    not known, and the row is taken as declared (the behaviour of those files before)."""
    header, table = read_table(curves / "p-h.parquet")
    settings = {k: v for k, v in header.meta["settings"].items() if k != "ref_encoder"}
    old = tmp_path / "old.parquet"
    write_table(str(old), Header(header.kind, header.schema, header.meta | {"settings": settings}),
                table)
    _, _, u, s = certified(enc(f"report --json {old}", curves))
    assert np.all(u > 0.4) and s["budget"]["contributions"][1]["source"].startswith("seed 000")


def test_a_step_run_read_on_an_encoder_the_rows_are_not_of_gets_no_U(tmp_path):
    """The rows declared for encoder II, the step run read on encoder I (the reference
    instrument: the axis positions on encoder II): no U, one note."""
    path = rig(1, tmp_path)
    path.write_text(path.read_text().replace('encoder = "I"', 'encoder = "II"'))
    enc(f"acquire --rig {path} --mode steps --count 8 --runs 2 --bidirectional --readings 2 "
        "-q -o steps.arrow", tmp_path)
    _, _, u, s = certified(enc("report --json steps.arrow", tmp_path))
    assert np.all(np.isnan(u))
    said = [n for n in s["notes"] if n.startswith("no expanded uncertainty U")]
    assert len(said) == 1
    assert "encoder I is read" in said[0] and "for encoder II only" in said[0]


@pytest.mark.parametrize("line, says", [
    ('encoder = "III"', "uncertainty.reference_encoder.encoder 'III' is not an encoder of "
                        "the rig (I, II)"),
    ('encoder = ""', "uncertainty.reference_encoder.encoder must name one of the rig's "
                     "encoders, not ''"),
    ("encoder = 1", "uncertainty.reference_encoder.encoder must name one of the rig's "
                    "encoders, not 1"),
])
def test_a_declared_encoder_the_rig_has_not_is_one_line(tmp_path, line, says):
    text = rig(1, tmp_path).read_text().replace('encoder = "I"', line, 1)
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(DataError) as e:
        load_rig(str(bad))
    assert says in str(e.value) and "\n" not in str(e.value)


def test_encoder_is_for_the_reference_encoder_rows_only(tmp_path):
    text = rig(1, tmp_path).read_text().replace(
        "[uncertainty.probe]\n", '[uncertainty.probe]\nencoder = "I"\n', 1)
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(DataError, match=r"uncertainty.probe.encoder is for reference_encoder "
                                        r"and reference_encoder_uncorrected only"):
        load_rig(str(bad))


def test_the_rig_record_in_a_stream_keeps_the_encoder(curves):
    meta = read_table(curves / "h-p.parquet")[0].meta
    declared = meta["rig"]["uncertainty"]
    assert declared["reference_encoder"]["encoder"] == "I"
    assert json.loads(json.dumps(declared))["reference_encoder_uncorrected"]["encoder"] == "I"
