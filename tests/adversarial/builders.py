"""Builders of the catalogue's hostile inputs.

A case's ``setup`` is a list of steps, ``{use = "NAME", ...}``: each calls the builder
``NAME(folder, base, **the other keys)``, which writes into the case's own folder. ``base``
is a folder of small valid inputs made once per test session (:func:`make_base`); the
builders copy from it, then break the copy. A builder writes what it is told and no more:
the runner takes a snapshot of the folder after the setup, and a failing command must
leave it as it was.
"""

from __future__ import annotations

import json
import os
import random as _random
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from adversarial.h5builders import h5_elsewhere, h5_table

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data"
RIGS = ROOT / "tests" / "rigs"
BUNDLED = ROOT / "enctools" / "rigs"

#: the base inputs in waves (a wave reads only what earlier waves made): file name ->
#: the enc command (after ``enc``) that makes it
BASE: list[dict[str, list[str]]] = [
    {"raw.arrows": ["acquire", "--rig", "sjtu-dual", "--revolutions", "0.05"],
     "r2.parquet": ["acquire", "--rig", "sjtu-dual", "--revolutions", "2",
                    "--heads", "H1,H2,H3,H4,P1,P2"],
     "lat.parquet": ["acquire", "--rig", "ciomp-23bit", "--mode", "continuous",
                     "--revolutions", "0.05"],
     "steps.parquet": ["acquire", "--rig", "ciomp-23bit", "--mode", "steps"],
     "closure.parquet": ["acquire", "--rig", "ciomp-23bit", "--mode", "closure", "--readings",
                         "1", "--settle", "0"],
     "sweep.parquet": ["acquire", "--rig", "sjtu-dual", "--mode", "sweep"],
     "signals.parquet": ["acquire", "--rig", "sjtu-dual", "--mode", "sweep", "--readings", "1",
                         "--runs", "1", "--signals", "--heads", "P1,P2"],
     "points.parquet": ["points", str(DATA / "seed001_table1.csv")],
     "points.arrows": ["points", str(DATA / "seed001_table1.csv")]},
    {"raw.parquet": ["acquire", "--replay", "raw.arrows"],
     "raw.h5": ["acquire", "--replay", "raw.arrows"],
     "raw.arrow": ["acquire", "--replay", "raw.arrows"],
     "steps.h5": ["acquire", "--replay", "steps.parquet"],
     "model.parquet": ["fit-rbf", "points.parquet", "--spread", "15"],
     "model.h5": ["fit-rbf", "points.parquet", "--spread", "15"],
     "dev.parquet": ["selfcal", "r2.parquet", "--spectrum", "spec.parquet"],
     "dev.arrows": ["compare", "r2.parquet", "--device", "H1", "--reference", "P1"],
     "dev.csv": ["selfcal", "r2.parquet", "--spectrum", "spec.tsv"],
     "r2.h5": ["acquire", "--replay", "r2.parquet"],
     "r2.arrows": ["acquire", "--replay", "r2.parquet"]},
    # a table to be read, whatever it holds: the guards of enc-make-rom(1) waived
    {"rom.parquet": ["make-rom", "model.parquet", "--bits", "10", "--target", "stream",
                     "--allow-no-gain", "--allow-coarse"],
     "polypts.parquet": ["points", "steps.parquet"]},
]


def _enc() -> str:
    return str(Path(sys.executable).parent / "enc")


def make_base(folder: Path) -> None:
    """The valid inputs every case starts from (a few seconds, once per session)."""
    from concurrent.futures import ThreadPoolExecutor

    def make(name: str, args: list[str]) -> None:
        r = subprocess.run([_enc(), *args, "-q", "-o", name], cwd=folder, capture_output=True,
                           timeout=300)
        if r.returncode != 0:
            msg = f"base input {name}: {r.stderr.decode()}"
            raise RuntimeError(msg)

    folder.mkdir(parents=True, exist_ok=True)
    with ThreadPoolExecutor(4) as pool:
        for wave in BASE:
            for f in [pool.submit(make, name, args) for name, args in wave.items()]:
                f.result()
    shutil.copy(DATA / "seed001_table1.csv", folder / "table1.csv")


