"""Man pages: one per command, every option documented, rendered by man without warnings."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import click
import pytest

from enctools.cli.main import COMMANDS, _available, cli

MAN = Path(__file__).resolve().parents[2] / "man"
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


def test_every_page_is_installed_with_the_package():
    """pyproject's shared-data puts each page in share/man/manN of the environment."""
    import tomllib

    project = tomllib.loads((MAN.parent / "pyproject.toml").read_text())
    shared = project["tool"]["hatch"]["build"]["targets"]["wheel"]["shared-data"]
    assert shared == {f"man/{p.name}": f"share/man/man{p.suffix[1:]}/{p.name}" for p in PAGES}


@pytest.mark.skipif(shutil.which("man") is None, reason="man is not installed")
@pytest.mark.parametrize("section,name", [("1", "enc"), ("1", "enc-selfcal"),
                                          ("5", "enc-streams"), ("5", "enc-rig")])
def test_man_finds_the_installed_pages_from_path(section, name):
    """`man enc` with the environment's bin on PATH opens enctools' page, not another enc."""
    import sys

    bindir = Path(sys.executable).parent
    r = subprocess.run(["man", "-w", section, name], capture_output=True, timeout=60,
                       env={"PATH": f"{bindir}:/usr/bin:/bin", "LC_ALL": "C.UTF-8"})
    assert r.returncode == 0, r.stderr.decode()
    found = Path(r.stdout.decode().strip())
    assert found == Path(sys.prefix) / "share" / "man" / f"man{section}" / f"{name}.{section}"
    assert found.read_bytes() == (MAN / f"{name}.{section}").read_bytes()


def test_every_rig_key_is_described_in_enc_rig():
    """Each key a rig file may hold is described in enc-rig(5) above LIMITS (the table of
    ranges alone does not say what a key means: speed_error_ppm once had only its range)."""
    import re

    from enctools.data.rig import _SPEC

    text = (MAN / "enc-rig.5").read_text().replace("\\-", "-").replace("\\&", "")
    body = text.split(".SH LIMITS")[0]
    missing = [f"{table}.{key}".lstrip(".") for table, keys in _SPEC.items() for key in keys
               if not re.search(rf"(?m)^\.(B|BR|BI|RB|IR|SH|SS)\b.*\b{re.escape(key)}\b", body)]
    assert not missing, f"enc-rig(5) does not describe {', '.join(missing)}"


def test_every_key_the_rig_loaders_accept_is_in_enc_rig():
    """What the loaders accept beyond the general tables: every key with a range, type or
    choice in data/riglimits.py, and every key of the backends' own tables (the
    simulator's, VISA and serial dialogues, NI-DAQmx), is described in enc-rig(5) above
    LIMITS; a key with a range is also in its LIMITS table."""
    import re

    from enctools.data import riglimits
    from enctools.hw import dialogue, nidaq

    text = (MAN / "enc-rig.5").read_text().replace("\\-", "-").replace("\\&", "")
    body, limits = text.split(".SH LIMITS")[0], text.split(".SH LIMITS")[1]
    keys = {k: "riglimits" for d in (riglimits.RANGES, riglimits.ARRAYS, riglimits.CHOICES,
                                     riglimits.LEAST) for k in d}
    backends = {"dialogue": (dialogue.backend_keys(), dialogue.instrument_keys(),
                             dialogue.COUNTER_KEYS, dialogue.SENSOR_KEYS, dialogue.MOTION_KEYS),
                "nidaq": (nidaq.COUNTER_KEYS, nidaq.HEAD_KEYS),
                "sim": ({"kind", "seed", "realtime"},)}
    for where, sets in backends.items():
        keys.update({f"backend.{k}": where for keyset in sets for k in keyset})
    described = [k for k in keys
                 if re.search(rf"(?m)^\.(B|BR|BI|RB|IR|SH|SS)\b.*\b{re.escape(k.split('.')[-1])}\b",
                              body)]
    assert sorted(set(keys) - set(described)) == []
    assert [k for k in riglimits.RANGES if k not in limits] == []
