"""The catalogue's rows: read from cases/*.toml, checked, matrices expanded.

A file holds ``[[case]]`` rows, and may hold the two matrices: ``[[reader]]`` x
``[[hostile_input]]`` (every command that reads a stream against every broken input) and
``[[writer]]`` x ``[[hostile_output]]`` (every writer against every output it must
refuse). A new command is covered by adding a reader or writer row. The keys of a row
are documented in cases/README.md.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

CASES = Path(__file__).resolve().parent / "cases"

#: the keys of a case row and their types
CASE_KEYS: dict[str, type | tuple[type, ...]] = {
    "id": str, "category": str, "setup": list, "argv": list, "shell": str, "stdin": str,
    "env": dict, "exit": (int, list), "files": list, "absent": list, "unchanged": list,
    "readable": list, "stderr": str, "stdout_lacks": list, "file_lacks": list,
    "signal": dict, "timeout": (int, float), "pending": str, "error_cmd": str,
    "why": str, "limits": dict, "check": str,
}
READER_KEYS = {"name", "argv", "valid", "other_kind", "column", "stdin", "pending", "outputs",
               "setup"}
HOSTILE_IN_KEYS = {"id", "setup", "stdin", "exit", "why", "formats"}
WRITER_KEYS = {"name", "argv", "ext", "setup", "pending", "timeout", "not_for"}
HOSTILE_OUT_KEYS = {"id", "setup", "out", "force", "exit", "unchanged", "files", "why", "limits"}


@dataclass
class Case:
    id: str
    category: str
    setup: list[dict[str, Any]] = field(default_factory=list)
    argv: list[str] | None = None
    shell: str | None = None
    stdin: str | None = None
    env: dict[str, str] = field(default_factory=dict)
    exit: list[int] = field(default_factory=lambda: [2])
    files: list[str] = field(default_factory=list)
    absent: list[str] = field(default_factory=list)
    unchanged: list[str] = field(default_factory=list)
    readable: list[str] = field(default_factory=list)
    stderr: str | None = None
    stdout_lacks: list[str] = field(default_factory=list)
    file_lacks: list[dict[str, str]] = field(default_factory=list)
    signal: dict[str, Any] | None = None
    limits: dict[str, int] = field(default_factory=dict)
    timeout: float = 10.0
    pending: str | None = None
    error_cmd: str | None = None
    check: str | None = None
    why: str = ""
    source: str = ""
    matrix: bool = False

    def command(self) -> str:
        """The command whose error line is expected: ``enc CMD`` or ``enc-nightly``."""
        if self.error_cmd:
            return self.error_cmd
        if self.argv and self.argv[0] == "enc-nightly":
            return "enc-nightly"
        if self.argv:
            return f"enc {self.argv[1]}"
        return "enc"


def _fail(source: str, row: dict[str, Any], why: str) -> None:
    msg = f"{source}: row {row.get('id') or row.get('name')!r}: {why}"
    raise ValueError(msg)


def _case(row: dict[str, Any], source: str) -> Case:
    for key, value in row.items():
        if key not in CASE_KEYS:
            _fail(source, row, f"unknown key {key!r}")
        if not isinstance(value, CASE_KEYS[key]):
            _fail(source, row, f"{key} is not {CASE_KEYS[key]}")
    if ("argv" in row) == ("shell" in row):
        _fail(source, row, "give argv or shell, not both")
    for key in ("id", "category"):
        if key not in row:
            _fail(source, row, f"{key} is required")
    codes = row.get("exit", 2)
    kw = {**row, "exit": codes if isinstance(codes, list) else [codes], "source": source}
    return Case(**kw)


def _fill(value: Any, subs: dict[str, str]) -> Any:
    """``value`` with ``{name}`` placeholders of ``subs`` replaced, recursively (other
    braces are left alone: they are the runner's placeholders)."""
    if isinstance(value, str):
        for k, v in subs.items():
            value = value.replace("{" + k + "}", v)
        return value
    if isinstance(value, list):
        return [_fill(v, subs) for v in value]
    if isinstance(value, dict):
        return {k: _fill(v, subs) for k, v in value.items()}
    return value


def _check_keys(rows: list[dict[str, Any]], keys: set[str], source: str) -> None:
    for row in rows:
        extra = set(row) - keys
        if extra:
            _fail(source, row, f"unknown key(s) {sorted(extra)}")


def _readers(doc: dict[str, Any], source: str) -> list[Case]:
    readers, hostile = doc.get("reader", []), doc.get("hostile_input", [])
    _check_keys(readers, READER_KEYS, source)
    _check_keys(hostile, HOSTILE_IN_KEYS, source)
    out = []
    for r in readers:
        ext = Path(r["valid"]).suffix
        for h in hostile:
            if h.get("stdin") and not r.get("stdin", True):
                continue
            if "formats" in h and ext not in h["formats"]:  # damage of one format's own
                continue
            inp = "-" if h.get("stdin") else f"in{ext}"
            subs = {"in": f"in{ext}", "valid": r["valid"], "other": r.get("other_kind", ""),
                    "column": r.get("column", ""), "input": inp}
            if "{other}" in str(h["setup"]) and not r.get("other_kind"):
                continue
            if "{column}" in str(h["setup"]) and not r.get("column"):
                continue
            argv = _fill(r["argv"], subs)
            pending = r.get("pending", {}).get(h["id"])
            codes = h["exit"] if isinstance(h.get("exit"), list) else [h.get("exit", 2)]
            out.append(Case(
                id=f"{r['name']}-{h['id']}", category="inputs",
                setup=[*r.get("setup", []), *_fill(h["setup"], subs)], argv=argv,
                stdin=f"in{ext}" if h.get("stdin") else None,
                exit=codes, absent=[] if 0 in codes else _fill(r.get("outputs", []), subs),
                pending=pending, why=h.get("why", ""), source=source, matrix=True))
    return out


def _writers(doc: dict[str, Any], source: str) -> list[Case]:
    writers, hostile = doc.get("writer", []), doc.get("hostile_output", [])
    _check_keys(writers, WRITER_KEYS, source)
    _check_keys(hostile, HOSTILE_OUT_KEYS, source)
    out = []
    for w in writers:
        for h in hostile:
            if h["id"] in w.get("not_for", {}):  # the writer's man page says otherwise
                continue
            target = _fill(h["out"], {"ext": w["ext"]})
            subs = {"out": target, "ext": w["ext"]}
            argv = _fill(w["argv"], subs) + (["--force"] if h.get("force") else [])
            out.append(Case(
                id=f"{w['name']}-{h['id']}", category="outputs",
                setup=[*w.get("setup", []), *_fill(h.get("setup", []), subs)], argv=argv,
                exit=[h.get("exit", 2)], unchanged=_fill(h.get("unchanged", []), subs),
                files=_fill(h.get("files", []), subs),
                limits=h.get("limits", {}),
                pending=w.get("pending", {}).get(h["id"]), why=h.get("why", ""),
                timeout=w.get("timeout", 10.0), source=source, matrix=True))
    return out


def load(folder: Path = CASES) -> list[Case]:
    """Every case of every file, ids unique."""
    cases: list[Case] = []
    for path in sorted(folder.glob("*.toml")):
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
        extra = set(doc) - {"case", "reader", "hostile_input", "writer", "hostile_output"}
        if extra:
            msg = f"{path.name}: unknown table(s) {sorted(extra)}"
            raise ValueError(msg)
        cases += [_case(row, path.name) for row in doc.get("case", [])]
        cases += _readers(doc, path.name) + _writers(doc, path.name)
    seen: set[str] = set()
    for c in cases:
        if c.id in seen:
            msg = f"{c.source}: duplicate case id {c.id!r}"
            raise ValueError(msg)
        seen.add(c.id)
    return cases