# ------------------------------------------------------------------ plain files

def copy(folder: Path, base: Path, src: str, to: str | None = None) -> None:
    """A base input (or a file of tests/data, tests/rigs: ``data:NAME``, ``rigs:NAME``)."""
    shutil.copy(_source(base, src), folder / (to or Path(src).name.split(":")[-1]))


def _source(base: Path, src: str) -> Path:
    if src.startswith("data:"):
        return DATA / src[5:]
    if src.startswith("rigs:"):
        return RIGS / src[5:]
    if src.startswith("bundled:"):
        return BUNDLED / f"{src[8:]}.toml"
    return base / src


def empty(folder: Path, base: Path, to: str) -> None:
    (folder / to).write_bytes(b"")


def text(folder: Path, base: Path, to: str, content: str) -> None:
    """A file holding ``content`` (UTF-8, written as given)."""
    (folder / to).write_text(content, encoding="utf-8")


def random_bytes(folder: Path, base: Path, to: str, size: int = 4096, seed: int = 0,
                 prefix: str = "") -> None:
    """``size`` random bytes, optionally after a prefix (magic bytes, given as latin-1)."""
    rng = _random.Random(seed)
    (folder / to).write_bytes(prefix.encode("latin-1") + rng.randbytes(size))


def sparse(folder: Path, base: Path, to: str, size: int) -> None:
    """A file of ``size`` zero bytes that takes no disk (a hole): a length to be believed."""
    with (folder / to).open("wb") as f:
        f.truncate(size)


def truncate(folder: Path, base: Path, src: str, to: str, at: float) -> None:
    """A base input cut short: at byte ``at`` (negative: that many bytes before the end;
    a fraction between 0 and 1: that part of the file)."""
    data = _source(base, src).read_bytes()
    n = int(len(data) * at) if 0 < at < 1 else int(at)
    (folder / to).write_bytes(data[:n])


def corrupt(folder: Path, base: Path, src: str, to: str, at: float, count: int = 16,
            seed: int = 0) -> None:
    """A base input with ``count`` bytes flipped from ``at`` on (a fraction of the file;
    negative: that part before the end): a sector gone bad, a copy over a noisy link.
    Parquet and Arrow keep no checksum: what decodes may be read."""
    data = bytearray(_source(base, src).read_bytes())
    start = int(len(data) * (at if at >= 0 else 1 + at))
    rng = _random.Random(seed)
    for i in range(start, min(start + count, len(data))):
        data[i] ^= rng.randrange(1, 256)
    (folder / to).write_bytes(bytes(data))


def cast_column(folder: Path, base: Path, src: str, to: str, column: str,
                type: str = "string") -> None:
    """``column`` turned into another Arrow ``type`` (its field metadata kept)."""
    import pyarrow as pa

    table = _read(_source(base, src))
    i = table.schema.get_field_index(column)
    f = table.schema.field(i)
    col = table.column(i).cast(pa.string()) if type == "string" else table.column(i).cast(type)
    _write(table.set_column(i, pa.field(column, col.type, metadata=f.metadata), col), folder / to)


def big_csv_field(folder: Path, base: Path, to: str, size: int = 200_000) -> None:
    """A points CSV whose second data line holds one field of ``size`` characters."""
    (folder / to).write_text("position_deg,deviation_arcsec\n0,1.0\n15," + "7" * size + "\n")


def csv_rows(folder: Path, base: Path, to: str, rows: list[list[Any]],
             header: str = "position_deg,deviation_arcsec") -> None:
    lines = [header, *(",".join(str(v) for v in row) for row in rows)]
    (folder / to).write_text("\n".join(lines) + "\n")


# ------------------------------------------------------------------ CSV streams

SIDECAR = "-metadata.json"


def csv_pair(folder: Path, base: Path, src: str, to: str, sidecar_of: str | None = None,
             table: bool = True) -> None:
    """A CSV or TSV stream of the base with its sidecar: the sidecar of ``sidecar_of``
    instead (another table's), or the sidecar alone (``table`` false)."""
    if table:
        shutil.copy(_source(base, src), folder / to)
    shutil.copy(_source(base, (sidecar_of or src) + SIDECAR), folder / (to + SIDECAR))


