"""Man pages: one per command, every option documented, rendered by man without warnings."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import click
import pytest

from enctools.cli.main import COMMANDS, _available, cli

MAN = Path(__file__).resolve().parent.parent / "man"
PAGES = sorted(MAN.glob("*.[15]"))


def _command(name: str) -> click.Command:
    ctx = click.Context(cli)
    cmd = cli.get_command(ctx, name)
    assert cmd is not None
    return cmd


@pytest.mark.parametrize("name", _available())
def test_every_option_is_in_the_page(name):
    page = MAN / f"enc-{name}.1"
    assert page.exists(), f"enc {name} has no man page {page.name}"
    text = page.read_text()
    missing = []
    for p in _command(name).params:
        if isinstance(p, click.Option):
            for opt in p.opts + p.secondary_opts:
                if opt.replace("-", r"\-") not in text:
                    missing.append(opt)
    assert not missing, f"{page.name} does not document {', '.join(missing)}"
    for section in ("NAME", "SYNOPSIS", "DESCRIPTION", "OPTIONS", "EXIT STATUS",
                    "ENVIRONMENT", "FILES", "EXAMPLES", "SEE ALSO"):
        assert f".SH {section}" in text, f"{page.name} lacks {section}"


def test_enc_page_lists_every_command():
    text = (MAN / "enc.1").read_text()
    for name in COMMANDS:
        assert f".B {name.replace('-', chr(92) + '-')}" in text, name


@pytest.mark.skipif(shutil.which("man") is None, reason="man is not installed")
@pytest.mark.parametrize("page", PAGES, ids=[p.name for p in PAGES])
def test_page_renders_without_warnings(page):
    r = subprocess.run(["man", "--warnings", "-l", str(page)], capture_output=True,
                       env={"MANWIDTH": "80", "LC_ALL": "C.UTF-8", "PATH": "/usr/bin:/bin"},
                       timeout=60)
    assert r.returncode == 0
    assert r.stderr.decode().strip() == "", r.stderr.decode()
    assert len(r.stdout) > 500
