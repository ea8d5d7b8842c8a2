"""Every example of every man page runs as written.

Each page's EXAMPLES section is read from its roff source: every ``.EX``/``.EE`` block,
in order. A block is a shell script unless the roff comment line just before its ``.EX``
says otherwise (the comment is invisible in the rendered page)::

    .\\" example: file NAME      the block is the text of the file NAME, which later
                                blocks of the page use (a rig file, a certificate)
    .\\" example: python         the block is Python, run after the page's earlier Python
                                blocks (as in one interpreter session)
    .\\" example: status N       a shell script whose documented ending is exit status N
    .\\" example: skip REASON    not run (a crontab line); the reason is listed by the test

A page's blocks run top to bottom in a fresh folder that holds only the repository's
``tests/`` and ``examples/`` (and this environment's ``enc`` on PATH), each shell block
with ``bash -e -o pipefail``. A block fails on an exit status other than the one it
documents, and on any "internal error" or traceback on stderr. So a page's examples make
their own inputs, or name a file of examples/ or tests/data, and never reach outside.
"""

from __future__ import annotations

import re
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import ROOT, run

MAN = ROOT / "man"
PAGES = sorted(p.name for p in MAN.glob("*.[15]"))
DIRECTIVE = re.compile(r'^\.\\"\s*example:\s*(\w+)\s*(.*?)\s*$')
#: roff escapes that the pages' examples use, and the characters they stand for
ESCAPES = {r"\-": "-", r"\(dq": '"', r"\(aq": "'", r"\(ga": "`", r"\(ti": "~",
           r"\(ha": "^", r"\(en": "\u2013", r"\&": "", r"\e": "\\"}
KINDS = ("sh", "file", "python", "status", "skip")


@dataclass(frozen=True)
class Block:
    """One example: its kind, the kind's argument, its text as a reader types it."""

    page: str
    kind: str
    arg: str
    text: str

    @property
    def commands(self) -> int:
        """The commands a reader types in this block (continued lines count once)."""
        if self.kind not in ("sh", "status"):
            return 0
        joined = re.sub(r"(\\|\|)\n", " ", self.text)
        return sum(1 for line in joined.splitlines() if line.strip())


def unescape(line: str) -> str:
    """A line of roff as the page shows it."""
    for escape, char in ESCAPES.items():
        line = line.replace(escape, char)
    return line


def examples(page: str) -> list[Block]:
    """The example blocks of a man page's EXAMPLES section, in order."""
    lines = (MAN / page).read_text().splitlines()
    blocks: list[Block] = []
    inside = section = False
    kind, arg, body = "sh", "", []
    for i, line in enumerate(lines):
        if line.startswith(".SH"):
            section = line.split(None, 1)[-1].strip('"') == "EXAMPLES"
        elif section and line == ".EX":
            inside, body = True, []
            m = DIRECTIVE.match(lines[i - 1])
            kind, arg = (m.group(1), m.group(2)) if m else ("sh", "")
            assert kind in KINDS, f"{page}: unknown example kind {kind!r}"
        elif inside and line == ".EE":
            inside = False
            blocks.append(Block(page, kind, arg, "\n".join(body) + "\n"))
        elif inside:
            body.append(unescape(line))
    return blocks


def all_blocks() -> list[Block]:
    return [b for page in PAGES for b in examples(page)]


def test_the_examples_are_found_and_counted():
    """The count printed here is the README's "Examples are tested" figure."""
    blocks = all_blocks()
    by_kind = {k: sum(1 for b in blocks if b.kind == k) for k in KINDS}
    commands = sum(b.commands for b in blocks)
    skipped = [f"{b.page}: {b.arg}" for b in blocks if b.kind == "skip"]
    print(f"{len(blocks)} example blocks in {len(PAGES)} pages, {commands} commands; "
          f"by kind {by_kind}; skipped: {skipped}")
    assert len(blocks) >= 60 and commands >= 100
    assert all(b.arg for b in blocks if b.kind in ("file", "status", "skip"))
    pages_with_examples = {b.page for b in blocks}
    assert {p for p in PAGES if p.endswith(".1")} <= pages_with_examples


def test_no_example_reaches_outside_the_repository():
    """A reader has the installed package and the repository's tests/ and examples/."""
    for b in all_blocks():
        if b.kind in ("sh", "status", "python"):
            assert "../" not in b.text, f"{b.page}: {b.text}"
            assert not re.search(r"(^|\s)/(var|etc|home|tmp)/", b.text), f"{b.page}: {b.text}"


def test_no_python_example_ends_the_session_early():
    """A page's Python blocks run as one session, each after the ones before it: a block
    that exits (os._exit, sys.exit) would end the session before the later blocks run,
    and their test would pass without running them."""
    ending = re.compile(r"\b(os\._exit|sys\.exit|exit|quit)\s*\(")
    for b in all_blocks():
        if b.kind == "python":
            assert not ending.search(b.text), f"{b.page}: {b.text}"


def _stage(folder: Path) -> None:
    """A fresh folder as a reader has it: the repository's tests/ and examples/."""
    (folder / "tests").symlink_to(ROOT / "tests")
    shutil.copytree(ROOT / "examples", folder / "examples")


def _run_block(b: Block, folder: Path, n: int, session: list[str]) -> None:
    """Run one example block in ``folder``; ``session``: the page's Python so far."""
    if b.kind == "skip":
        return
    if b.kind == "file":
        (folder / b.arg).write_text(b.text)
        return
    if b.kind == "python":
        session.append(b.text)
        script = folder / f".example-{n}.py"
        script.write_text("\n".join(session))
        r = run([sys.executable, str(script)], cwd=folder)
        expected = 0
    else:
        script = folder / f".example-{n}.sh"
        script.write_text("set -e -o pipefail\n" + b.text)
        r = run(["bash", str(script)], cwd=folder, env={"HOME": str(folder)})
        expected = int(b.arg) if b.kind == "status" else 0
    err = r.stderr.decode(errors="replace")
    where = f"{b.page}, example {n + 1}:\n{b.text}\nstderr:\n{err[-3000:]}"
    assert r.returncode == expected, f"exit {r.returncode}, documented {expected}: {where}"
    assert "internal error" not in err and "Traceback" not in err, where


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if examples(p)])
def test_every_example_of_the_page_runs(page: str, tmp_path: Path) -> None:
    _stage(tmp_path)
    session: list[str] = []
    for n, b in enumerate(examples(page)):
        _run_block(b, tmp_path, n, session)


def _without_opening_comment(text: str) -> list[str]:
    lines = text.splitlines()
    return lines[next(i for i, line in enumerate(lines) if not line.startswith("#")):]


def test_the_example_rigs_are_the_bundled_rig_but_for_what_they_say():
    """examples/rigs/*.toml: the bundled rig they name in their first comment, but for the
    comment, the name and one setting (kept in step when the bundled rig changes)."""
    for path in sorted((ROOT / "examples" / "rigs").glob("*.toml")):
        body = _without_opening_comment(path.read_text())
        named = re.search(r"\(enc rig show (\S+?)\)", path.read_text())
        assert named, f"{path}: its comment names no bundled rig"
        bundled = _without_opening_comment(
            (ROOT / "enctools" / "rigs" / f"{named.group(1)}.toml").read_text())
        assert len(body) == len(bundled), path
        changed = [(a, b) for a, b in zip(bundled, body, strict=True) if a != b]
        assert len(changed) == 2 and changed[0][1] == f'name = "{path.stem}"', (path, changed)