def csv_cut(folder: Path, base: Path, src: str, to: str, at: float = 0.0,
            lines: int = 0) -> None:
    """A CSV stream with its sidecar, the table cut at a fraction ``at`` of its bytes, or
    its last ``lines`` lines dropped (the file still ends with a newline)."""
    csv_pair(folder, base, src, to)
    data = (folder / to).read_bytes()
    if lines:
        data = b"".join(data.splitlines(keepends=True)[:-lines])
    else:
        data = data[: int(len(data) * at)]
    (folder / to).write_bytes(data)


def csv_field(folder: Path, base: Path, src: str, to: str, value: str, line: int = 1,
              repeat: int = 1) -> None:
    """A CSV stream with its sidecar whose data line ``line`` starts with ``value`` *
    ``repeat`` in place of its first field (a number without quotes)."""
    csv_pair(folder, base, src, to)
    lines = (folder / to).read_bytes().splitlines(keepends=True)
    _, sep, rest = lines[line].partition(b",")
    lines[line] = (value * repeat).encode() + sep + rest
    (folder / to).write_bytes(b"".join(lines))


def csv_sidecar(folder: Path, base: Path, src: str, to: str, path: str = "",
                value: Any = None, text: str | None = None, depth: int = 0) -> None:
    """A CSV stream whose sidecar has ``value`` at the dotted ``path``
    (``enctools.kind``), or is the raw ``text``, or nests a list ``depth`` deep."""
    csv_pair(folder, base, src, to)
    side = folder / (to + SIDECAR)
    if text is not None:
        side.write_text(text)
        return
    doc = json.loads(side.read_text())
    if depth:
        value = json.loads("[" * depth + "]" * depth)
    _set_path(doc, path, value)
    side.write_text(json.dumps(doc))


def fifo(folder: Path, base: Path, to: str) -> None:
    os.mkfifo(folder / to)


def mkdir(folder: Path, base: Path, to: str) -> None:
    (folder / to).mkdir(parents=True, exist_ok=True)


def symlink(folder: Path, base: Path, to: str, target: str) -> None:
    (folder / to).symlink_to(target)


def stale_temporary(folder: Path, base: Path, name: str, age_s: float = 7200) -> None:
    """What kill -9 leaves: ``.NAME.PID@HOST.RANDOM.tmp`` of an ended writer, ``age_s`` old."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    host = os.uname().nodename
    t = folder / f".{name}.{p.pid}@{host}.k9x{p.pid % 1000}.tmp"
    t.write_bytes(b"PAR1 partial")
    then = time.time() - age_s
    os.utime(t, (then, then))


class Unsupported(Exception):
    """This machine cannot build the case's input (a mount without the privilege): the
    case is skipped, saying why."""


def full_disk(folder: Path, base: Path, to: str, size_kib: int = 256, free: int = 0) -> None:
    """A file system of ``size_kib`` KiB mounted at ``to`` (a tmpfs), filled until only
    ``free`` bytes are left: a full disk. Needs the privilege to mount (root in the
    sandbox the suite runs in); :func:`unmount_all` removes it after the case."""
    where = folder / to
    where.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kib}k,mode=1777", "tmpfs",
                        str(where)], capture_output=True, text=True, check=False)
    if r.returncode != 0:
        where.rmdir()
        msg = f"cannot mount a small file system here: {r.stderr.strip() or r.returncode}"
        raise Unsupported(msg)
    st = os.statvfs(where)
    left = st.f_bavail * st.f_frsize - free
    with open(where / ".fill", "wb") as f:
        while left > 0:
            n = f.write(b"\0" * min(left, 1 << 16))
            left -= n


def unmount_all(folder: Path) -> None:
    """Unmount what :func:`full_disk` mounted below ``folder``."""
    with open("/proc/self/mounts", encoding="utf-8") as f:
        points = [line.split()[1] for line in f]
    mine = [p for p in points if p.startswith(f"{folder}/")]
    for p in sorted(mine, reverse=True):
        subprocess.run(["umount", "-l", p], capture_output=True, check=False)


def nightly_folder(folder: Path, base: Path, pid: int, to: str = "tmp", lock: bool = True,
                   name: str = "k9x") -> None:
    """What a killed enc-nightly leaves in its TMPDIR ``to``: ``enc-nightly-PID@HOST-NAME``
    with a result in it, and its lock file (unheld) unless ``lock`` is false."""
    from enctools.data.files import writer_tag

    host = writer_tag().split("@", 1)[1]
    d = folder / to / f"enc-nightly-{pid}@{host}-{name}"
    d.mkdir(parents=True)
    (d / "result.parquet").write_bytes(b"PAR1 partial")
    if lock:
        (d / ".enc-nightly.lock").write_text(f"{pid}@{host}\n")


# ------------------------------------------------------------------ streams

def _read(path: Path) -> Any:
    """A stream file as an Arrow table, its schema metadata kept (any of the four formats)."""
    from enctools.data import streams

    with streams.open_input(str(path)) as s:
        table = s.read_all()
        meta = {b"kind": s.header.kind.encode(),
                b"enctools": json.dumps(s.header.meta).encode()}
    return table.replace_schema_metadata({**(table.schema.metadata or {}), **meta})


def _write(table: Any, path: Path) -> None:
    """``table`` as Parquet or Arrow IPC (by the extension), its metadata as it is."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    if path.suffix in (".arrows", ".ipc"):
        with pa.ipc.new_stream(path, table.schema) as w:
            w.write_table(table)
    elif path.suffix in (".arrow", ".feather"):
        with pa.ipc.new_file(path, table.schema) as w:
            w.write_table(table)
    else:
        pq.write_table(table, path)


