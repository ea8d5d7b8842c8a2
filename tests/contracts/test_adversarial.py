"""The adversarial catalogue (tests/adversarial/cases/*.toml): every hostile case in a child
process with a timeout, its peak memory measured (under 500 MB), its exit status, files
and error line checked (tests/adversarial/runner.py).

A case marked ``pending`` is a known failure, expected to fail (strict): when the fix
lands it passes, the test fails loudly, and the marker is to be deleted from its row.
The cases spawn many processes: marked slow (``make test-slow``), as is the check of the
runner's fork against exec; the checks of the catalogue itself are not.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import pytest
from adversarial import builders, catalogue, runner
from conftest import made_once

from enctools.errors import ending_signal_numbers

CASES = catalogue.load()
#: the rows written one by one here; the matrices' rows run in test_adversarial_matrix.py
#: (two files, one for the rows a person wrote, one for the rows the matrices make)
ROWS = [c for c in CASES if not c.matrix]


def _param(case: catalogue.Case) -> object:
    marks = [pytest.mark.slow]
    if case.pending:
        strict = not case.pending.startswith("intermittent:")
        marks.append(pytest.mark.xfail(strict=strict, reason=f"pending: {case.pending}"))
    return pytest.param(case, id=case.id, marks=marks)


def _make_base(path: Path) -> None:
    part = path.with_name(path.name + ".part")
    shutil.rmtree(part, ignore_errors=True)
    builders.make_base(part)
    part.rename(path)


@pytest.fixture(scope="session")
def base(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return made_once(tmp_path_factory, "adversarial-base", _make_base)


def run_case(case: catalogue.Case, base: Path, tmp_path: Path, record_property) -> None:
    """Build the case's inputs, run it, record its figures, check its promises."""
    folder = tmp_path / "case"
    folder.mkdir()
    try:
        builders.build(folder, base, case.setup)
    except builders.Unsupported as exc:
        builders.unmount_all(folder)
        pytest.skip(str(exc))
    try:
        _run_and_check(case, base, folder, record_property)
    finally:
        builders.unmount_all(folder)


def _run_and_check(case: catalogue.Case, base: Path, folder: Path, record_property) -> None:
    before = runner.snapshot(folder)
    kept = runner.digests(folder, case.unchanged)
    r = runner.run(case, folder, base)
    record_property("adv_id", case.id)
    record_property("adv_category", case.category)
    record_property("adv_peak_mb", round(r.peak_mb, 1))
    record_property("adv_seconds", round(r.seconds, 2))
    record_property("adv_cpu_s", round(r.cpu_s, 2))
    bad = runner.problems(case, r, folder, before, kept, base)
    assert not bad, (f"{case.id} ({case.source}): " + "; ".join(bad)
                     + f"\nexit {r.code}, {r.seconds:.1f} s, {r.peak_mb:.0f} MB"
                     + f"\nstderr: {r.stderr.decode('utf-8', 'replace')[-2000:]}")


@pytest.mark.parametrize("case", [_param(c) for c in ROWS])
def test_case(case: catalogue.Case, base: Path, tmp_path: Path, record_property) -> None:
    run_case(case, base, tmp_path, record_property)


# ------------------------------------------------------------------ the catalogue itself

def test_every_row_is_well_formed() -> None:
    """Ids unique (load checks), builders known, categories from the documented list."""
    known = {"inputs", "options", "rigs", "outputs", "signals", "devices", "injection",
             "terminal", "metadata", "fuzz"}
    for c in CASES:
        assert c.category in known, c.id
        for step in c.setup:
            assert step["use"] in builders.BUILDERS, (c.id, step)
        # the documented statuses: 0-3, and 128 + a signal's number (enc(1), EXIT STATUS)
        assert all(code in (0, 1, 2, 3) or code - 128 in ending_signal_numbers()
                   for code in c.exit), c.id
    assert len(CASES) >= 250


def test_every_command_is_in_the_catalogue() -> None:
    from enctools.cli.main import COMMANDS

    argv0 = {(c.argv or ["", ""])[1] for c in CASES if c.argv and c.argv[0] == "enc"}
    missing = set(COMMANDS) - argv0
    assert not missing, f"commands without an adversarial case: {sorted(missing)}"
    assert any(c.argv and c.argv[0] == "enc-nightly" for c in CASES)


def test_peak_memory_is_the_commands_own_not_the_test_processs(tmp_path: Path) -> None:
    """A command's peak is measured in a small process (adversarial/peak.py): a test
    process grown to 300 MB does not show in it, and 300 MB the command allocates
    does; the command's exit status and a signal's death come back as they were."""
    ballast = bytearray(300 << 20)  # the test process's own memory, touched
    ballast[::4096] = b"x" * len(ballast[::4096])

    def case(script: str) -> catalogue.Case:
        return catalogue.Case(id="peak", category="outputs", argv=[sys.executable, "-c", script],
                              source="test", why="the runner's own measurement")

    small = runner.run(case("pass"), tmp_path, tmp_path)
    big = runner.run(case("b = bytearray(300 << 20); b[::4096] = b'x' * len(b[::4096])\n"
                          "raise SystemExit(3)"), tmp_path, tmp_path)
    killed = runner.run(case("import os, signal; os.kill(os.getpid(), signal.SIGTERM)"),
                        tmp_path, tmp_path)
    del ballast
    assert small.peak_mb < 100 and small.code == 0
    assert big.peak_mb > 300 and big.code == 3
    assert killed.code == -15


#: cases run both ways in test_a_forked_command_is_an_execd_one: one per kind of ending
SAME_EITHER_WAY = ["points-truncated-8", "selfcal-stdin-concatenated", "sigterm-make-rom-force",
                   "report-15mb-description", "make-rom-mif-file-size-limit"]


@pytest.mark.slow  # with the catalogue, whose runner it checks: 14 s of CPU for 5 cases
@pytest.mark.parametrize("case_id", SAME_EITHER_WAY)
def test_a_forked_command_is_an_execd_one(case_id: str, base: Path, tmp_path: Path,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """The zygote (adversarial/zygote.py) forks an ``enc`` command instead of starting
    it: the same case gives the same status and the same error line either way, and
    its peak memory is the command's (within what the zygote's imports add)."""
    case = next(c for c in CASES if c.id == case_id)
    results = []
    for exec_ in ("1", "0"):
        monkeypatch.setenv("ENC_CATALOGUE_EXEC", exec_)
        assert runner.forked(case) is (exec_ == "0")
        folder = tmp_path / f"exec{exec_}"
        folder.mkdir()
        try:
            builders.build(folder, base, case.setup)
            results.append(runner.run(case, folder, base))
        finally:
            builders.unmount_all(folder)
    execd, forked = results
    assert forked.code == execd.code, (execd.stderr, forked.stderr)
    lines = [[ln for ln in r.stderr.decode().splitlines() if "error:" in ln] for r in results]
    assert [ln.split(": ")[:2] for ln in lines[0]] == [ln.split(": ")[:2] for ln in lines[1]]
    assert abs(forked.peak_mb - execd.peak_mb) < 150
