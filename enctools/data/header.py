"""The header of a stream: its kind, column schema and metadata, and its history lines.

A :class:`Header` travels in the Arrow schema's metadata (key ``enctools``, JSON), in
Parquet's footer and in HDF5 attributes alike; :mod:`enctools.data.streams` and
:mod:`enctools.data.h5io` both build on it.
"""

from __future__ import annotations

import json
import os
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa

from enctools import __version__
from enctools.errors import DataError

META_KEY = b"enctools"
KIND_KEY = b"kind"


@dataclass
class Header:
    """What a stream says of itself: kind, column schema, metadata (JSON-able dict)."""

    kind: str
    schema: pa.Schema
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def history(self) -> list[str]:
        return list(self.meta.get("history", []))

    def arrow_schema(self) -> pa.Schema:
        """The Arrow schema with the kind and the metadata in its schema metadata."""
        meta = dict(self.meta)
        meta["kind"] = self.kind
        meta.setdefault("schema_version", _spec_version(self.kind))
        return self.schema.with_metadata({KIND_KEY: self.kind.encode(),
                                          META_KEY: json.dumps(meta).encode()})

    def derive(self, kind: str, schema: pa.Schema, **meta: Any) -> Header:
        """A header for a command's output: keeps rig, truth and history, sets the rest."""
        keep = {k: v for k, v in self.meta.items() if k in ("rig", "truth", "history")}
        keep.update(meta)
        keep["schema_version"] = _spec_version(kind)
        return Header(kind, schema, keep)


def _spec_version(kind: str) -> int:
    from enctools.data.schemas import kind_spec
    return kind_spec(kind).version


def library_versions() -> str:
    """The versions of the libraries the numbers depend on: "numpy 2.4.0, scipy 1.17.1, ..."."""
    return ", ".join(f"{name} {v}" for name in _NUMERIC_LIBRARIES
                     if (v := library_version(name)) is not None)


_NUMERIC_LIBRARIES = ("numpy", "scipy", "pyarrow")
_VERSION_LINE = re.compile(r"""^version\s*=\s*["'](\d[^"']*)["']""", re.MULTILINE)


def library_version(name: str) -> str | None:
    """A package's version without importing it; None when it is not installed.

    An imported package tells its ``__version__``; otherwise the ``version.py`` that
    numpy and scipy ship is read, and only failing that the installed metadata
    (importlib.metadata costs some 40 ms, a third of a short command).
    """
    module = sys.modules.get(name)
    if module is not None and isinstance(getattr(module, "__version__", None), str):
        return str(module.__version__)
    from importlib.util import find_spec

    spec = find_spec(name)
    if spec is None:
        return None
    for folder in spec.submodule_search_locations or ():
        try:
            found = _VERSION_LINE.search(Path(folder, "version.py").read_text())
        except OSError:
            continue
        if found:
            return found.group(1)
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(name)
    except PackageNotFoundError:
        return None


def output_time() -> float:
    """The time a command writes into its outputs [s since 1970-01-01 UTC]: the
    environment's SOURCE_DATE_EPOCH when it is set (the reproducible-builds convention:
    the same inputs give the same bytes), else now. A SOURCE_DATE_EPOCH that is not a
    whole number of seconds >= 0 is refused (DataError), as that convention asks."""
    given = os.environ.get("SOURCE_DATE_EPOCH")
    if given is None:
        return time.time()
    if not given.isascii() or not given.isdigit() or len(given) > 12:
        msg = f"SOURCE_DATE_EPOCH={given!r} is not a whole number of seconds since 1970"
        raise DataError(msg)
    return float(int(given))


def history_line(argv: list[str] | None = None) -> str:
    """One NCO-style history line: UTC time (:func:`output_time`), enctools and library
    versions, command line."""
    import shlex
    argv = sys.argv if argv is None else argv
    cmd = "enc " + shlex.join(argv[1:]) if argv else "enc"
    stamp = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(output_time()))
    return f"{stamp} enctools {__version__} ({library_versions()}): {cmd}"


def with_history(header: Header, line: str | None = None) -> Header:
    """The header with one more history line (this command's)."""
    meta = dict(header.meta)
    meta["history"] = [*header.history, line or history_line()]
    return Header(header.kind, header.schema, meta)


def header_from_arrow(schema: pa.Schema, source: str) -> Header:
    md = schema.metadata or {}
    if META_KEY not in md:
        msg = f"{source}: not an enctools stream (its schema carries no enctools metadata)"
        raise DataError(msg)
    meta = load_metadata(md[META_KEY], source)
    return Header(str(meta.get("kind")), schema.remove_metadata(), meta)


#: a JSON string, its loop unrolled: a run of plain bytes is one step of the matcher, not
#: one per byte (``"(?:[^"\\]|\\.)*"`` held ~120 bytes a character: 1.8 GB for 15 MB)
_JSON_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)
#: every byte but JSON's brackets (deleted before the nesting is counted)
_NOT_BRACKETS = bytes(b for b in range(256) if b not in b"{}[]")


def load_metadata(raw: bytes | str, source: str) -> dict[str, Any]:
    """A header's JSON metadata as a dict, once its size and nesting are within the limits.

    :data:`~enctools.data.limits.MAX_METADATA_BYTES` and ``MAX_METADATA_DEPTH`` are
    checked before the JSON is parsed (a deep nesting would exhaust the parser's
    recursion); a one-line DataError otherwise.
    """
    import numpy as np

    from enctools.data.limits import MAX_METADATA_BYTES, MAX_METADATA_DEPTH

    data = raw.encode() if isinstance(raw, str) else bytes(raw)
    if len(data) > MAX_METADATA_BYTES:
        msg = (f"{source}: enctools metadata of {len(data)} bytes; at most "
               f"{MAX_METADATA_BYTES} are read")
        raise DataError(msg)
    brackets = np.frombuffer(_JSON_STRING.sub(b'""', data).translate(None, _NOT_BRACKETS),
                             dtype=np.uint8)  # outside strings: a few bytes, not the text
    steps = np.where((brackets == ord("{")) | (brackets == ord("[")), 1, -1).astype(np.int32)
    depth = int(np.cumsum(steps, dtype=np.int32).max(initial=0))
    if depth > MAX_METADATA_DEPTH:
        msg = (f"{source}: enctools metadata nested {depth} levels deep; at most "
               f"{MAX_METADATA_DEPTH} are read")
        raise DataError(msg)
    try:
        meta = json.loads(data)
    except (ValueError, RecursionError):
        msg = f"{source}: enctools metadata is not valid JSON"
        raise DataError(msg) from None
    if not isinstance(meta, dict):
        msg = f"{source}: enctools metadata is not a JSON object"
        raise DataError(msg)
    return meta