def drop_column(folder: Path, base: Path, src: str, to: str, column: str) -> None:
    table = _read(_source(base, src))
    _write(table.drop_columns([column]), folder / to)


def field_meta(folder: Path, base: Path, src: str, to: str, column: str, key: str,
               value: str | None) -> None:
    """A stream whose column's field metadata ``key`` is ``value`` (None: removed)."""
    import pyarrow as pa

    table = _read(_source(base, src))
    i = table.schema.get_field_index(column)
    f = table.schema.field(i)
    md = dict(f.metadata or {})
    md.pop(key.encode(), None)
    if value is not None:
        md[key.encode()] = str(value).encode()
    schema = table.schema.set(i, pa.field(f.name, f.type, metadata=md))
    _write(pa.Table.from_arrays(table.columns, schema=schema), folder / to)


def _set_path(meta: dict[str, Any], path: str, value: Any) -> None:
    keys = path.split(".")
    node: Any = meta
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
    if isinstance(node, list):
        node[int(keys[-1])] = value
    else:
        node[keys[-1]] = value


def stream_meta(folder: Path, base: Path, src: str, to: str, path: str, value: Any = None,
                repeat: int = 1) -> None:
    """A stream whose ``enctools`` metadata has ``value`` at the dotted ``path``
    (``rig.polygon.faces``, ``rig``); a text ``value`` ``repeat`` times over (a long
    description)."""
    if isinstance(value, str):
        value *= repeat
    table = _read(_source(base, src))
    meta = json.loads(table.schema.metadata[b"enctools"])
    _set_path(meta, path, value)
    md = {**table.schema.metadata, b"enctools": json.dumps(meta).encode()}
    _write(table.replace_schema_metadata(md), folder / to)


def raw_meta(folder: Path, base: Path, src: str, to: str, key: str, value: str) -> None:
    """A stream whose schema metadata ``key`` (``enctools``, ``kind``) is the raw text."""
    table = _read(_source(base, src))
    md = {**table.schema.metadata, key.encode(): value.encode()}
    _write(table.replace_schema_metadata(md), folder / to)


def deep_json_meta(folder: Path, base: Path, src: str, to: str, depth: int,
                   where: str = "settings") -> None:
    """The ``enctools`` metadata with a list nested ``depth`` deep at ``where``."""
    table = _read(_source(base, src))
    text_ = table.schema.metadata[b"enctools"].decode()
    nested = "[" * depth + "]" * depth
    assert text_.startswith("{")
    text_ = "{" + json.dumps(where) + ": " + nested + ", " + text_[1:]
    md = {**table.schema.metadata, b"enctools": text_.encode()}
    _write(table.replace_schema_metadata(md), folder / to)


