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


def history_line(argv: list[str] | None = None, output: str | None = None,
                 measured: bool = False) -> str:
    """One NCO-style history line: UTC time, enctools and library versions, command line.

    The time is :func:`output_time`, or now when ``measured`` (a real acquisition keeps
    the time it measured at). The paths on the command line are written as
    :func:`recorded_path` gives them for ``output`` (the file the line goes into; None
    or "-": stdout), so that no folder of the machine reaches the file.
    """
    import shlex
    argv = sys.argv if argv is None else argv
    folder = output_folder(output)
    cmd = "enc " + shlex.join(recorded_word(a, folder) for a in argv[1:]) if argv else "enc"
    when = time.time() if measured else output_time()
    stamp = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(when))
    return f"{stamp} enctools {__version__} ({library_versions()}): {cmd}"


def with_history(header: Header, line: str | None = None, *, output: str | None = None,
                 measured: bool = False, read: tuple[str, ...] = ()) -> Header:
    """The header with one more history line (this command's, for ``output``), and the
    paths of this command's line that its metadata names (``source``, a setting's file),
    and those of files it ``read`` that its line does not name (a campaign's own),
    written as :func:`recorded_path` gives them for ``output``."""
    folder = output_folder(output)
    words = [w.split("=", 1)[-1] if w.startswith("--") else w for w in sys.argv[1:]]
    paths = {w: recorded_path(w, folder) for w in (*words, *read)
             if not w.startswith("-") and _names_path(w)}
    meta = {k: v if k in ("history", "truth") else _recorded_values(v, paths)
            for k, v in header.meta.items()}
    meta["history"] = [*header.history, line or history_line(output=output, measured=measured)]
    return Header(header.kind, header.schema, meta)


def _recorded_values(value: Any, paths: dict[str, str]) -> Any:
    """``value`` (metadata) with every string that is one of ``paths``, or ends with one
    after a space ("steps run PATH"), written as recorded."""
    if isinstance(value, dict):
        return {k: _recorded_values(v, paths) for k, v in value.items()}
    if isinstance(value, list):
        return [_recorded_values(v, paths) for v in value]
    if isinstance(value, str):
        for given, recorded in paths.items():
            if value == given:
                return recorded
            if value.endswith(" " + given):
                return value[: len(value) - len(given)] + recorded
    return value


def output_folder(output: str | None) -> str | None:
    """The folder an output is written into, as the machine names it (symbolic links
    resolved); for stdout (None or "-") the folder of the regular file it was sent to
    (``> FILE``), or None when that is not known (a pipe, a terminal)."""
    try:
        if output is not None and output != "-":  # (a removed working folder: OSError)
            return os.path.realpath(os.path.dirname(os.path.abspath(output)))
        if not os.path.isfile(f"/proc/self/fd/{sys.stdout.fileno()}"):
            return None
        return os.path.dirname(os.readlink(f"/proc/self/fd/{sys.stdout.fileno()}"))
    except (OSError, ValueError, AttributeError):
        return None


def recorded_path(path: str, folder: str | None) -> str:
    """A path as an output written into ``folder`` (:func:`output_folder`) records it:
    relative to that folder when the file is in it or below it, else its base name; never
    absolute, so the same campaign written into two folders gives the same bytes."""
    if path == "-" or not path:
        return path
    try:
        full = os.path.abspath(path)
        where = os.path.join(os.path.realpath(os.path.dirname(full)), os.path.basename(full))
        if folder is not None:
            relative = os.path.relpath(where, folder)
            if relative != os.pardir and not relative.startswith(os.pardir + os.sep):
                return Path(relative).as_posix()
    except (OSError, ValueError):
        pass
    return os.path.basename(os.path.normpath(path)) or path


def recorded_word(arg: str, folder: str | None) -> str:
    """A command-line word, or a file's name as a command was given it, with the path it
    names (an absolute one, or one through a folder that exists) as :func:`recorded_path`
    gives it; any other word, a bare name among them, as it is."""
    if arg.startswith("--") and "=" in arg:
        name, value = arg.split("=", 1)
        return f"{name}={recorded_word(value, folder)}"
    if arg.startswith("-") or not _names_path(arg):
        return arg
    return recorded_path(arg, folder)


def _names_path(arg: str) -> bool:
    """Whether a word names a file through a folder: absolute, or with a folder part that
    exists. A bare name is left as it is: it names no folder, and may be a rig's or a
    head's name that a file or folder happens to share."""
    try:
        return os.path.isabs(arg) or (os.sep in arg and (
            os.path.lexists(arg) or os.path.isdir(os.path.dirname(arg))))
    except (OSError, ValueError):
        return False


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
