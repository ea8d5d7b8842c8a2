"""Shared click options: every command spells the same idea the same way.

Output, overwrite, format, verbosity and debug are declared once here; a command
stacks the decorators it needs.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

FORMATS = ("arrows", "parquet", "arrow", "hdf5")


def _positive(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    if value is not None and not value > 0:
        msg = f"must be > 0, not {value}"
        raise click.BadParameter(msg)
    return value


def _float_list(ctx: click.Context, param: click.Parameter, value: str | None) -> list[float] | None:
    if value is None:
        return None
    try:
        return [float(v) for v in value.split(",") if v.strip()]
    except ValueError:
        msg = f"expected numbers separated by commas, not {value!r}"
        raise click.BadParameter(msg) from None


def _name_list(ctx: click.Context, param: click.Parameter, value: str | None) -> list[str] | None:
    if value is None:
        return None
    names = [v.strip() for v in value.split(",") if v.strip()]
    if not names:
        msg = "expected names separated by commas"
        raise click.BadParameter(msg)
    return names


positive = _positive
float_list = _float_list
name_list = _name_list

input_arg = click.argument("input", required=False, default=None, metavar="[INPUT]",
                           type=click.Path(dir_okay=False, allow_dash=True))
output = click.option("-o", "--output", default=None, metavar="PATH",
                      type=click.Path(allow_dash=True),
                      help="Write to PATH (format from its extension); default stdout.")
force = click.option("--force", is_flag=True, default=False,
                     help="Replace an existing output file.")
out_format = click.option("--format", "fmt", type=click.Choice(FORMATS), default=None,
                          help="Output format (default: from -o's extension; arrows on stdout).")
rig = click.option("--rig", default=None, metavar="NAME|PATH", envvar="ENC_RIG",
                   help="Rig: a bundled name (sjtu-dual, ciomp-23bit) or a rig file.")


def verbosity(f: Callable[..., Any]) -> Callable[..., Any]:
    """-v/-q (counted) and --debug, consumed by the command runner."""
    f = click.option("-v", "--verbose", count=True, help="More messages on stderr (-vv: more).")(f)
    f = click.option("-q", "--quiet", count=True, help="Fewer messages: errors only.")(f)
    f = click.option("--debug", is_flag=True, default=False, envvar="ENC_DEBUG",
                     help="Show a traceback on errors.")(f)
    return f


def outputs(f: Callable[..., Any]) -> Callable[..., Any]:
    """-o/--output, --force, --format."""
    return output(force(out_format(f)))
