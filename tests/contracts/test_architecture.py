"""The layers of docs/ARCHITECTURE.md, enforced: imports only downward, no cycles, sizes.

Every ``import`` of the library is read from the source (module level and inside
functions alike), so a lazy import cannot hide a wrong direction.
"""

from __future__ import annotations

import ast
import functools
from collections.abc import Iterator
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "enctools"

#: layer -> the layers it may import (itself included). ``core`` is the package's own
#: top-level modules (version, errors, units). hw and methods/models are siblings: the
#: instruments know nothing of the methods and the methods nothing of the instruments.
ALLOWED = {
    "core": {"core"},
    "data": {"core", "data"},
    "methods": {"core", "data", "methods"},
    "models": {"core", "data", "methods", "models"},
    "hw": {"core", "data", "hw"},
    "report": {"core", "data", "methods", "models", "report"},
    "cli": {"core", "data", "methods", "models", "hw", "report", "cli"},
}

MAX_MODULE_LINES = 600
MAX_FUNCTION_LINES = 60


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _layer(module: str) -> str:
    parts = module.split(".")
    if len(parts) > 1 and parts[1] in ALLOWED and (PACKAGE / parts[1]).is_dir():
        return parts[1]
    return "core"


def _resolve(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    if node.level == 0:
        return node.module or ""
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _imports(path: Path) -> set[str]:
    """The enctools modules ``path`` imports (``from enctools.data import streams``
    counts as enctools.data.streams when that is a module)."""
    module = _module_name(path)
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("enctools"))
        elif isinstance(node, ast.ImportFrom):
            target = _resolve(node, module, path.name == "__init__.py")
            if not target.startswith("enctools"):
                continue
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                found.add(sub if sub in MODULES else target)
    found.discard(module)
    return found


FILES = sorted(PACKAGE.rglob("*.py"))
MODULES = {_module_name(p) for p in FILES}


@functools.cache
def graph() -> dict[str, set[str]]:
    """module -> the enctools modules it imports (read when a test asks, not at
    collection: every worker collects)."""
    return {_module_name(p): _imports(p) for p in FILES}


@pytest.mark.heavy
def test_every_import_points_down_the_layers():
    wrong = [f"{src} ({_layer(src)}) imports {dst} ({_layer(dst)})"
             for src, targets in graph().items() for dst in sorted(targets)
             if _layer(dst) not in ALLOWED[_layer(src)]]
    assert not wrong, "\n".join(wrong)


@pytest.mark.heavy
def test_the_layer_test_can_fail():
    # the rules themselves: a method may not reach the instruments nor the commands
    assert "hw" not in ALLOWED["methods"] and "cli" not in ALLOWED["report"]
    assert _layer("enctools.methods.selfcal") == "methods"
    assert _layer("enctools.errors") == "core"
    assert "enctools.data.streams" in graph()["enctools.methods.heads"]


@pytest.mark.heavy
def test_no_import_cycles():
    # Package __init__ modules are left out: importing enctools.hw.sim runs
    # enctools/hw/__init__.py first, which is not an edge of the design.
    whole = graph()
    edges = {m: {t for t in ts if t in whole and not (PACKAGE.parent / (t.replace(".", "/"))
                                                      / "__init__.py").exists()}
             for m, ts in whole.items()}
    state: dict[str, int] = {}
    cycles: list[str] = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 1:
                cycles.append(" -> ".join(stack[stack.index(nxt):] + [node, nxt])
                              if nxt in stack else f"{node} -> {nxt}")
            elif nxt not in state:
                visit(nxt, stack + [node])
        state[node] = 2

    for m in sorted(edges):
        if m not in state:
            visit(m, [])
    assert not cycles, "\n".join(cycles)


def functions(tree: ast.Module) -> Iterator[ast.FunctionDef | ast.AsyncFunctionDef]:
    """Every function of a module, nested ones too: the statements' blocks walked, not
    their expressions, where no ``def`` can stand (ast.walk's every node: 8x the time)."""
    stack: list[ast.AST] = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            yield node
        for block in ("body", "orelse", "finalbody", "handlers", "cases"):
            stack.extend(getattr(node, block, ()))


def test_functions_finds_every_def_ast_walk_finds():
    """Nested in a class, a function, a branch, a loop, a with, a try, a match."""
    src = ("class A:\n    def m(self):\n        def inner(): pass\n"
           "if x:\n    pass\nelse:\n    async def b(): pass\n"
           "for i in y:\n    pass\nelse:\n    def c(): pass\n"
           "with z:\n    while w:\n        def d(): pass\n"
           "try:\n    pass\nexcept E:\n    def e(): pass\nfinally:\n    def f(): pass\n"
           "match v:\n    case 1:\n        def g(): pass\n")
    want = {n.name for n in ast.walk(ast.parse(src))
            if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)}
    assert want == {"m", "inner", "b", "c", "d", "e", "f", "g"}
    assert {n.name for n in functions(ast.parse(src))} == want


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_modules_and_functions_stay_small(path: Path):
    text = path.read_text()
    lines = text.count("\n")
    assert lines <= MAX_MODULE_LINES, f"{path.name}: {lines} lines"
    long = [f"{node.name} ({node.end_lineno - node.lineno + 1} lines)"
            for node in functions(ast.parse(text))
            if node.end_lineno is not None
            and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]
    assert not long, f"{path.name}: " + ", ".join(long)
