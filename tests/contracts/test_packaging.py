"""The declared minimum versions are the ones `make test-min` installs and tests."""

from __future__ import annotations

import tomllib

from conftest import ROOT
from packaging.requirements import Requirement
from packaging.version import Version


def _floors() -> dict[str, Version]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    floors = {}
    for line in project["dependencies"] + project["optional-dependencies"]["test"]:
        req = Requirement(line)
        lower = [Version(s.version) for s in req.specifier if s.operator == ">="]
        assert len(lower) == 1, f"{line}: give one floor (>=)"
        floors[req.name.lower()] = lower[0]
    return floors


def _pins() -> dict[str, Version]:
    pins = {}
    for line in (ROOT / "tests" / "min-versions.txt").read_text().splitlines():
        if line.strip() and not line.startswith("#"):
            name, _, version = line.partition("==")
            pins[name.strip().lower()] = Version(version.strip())
    return pins


def test_every_floor_is_pinned_for_the_minimum_versions_run():
    floors, pins = _floors(), _pins()
    assert set(pins) == set(floors)
    wrong = {name: (str(floors[name]), str(pins[name])) for name in floors
             if pins[name] != floors[name]}
    assert not wrong, f"floor, pin: {wrong}"
