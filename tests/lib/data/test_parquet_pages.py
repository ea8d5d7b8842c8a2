"""A Parquet stream's row group read a page at a time, and its footer walked once."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from enctools.data import extent, limits
from enctools.data.schemas import make_field
from enctools.data.streams import Header, write_table


def test_one_large_row_group_is_read_a_page_at_a_time(tmp_path):
    # one row group of 2,000,000 rows x 4 float64 columns (64 MB decoded): its column
    # chunks read whole, the decoder held 77 MB; a page at a time, 18 MB
    path = tmp_path / "one.parquet"
    rows = 2_000_000
    theta = np.arange(rows) * (2 * np.pi / rows)
    schema = pa.schema([make_field("theta", pa.float64(), "rad")] + [
        make_field(f"e{i}", pa.float64(), "arcsec", "deviation", encoder="II")
        for i in range(3)])
    write_table(str(path), Header("deviations", schema, {"history": []}),
                pa.table([theta] + [np.sin((i + 1) * theta) for i in range(3)], schema=schema))
    pq.write_table(pq.read_table(path), path, row_group_size=rows, compression="none")
    assert pq.ParquetFile(path).metadata.num_row_groups == 1
    code = ("import sys, pyarrow as pa; from enctools.data import streams; "
            "s = streams.open_input(sys.argv[1]); n = sum(b.num_rows for b in s.batches()); "
            "print(n, pa.default_memory_pool().max_memory())")
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True,
                         text=True, check=True).stdout.split()
    assert int(out[0]) == rows
    assert int(out[1]) < 24e6, f"{int(out[1]) / 1e6:.0f} MB held by the decoder"


def test_the_footer_is_walked_once(tmp_path, monkeypatch):
    # the row groups' limits and the file's extent: one pass over the row groups
    path = tmp_path / "g.parquet"
    pq.write_table(pa.table({"x": np.arange(1000.0)}), path, row_group_size=100)
    metadata = pq.ParquetFile(path).metadata
    seen: list[int] = []

    class Counted:
        num_row_groups = metadata.num_row_groups

        def row_group(self, i: int):
            seen.append(i)
            return metadata.row_group(i)

    checked: list[int] = []
    monkeypatch.setattr(extent, "check_row_group",
                        lambda group, source: checked.append(group.num_rows))
    with open(path, "rb") as f:
        extent.check_parquet(f, Counted(), str(path), groups=True)
    assert seen == list(range(10)) and checked == [100] * 10
    assert limits.MAX_ROW_GROUP_ROWS == 4 << 20
