"""docs/ARCHITECTURE.md names only what exists: every module, file, function, class and
constant it cites between backticks is found in the code, so the map cannot drift."""

from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

import pytest

# one worker reads the code once for both tests (_definitions is cached per process)
pytestmark = pytest.mark.xdist_group("architecture_doc")

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "enctools"
DOC = ROOT / "docs" / "ARCHITECTURE.md"

#: words the page puts between backticks that are not names in the code
NOT_CODE = {
    "slow",        # the pytest marker of the long tests
    "core",        # the layer of enctools/*.py
    "pa.array",    # pyarrow's, named for what the code avoids
    "numpy.ma",    # numpy's
    "cat", "dd",   # the Unix commands the benchmarks compare against
    "rig=NAME/year=YYYY",  # the folders of the history, not of the project
    "subprocess",  # the standard library's
}
#: names the page cites as what the code had before a change (the "before" of a worked
#: example): each must be gone from the code
GONE = {"INSTRUMENT_KINDS", "BACKENDS"}
#: where a file the page names may be, relative to its layer or the project
BASES = (ROOT, PACKAGE, *(p for p in PACKAGE.rglob("*") if p.is_dir()), ROOT / "tests",
         *(p for p in (ROOT / "tests").glob("*/**") if p.is_dir()), ROOT / "benchmarks")


def _definitions() -> tuple[set[str], set[str]]:
    """Every module (last dotted part and whole dotted path) and every name defined at
    any level of a module, class or function of the package or its tests (defs, classes,
    assignments, annotated fields), and every string constant that is an identifier (a
    backend's kind, a rig key)."""
    modules: set[str] = set()
    names: set[str] = set()
    for path in [*PACKAGE.rglob("*.py"), *(ROOT / "tests").rglob("*.py")]:
        if path.resolve() == Path(__file__).resolve():
            continue
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        for i in range(len(parts)):
            modules.add(".".join(parts[i:]))
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names.add(node.name)
            elif isinstance(node, ast.Assign):
                names.update(t.id for t in node.targets if isinstance(t, ast.Name))
                names.update(t.attr for t in node.targets if isinstance(t, ast.Attribute))
            elif isinstance(node, ast.AnnAssign):
                if isinstance(node.target, ast.Name):
                    names.add(node.target.id)
                elif isinstance(node.target, ast.Attribute):
                    names.add(node.target.attr)
            elif isinstance(node, ast.arg):
                names.add(node.arg)
            elif isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and node.value.isidentifier():
                names.add(node.value)
    return modules, names


_definitions = functools.cache(_definitions)  # read when a test asks, not at collection
IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*(\(\))?$")


def _exists(token: str) -> bool:
    token = token.removesuffix("()")
    if "/" in token or re.search(r"\.(py|md|toml|j2|json|txt|mk|1|5)$", token):
        path = token.rstrip("/")
        if any(c in path for c in "<*="):  # a pattern: its folder must exist
            path = path.rsplit("/", 1)[0]
        for base in BASES:
            if (base / path).exists() or (base / f"{path}.py").exists():
                return True
        if "/" in path and "." in path.rsplit("/", 1)[1]:  # cli/options.table_columns
            module, name = path.rsplit(".", 1)
            return any((b / f"{module}.py").exists() for b in BASES) and name in _definitions()[1]
        return False
    modules, names = _definitions()
    if token in modules or token in names:
        return True
    parts = token.split(".")
    # module.name, Class.attribute, module.module.name: every part found as a module
    # or a name, the first as a module or a class
    return all(p in modules or p in names for p in parts)


def cited() -> list[tuple[int, str]]:
    """(line, token) for each code-like backticked token of the page."""
    found = []
    in_code = False
    for n, line in enumerate(DOC.read_text(encoding="utf-8").splitlines(), 1):
        if line.startswith("```"):
            in_code = not in_code
            continue
        if in_code:
            continue
        for token in re.findall(r"`([^`]+)`", line):
            token = token.strip()
            if token in NOT_CODE or token in GONE or token.startswith(("-", "enc ", "make ", "$")):
                continue
            if ("/" in token and " " not in token) or IDENT.match(token):
                found.append((n, token))
    return found


def test_the_page_cites_names_at_all():
    assert len(cited()) > 100


@pytest.mark.heavy
def test_every_name_the_page_cites_exists():
    missing = [f"line {n}: `{t}`" for n, t in cited() if not _exists(t)]
    assert not missing, "docs/ARCHITECTURE.md cites what the code does not have:\n" + \
        "\n".join(missing)


@pytest.mark.heavy
def test_what_the_page_says_is_gone_is_gone():
    back = sorted(t for t in GONE if t in _definitions()[1])
    assert not back, f"the page cites as gone what the code still defines: {back}"
