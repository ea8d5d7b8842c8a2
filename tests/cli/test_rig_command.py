"""enc rig: list, show (a rig to start from) and check, as a user runs them."""

from __future__ import annotations

import pyarrow.parquet as pq
import pytest
from conftest import one_error_line, run

from enctools.data.rig import bundled_rigs


def test_list_names_every_bundled_rig_with_its_description():
    r = run("enc rig list")
    assert r.returncode == 0, r.stderr
    rows = [line.split("\t") for line in r.stdout.decode().splitlines()]
    assert [name for name, _ in rows] == bundled_rigs()
    assert all(description for _, description in rows)


@pytest.mark.slow
def test_a_shown_rig_acquires_as_the_bundled_one(tmp_path):
    """`enc rig show NAME > r.toml && enc acquire --rig r.toml` is `--rig NAME`."""
    r = run(f"enc rig show sjtu-dual > {tmp_path}/r.toml && "
            f"enc acquire --rig {tmp_path}/r.toml --revolutions 0.2 -o {tmp_path}/a.parquet && "
            f"enc acquire --rig sjtu-dual --revolutions 0.2 -o {tmp_path}/b.parquet")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "r.toml").read_text().startswith("#")  # the comments are kept
    a, b = pq.read_table(tmp_path / "a.parquet"), pq.read_table(tmp_path / "b.parquet")
    assert a.num_rows > 0 and a.schema.remove_metadata() == b.schema.remove_metadata()
    assert a.equals(b.replace_schema_metadata(a.schema.metadata))  # same samples


def test_check_summarises_heads_counts_and_polygon():
    r = run("enc rig check ciomp-23bit")
    assert r.returncode == 0, r.stderr
    out = r.stdout.decode()
    assert "8388608 counts/rev" in out and "F1 0, F2 180" in out and "24 faces" in out


@pytest.mark.parametrize("text,key", [
    ('format = 1\nname = "x"\n[[encoder]]\nname = "E"\nperiods_per_rev = 0\n',
     "encoder[0].periods_per_rev"),
    ("format = 1\nname = [\n", "not valid TOML"),
])
def test_check_names_the_key_at_fault(tmp_path, text, key):
    rig = tmp_path / "bad.toml"
    rig.write_text(text)
    for sub in ("check", "show"):
        r = run(f"enc rig {sub} {rig}")
        assert key in one_error_line(r, 2, "enc rig")
        assert r.stdout == b""


def test_unknown_rig_lists_the_bundled_ones():
    line = one_error_line(run("enc rig show sjtu"), 2, "enc rig")
    assert "bundled rigs: ciomp-23bit, sjtu-dual" in line
