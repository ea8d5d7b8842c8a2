"""Every command spells the same idea the same way (STYLE.md): one flag, one metavar."""

from __future__ import annotations

import click
import pytest

from enctools.cli.main import _available, cli


def _params(name: str) -> list[click.Option]:
    cmd = cli.get_command(click.Context(cli), name)
    assert cmd is not None
    return [p for p in cmd.params if isinstance(p, click.Option) and not p.hidden]


ALL = [(name, p) for name in _available() for p in _params(name)]

#: flags that once meant the same idea as another flag, or two ideas at once
RETIRED = {"--nmax": "--band", "--harmonics": "--band or --top", "--check": "--max-<figure>",
           "--reference-harmonics": "--reference-band"}


@pytest.mark.parametrize("flag, metavar", [("--band", "K"), ("--heads", "H1,H2,..."),
                                           ("--spectrum", "FILE"), ("--top", "N"),
                                           ("--points", "M")])
def test_shared_option_has_one_metavar(flag, metavar):
    users = [(name, p) for name, p in ALL if flag in p.opts]
    assert users, flag
    for name, p in users:
        assert p.metavar == metavar, f"enc {name} {flag} shows {p.metavar}, not {metavar}"


def test_references_are_spelt_one_way():
    """A reference a command measures against is --reference (a head of the scale
    calibrated is selfcal's --ref-head); --ref alone is an old spelling, hidden."""
    for name, p in ALL:
        if "--reference" in p.opts:
            assert p.opts[0] in ("--ref", "--reference"), f"enc {name}: {p.opts}"
    for name in ("selfcal", "compare", "latency", "interp-check", "correct"):
        assert not [p for p in _params(name) if "--ref" in p.opts], name


def test_retired_spellings_are_gone():
    for name, p in ALL:
        for flag, now in RETIRED.items():
            assert flag not in p.opts, f"enc {name} {flag}: use {now}"


def test_thresholds_are_max_figure_numbers():
    for name, p in ALL:
        flag = p.opts[0]
        # --max-entries, --max-candidates: counts that bound the work, not a figure's threshold
        if flag.startswith("--max-") and not p.multiple and flag not in ("--max-entries",
                                                                          "--max-candidates"):
            assert isinstance(p.type, click.types.FloatParamType), f"enc {name} {flag}"
            assert p.metavar in ("ARCSEC", "NM"), f"enc {name} {flag}: {p.metavar}"
            with pytest.raises(click.BadParameter):
                p.process_value(click.Context(cli), -1.0)


@pytest.mark.parametrize("cmd", ["selfcal --band 2000000", "selfcal --points 1000000000",
                                 "compare --device H1 --reference H2 --points 1000000000",
                                 "design --angles 0,60,135,228 --band 1000000000",
                                 "average-heads --band 1000000000", "report --band 2000000"])
def test_absurd_orders_and_grids_are_usage_errors(cmd, tmp_path):
    """Not a MemoryError after reading the input: refused while parsing the options."""
    from conftest import run_in_process

    out = tmp_path / "o.parquet"
    r = run_in_process(f"enc {cmd} -o {out}" if "design" not in cmd and "report" not in cmd
                       else f"enc {cmd}")  # stdin: /dev/null
    err = r.stderr.decode()
    assert r.returncode == 2 and err.startswith(f"enc {cmd.split()[0]}: error:"), err
    assert err.count("\n") == 1 and "1048576" in err, err
    assert not out.exists()