def nasty_meta(folder: Path, base: Path, src: str, to: str, extra: str = "",
               name: str = "rig") -> None:
    """A stream whose rig description and a history line carry terminal controls (and
    ``extra``), its rig named ``name``."""
    nasty = "\x1b[2J\x1b]0;title\x07\rerror: fake\x9b31m\x7f" + extra
    table = _read(_source(base, src))
    meta = json.loads(table.schema.metadata[b"enctools"])
    meta["rig"] = {**(meta.get("rig") or {}), "name": name,
                   "description": "desc" + nasty + "\nsecond line"}
    meta["history"] = [*meta.get("history", []), "hist" + nasty]
    md = {**table.schema.metadata, b"enctools": json.dumps(meta).encode()}
    _write(table.replace_schema_metadata(md), folder / to)


def nasty_column(folder: Path, base: Path, src: str, to: str, column: str) -> None:
    """A stream whose column ``column`` is renamed to a name carrying terminal controls,
    with a unit that does too."""
    import pyarrow as pa

    table = _read(_source(base, src))
    i = table.schema.get_field_index(column)
    f = table.schema.field(i)
    md = {**(f.metadata or {}), b"unit": b"arcsec\x1b[2J"}
    schema = table.schema.set(i, pa.field(f"{column}\x1b]0;x\x07", f.type, metadata=md))
    _write(pa.Table.from_arrays(table.columns, schema=schema), folder / to)


