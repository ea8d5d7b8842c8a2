"""Builders of HDF5 inputs whose data lives outside the file (issue 34, item 1).

HDF5 lets a dataset keep its bytes in other files (external storage), be assembled from
another file's datasets (a virtual dataset), or a name point into another file (an
external link). Opened as they are, a stream or a user's table arriving as HDF5 copies
whatever file it names into an output: /etc/shadow, /proc/self/environ, a key; or hangs
on a FIFO. Each builder here makes such a file from a valid one, the column it moves
elsewhere holding the same values as before: read from elsewhere, the command would
succeed (exit 0), so the case shows the refusal and nothing else.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

DATA = Path(__file__).resolve().parents[1] / "data"


def _first_column(h5: Any) -> tuple[Any, str]:
    """The group and name of the first numeric column of the table in ``h5`` (the one
    group with a ``kind`` attribute, else the file's root: a user's table)."""
    import h5py

    groups = [g for g in h5.values() if isinstance(g, h5py.Group) and "kind" in g.attrs]
    group = groups[0] if groups else h5
    for name, ds in group.items():
        if isinstance(ds, h5py.Dataset) and ds.dtype.kind in "if" and ds.ndim == 1:
            return group, name
    msg = "no numeric column to move elsewhere"
    raise ValueError(msg)


def h5_elsewhere(folder: Path, base: Path, src: str, to: str, how: str,
                 target: str = "elsewhere") -> None:
    """``src`` (a base input, or a file of the case's folder) copied to ``to``, its first
    numeric column's data moved outside the file, ``how``:

    - ``external``: HDF5 external storage in the raw file ``target`` (by its absolute
      name, as an attacker's /etc/passwd would be);
    - ``fifo``: external storage in the FIFO ``target`` (reading it would wait forever);
    - ``link``: an external link to dataset ``data`` of the HDF5 file ``target``;
    - ``virtual``: a virtual dataset mapping all of ``target``'s dataset ``data``.
    """
    import h5py

    source = folder / src if (folder / src).exists() else base / src
    shutil.copy(source, folder / to)
    elsewhere = folder / target
    with h5py.File(folder / to, "r+") as h5:
        group, name = _first_column(h5)
        ds = group[name]
        values, attrs = ds[()], dict(ds.attrs)
        del group[name]
        if how in ("external", "fifo"):
            if how == "fifo":
                os.mkfifo(elsewhere)
            else:
                elsewhere.write_bytes(values.tobytes())
            new = group.create_dataset(name, shape=values.shape, dtype=values.dtype,
                                       external=[(str(elsewhere), 0, values.nbytes)])
        elif how in ("link", "virtual"):
            with h5py.File(elsewhere, "w") as other:
                other.create_dataset("data", data=values).attrs.update(attrs)
            if how == "link":
                group[name] = h5py.ExternalLink(str(elsewhere), "data")
                return
            layout = h5py.VirtualLayout(shape=values.shape, dtype=values.dtype)
            layout[:] = h5py.VirtualSource(str(elsewhere), "data", shape=values.shape)
            new = group.create_virtual_dataset(name, layout)
        else:
            msg = f"h5_elsewhere: unknown how {how!r}"
            raise ValueError(msg)
        new.attrs.update(attrs)


def h5_table(folder: Path, base: Path, to: str, src: str = "seed001_table1.csv") -> None:
    """A user's table as HDF5 without enctools' metadata: one dataset per column of the
    tests' text table ``src`` (its titles as the names), at the file's root."""
    import h5py
    import numpy as np

    lines = [ln for ln in (DATA / src).read_text(encoding="utf-8").splitlines()
             if ln.strip() and not ln.startswith("#")]
    titles = [t.strip() for t in lines[0].split(",")]
    rows = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    with h5py.File(folder / to, "w") as h5:
        for i, title in enumerate(titles):
            h5[title] = rows[:, i]