def set_values(folder: Path, base: Path, src: str, to: str, column: str, value: Any,
               rows: str = "all") -> None:
    """A stream whose ``column`` holds ``value`` ("nan", "inf", "-inf", "int64max", a
    number) in every row (``rows = "all"``), the first (``"first"``) or the middle one."""
    import numpy as np
    import pyarrow as pa

    table = _read(_source(base, src))
    i = table.schema.get_field_index(column)
    f = table.schema.field(i)
    col = table.column(i).to_numpy().copy()
    special = {"nan": np.nan, "inf": np.inf, "-inf": -np.inf,
               "int64max": np.iinfo(np.int64).max, "int64min": np.iinfo(np.int64).min}
    v = special.get(value, value) if isinstance(value, str) else value
    if rows == "all":
        col[:] = v
    else:
        col[0 if rows == "first" else len(col) // 2] = v
    cols = list(table.columns)
    cols[i] = pa.array(col, type=f.type)
    _write(pa.Table.from_arrays(cols, schema=table.schema), folder / to)


def concatenated(folder: Path, base: Path, src: str, to: str, times: int = 2,
                 tail: str = "") -> None:
    """``src``'s bytes ``times`` times over, then ``tail`` (text): two streams in one
    file, or a stream followed by garbage."""
    data = _source(base, src).read_bytes()
    (folder / to).write_bytes(data * times + tail.encode())


def extreme_value(folder: Path, base: Path, src: str, to: str, column: str,
                  sign: int = 1) -> None:
    """``column``'s middle row at the end of its type's range: +inf in a float column,
    the largest int64 in an integer one (``sign = -1``: -inf, the smallest int64)."""
    import pyarrow as pa

    f = _read(_source(base, src)).schema.field(column)
    value = ("inf" if pa.types.is_floating(f.type) else "int64max") if sign > 0 else (
        "-inf" if pa.types.is_floating(f.type) else "int64min")
    set_values(folder, base, src, to, column, value, rows="middle")


def null_column(folder: Path, base: Path, src: str, to: str, column: str,
                how: str = "typed") -> None:
    """``column`` of Arrow's null type (``how = "typed"``: a column that holds nothing),
    or of its own type with its middle row missing (``"one"``: a validity bitmap)."""
    import numpy as np
    import pyarrow as pa

    table = _read(_source(base, src))
    i = table.schema.get_field_index(column)
    f = table.schema.field(i)
    if how == "typed":
        col, field = pa.nulls(table.num_rows), pa.field(column, pa.null(), metadata=f.metadata)
    else:
        mask = np.arange(table.num_rows) == table.num_rows // 2
        col = pa.array(table.column(i).to_numpy(zero_copy_only=False), type=f.type, mask=mask)
        field = f
    _write(table.set_column(i, field, col), folder / to)


def duplicate_column(folder: Path, base: Path, src: str, to: str, column: str) -> None:
    """A stream holding ``column`` twice (the second a copy of the first)."""
    table = _read(_source(base, src))
    i = table.schema.get_field_index(column)
    _write(table.append_column(table.schema.field(i), table.column(i)), folder / to)


def h5_claims_rows(folder: Path, base: Path, src: str, to: str, rows: int) -> None:
    """An HDF5 copy of a stream whose every column dataset claims ``rows`` rows: chunked,
    never written (a few kB on disk)."""
    import h5py

    shutil.copy(_source(base, src), folder / to)
    with h5py.File(folder / to, "r+") as h5:
        for gname, g in list(h5.items()):
            if not isinstance(g, h5py.Group):
                continue
            for name, ds in list(g.items()):
                attrs = dict(ds.attrs)
                dtype = ds.dtype
                del g[name]
                new = g.create_dataset(name, shape=(rows,), dtype=dtype, chunks=(1 << 16,))
                for k, v in attrs.items():
                    new.attrs[k] = v
            del gname


def many_rows(folder: Path, base: Path, src: str, to: str, rows: int) -> None:
    """A Parquet readings file of ``rows`` rows of one repeated row of ``src`` (each column
    one value: dictionary-encoded, a few MB). Made once per session and linked."""
    import fcntl

    cache = base / f"many-{rows}-{Path(src).stem}.parquet"
    with open(base / ".many.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not cache.exists():
            _write_many(_source(base, src), cache, rows)
    os.link(cache, folder / to)


def _write_many(src: Path, out: Path, rows: int) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = _read(src)
    chunk = 1 << 22
    one = table.slice(0, 1)
    block = pa.Table.from_arrays([pa.repeat(c.chunk(0)[0], chunk) if hasattr(pa, "repeat")
                                  else c.take([0] * chunk) for c in one.columns],
                                 schema=table.schema)
    tmp = out.with_suffix(".part")
    with pq.ParquetWriter(tmp, table.schema, compression="zstd",
                          use_dictionary=True) as w:
        done = 0
        while done < rows:
            n = min(chunk, rows - done)
            w.write_table(block.slice(0, n), row_group_size=chunk)
            done += n
    tmp.rename(out)


# ------------------------------------------------------------------ rig files

def rig(folder: Path, base: Path, to: str = "rig.toml", src: str = "bundled:ciomp-23bit",
        replace: dict[str, str] | None = None, append: str = "", prepend: str = "") -> None:
    """A rig file: ``src`` (a bundled rig, or ``rigs:visa-sim.toml`` with its pyvisa-sim
    file beside it) with text substitutions (each must match) and lines added."""
    path = _source(base, src)
    body = path.read_text()
    for old, new in (replace or {}).items():
        if old not in body:
            msg = f"rig builder: {old!r} is not in {path}"
            raise ValueError(msg)
        body = body.replace(old, new)
    (folder / to).write_text(prepend + body + append)
    if src.startswith("rigs:"):
        shutil.copy(RIGS / "rotary-table.yaml", folder)


def deep_toml(folder: Path, base: Path, to: str, depth: int, how: str = "array") -> None:
    """A rig file nesting an array (or inline table) ``depth`` deep."""
    if how == "array":
        value = "[" * depth + "1" + "]" * depth
    else:
        value = "{a = " * depth + "1" + "}" * depth
    (folder / to).write_text(f'format = 1\nname = "deep"\ndescription = {value}\n')


def wide_heads(folder: Path, base: Path, src: str, to: str, heads: int, like: str = "H1",
               every: int = 1) -> None:
    """``src`` with ``heads`` copies of head ``like`` (G0, G1, ...), each at its own nominal
    angle 360 k / heads [deg] and its zero count that much larger (the same counts), so
    that every copy reads as ``like`` does; every ``every``-th row of ``src``; the rig's
    measuring heads of that encoder are the copies. Only t and the copies are written, as
    an Arrow IPC stream."""
    import pyarrow as pa

    table = _read(_source(base, src))
    table = table.take(list(range(0, table.num_rows, every)))
    field = table.schema.field(like)
    meta = dict(field.metadata or {})
    cpr = int(meta[b"counts_per_rev"])
    zero0 = int(meta[b"zero_count"])
    counts = table.column(like).combine_chunks()
    fields, cols = [table.schema.field("t")], [table.column("t").combine_chunks()]

    for k in range(heads):
        zero = (cpr * k) // heads
        m = meta | {b"alpha_deg": repr(360.0 * zero / cpr).encode(),
                    b"zero_count": str(zero0 + zero).encode()}
        fields.append(pa.field(f"G{k}", pa.int64(), metadata=m))
        cols.append(counts)
    meta_json = json.loads(table.schema.metadata[b"enctools"])
    for enc in meta_json["rig"]["encoders"]:
        if enc["name"] == meta[b"encoder"].decode():
            enc["measure_heads"] = [f"G{k}" for k in range(heads)]
    smeta = {**table.schema.metadata, b"enctools": json.dumps(meta_json).encode()}
    out = pa.Table.from_arrays(cols, schema=pa.schema(fields, smeta))
    with pa.ipc.new_stream(folder / to, out.schema) as w:  # batches of 256 rows, as acquire's
        w.write_table(out, max_chunksize=256)


def closure_run(folder: Path, base: Path, src: str, to: str, faces: int,
                readings: int = 1) -> None:
    """A closure run of ``faces`` faces shaped as ``src`` (a closure run) records it: an
    Arrow IPC stream of one batch a reading, as enc acquire writes it; faces x faces
    positions, ``readings`` each, the heads exact and the autocollimator 0; the rig's
    polygon has ``faces`` faces."""
    import numpy as np
    import pyarrow as pa

    table = _read(_source(base, src))
    meta = json.loads(table.schema.metadata[b"enctools"])
    meta["rig"]["polygon"]["faces"] = faces
    schema = table.schema.with_metadata({**table.schema.metadata,
                                         b"enctools": json.dumps(meta).encode()})
    n = faces * faces * readings
    run = np.repeat(np.arange(faces, dtype=np.int32), faces * readings)
    step = np.tile(np.repeat(np.arange(faces, dtype=np.int32), readings), faces)
    cols: dict[str, Any] = {"t": np.arange(n) * 0.001, "target": step * (2 * np.pi / faces),
                            "step": step, "run": run, "direction": np.ones(n, np.int8)}
    for f in schema:
        m = f.metadata or {}
        if m.get(b"role") == b"head":
            cpr = int(m[b"counts_per_rev"])
            turns = step / faces + float(m[b"alpha_deg"]) / 360.0
            cols[f.name] = np.round(cpr * turns).astype(np.int64) - int(m[b"zero_count"])
    arrays = [pa.array(cols.get(f.name, np.zeros(n)), type=f.type) for f in schema]
    with pa.ipc.new_stream(folder / to, schema) as w:
        w.write_table(pa.Table.from_arrays(arrays, schema=schema), max_chunksize=1)


BUILDERS: dict[str, Callable[..., None]] = {
    f.__name__: f for f in (copy, empty, text, random_bytes, sparse, truncate, big_csv_field,
                            csv_rows, fifo, mkdir, symlink, stale_temporary, drop_column,
                            field_meta, stream_meta, raw_meta, deep_json_meta, nasty_meta,
                            nasty_column, set_values, h5_claims_rows, many_rows, rig,
                            deep_toml, csv_pair, csv_cut, csv_field, csv_sidecar,
                            full_disk, concatenated, extreme_value, null_column,
                            duplicate_column, nightly_folder, corrupt, cast_column,
                            wide_heads, closure_run, h5_elsewhere, h5_table)
}


def build(folder: Path, base: Path, steps: list[dict[str, Any]]) -> None:
    """Run a case's setup steps in order."""
    for step in steps:
        args = dict(step)
        name = args.pop("use")
        BUILDERS[name](folder, base, **args)
