"""Shared click options: every command spells the same idea the same way.

Output, overwrite, format, verbosity and debug are declared once here; a command
stacks the decorators it needs.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import Any

import click

from enctools.cli import runner
from enctools.cli.completion import complete_heads, complete_rig
from enctools.units import DISPLAY_UNITS

FORMATS = ("arrows", "parquet", "arrow", "hdf5", "csv", "tsv")


class Text(click.types.StringParamType):
    """The value of a text option (a name, a title: no file name), refused when it holds a
    byte that is not UTF-8 (an argument given in Latin-1): the byte is named, escaped
    (``\\xe9``). A file name (``click.Path``) takes any bytes the file system does."""

    name = "text"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None
                ) -> Any:
        value = super().convert(value, param, ctx)
        if isinstance(value, str) and any("\udc80" <= ch <= "\udcff" for ch in value):
            from enctools.data.text import printable

            bad = next(ch for ch in value if "\udc80" <= ch <= "\udcff")
            self.fail(f"'{printable(value)}' holds the byte {printable(bad)}, which is not "
                      "UTF-8 text", param, ctx)
        return value


def text_options(command: click.Command) -> None:
    """Every text option and argument of ``command`` (and of its subcommands) a
    :class:`Text`: a string that is no file name (not ``click.Path``, no FILE, PATH or
    DIR in its metavar)."""
    for sub in getattr(command, "commands", {}).values():
        text_options(sub)
    for p in command.params:
        metavar = getattr(p, "metavar", None) or ""
        if type(p.type) is click.types.StringParamType and not any(
                word in metavar for word in ("FILE", "PATH", "DIR")):
            p.type = Text()


def _positive(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    if value is not None and not value > 0:
        msg = f"must be > 0, not {value}"
        raise click.BadParameter(msg)
    return value


def _float_list(ctx: click.Context, param: click.Parameter,
                value: str | None) -> list[float] | None:
    if value is None:
        return None
    try:
        numbers = [float(v) for v in value.split(",") if v.strip()]
    except ValueError:
        msg = f"expected numbers separated by commas, not {value!r}"
        raise click.BadParameter(msg) from None
    if not numbers:
        msg = f"expected numbers separated by commas, not {value!r}"
        raise click.BadParameter(msg)
    if not all(math.isfinite(v) for v in numbers):
        msg = f"expected finite numbers, not {value!r}"
        raise click.BadParameter(msg)
    return numbers


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
                   shell_complete=complete_rig,
                   help="Rig: a bundled name (sjtu-dual, ciomp-23bit) or a rig file.")


def verbosity(f: Callable[..., Any]) -> Callable[..., Any]:
    """-v/-q (counted) and --debug, then the prologue every command shares.

    The command function receives none of the three: :func:`runner.prologue` sets the
    logging from -v/-q, tunes the process for streaming and turns SIGTERM into a clean
    stop before the command's body runs; --debug is read by the driver (``enc --debug``
    or ``ENC_DEBUG``) before any command starts.
    """
    @functools.wraps(f)
    def with_prologue(*args: Any, verbose: int, quiet: int, debug: bool, **kwargs: Any) -> Any:
        runner.prologue(verbose, quiet)
        return f(*args, **kwargs)

    g: Callable[..., Any] = with_prologue
    g = click.option("-v", "--verbose", count=True, help="More messages on stderr (-vv: more).")(g)
    g = click.option("-q", "--quiet", count=True, help="Fewer messages: errors only.")(g)
    g = click.option("--debug", is_flag=True, default=False, envvar="ENC_DEBUG",
                     help="Show a traceback on errors.")(g)
    return g


def outputs(f: Callable[..., Any]) -> Callable[..., Any]:
    """-o/--output, --force, --format. A command's --unit (:data:`unit`) is also the unit of
    the angle errors of a CSV or TSV output: the command passes it to what it writes
    (``streams.write_table(..., unit=unit)``)."""
    return output(force(out_format(f)))


# Ideas several commands share: one spelling, one metavar, one check.

def non_negative(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    """Callback: a threshold or a count that may be 0 but not negative (nor NaN)."""
    if value is not None and not value >= 0:
        msg = f"must be >= 0, not {value}"
        raise click.BadParameter(msg)
    return value


def finite(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
    """Callback: any finite number (an angle, an offset), not NaN nor infinity."""
    if value is not None and not math.isfinite(value):
        msg = f"must be a finite number, not {value}"
        raise click.BadParameter(msg)
    return value


def bounded(lo: float, hi: float, low_open: bool = False,
             unit: str = "") -> Callable[[click.Context, click.Parameter, Any], Any]:
    """Callback: a finite number in lo..hi (bounds included; with ``low_open`` above lo).

    The range is stated once, here in the option, and the error names it.
    """
    def fmt(v: float) -> str:
        return str(int(v)) if float(v).is_integer() and abs(v) < 1e16 else f"{v:g}"

    def check(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
        if value is None:
            return value
        ok = math.isfinite(value) and (lo < value if low_open else lo <= value) and value <= hi
        if not ok:
            span = f"> {fmt(lo)} and <= {fmt(hi)}" if low_open else f"{fmt(lo)}..{fmt(hi)}"
            msg = f"must be {span}{unit}, not {value}"
            raise click.BadParameter(msg)
        return value

    return check


def distinct_outputs(paths: dict[str, str | None]) -> None:
    """UsageError when two outputs of one command name the same file (``--html X --pdf X``
    would leave only the last written). ``paths``: option -> path; None and ``-`` (stdout)
    are left out, as are two paths that only differ by spelling the same file."""
    import os

    from enctools.cli.usage import UsageError

    seen: dict[str, str] = {}
    for flag, path in paths.items():
        if path is None or path == "-":
            continue
        key = os.path.realpath(path)
        if key in seen:
            msg = f"{seen[key]} and {flag} name the same file {path}; give each output its own"
            raise UsageError(msg)
        seen[key] = flag


def check_curve_outputs(output: str | None, spectrum: str | None, force: bool,
                        fmt: str | None, as_json: bool) -> None:
    """Before any work, the outputs of a command that writes a deviation curve (``-o``)
    and, with ``--spectrum``, its spectrum: distinct files, ``--json`` not on the curve's
    stdout, each writable (UsageError or OutputError)."""
    from enctools.cli import summary
    from enctools.data import streams

    distinct_outputs({"-o": output, "--spectrum": spectrum})
    summary.check_json(as_json, output)
    streams.check_output(output, force, fmt)
    if spectrum is not None:
        streams.check_output(spectrum, force)


def heads(help: str, flag: str = "--heads", dest: str | None = None) -> Callable[..., Any]:
    """A comma-separated list of head (or channel) names, e.g. --heads H1,H2."""
    decls = [flag] if dest is None else [flag, dest]
    return click.option(*decls, default=None, callback=name_list, metavar="H1,H2,...",
                        shell_complete=complete_heads, help=help)


def polygon_run(f: Callable[..., Any]) -> Callable[..., Any]:
    """--heads, --autocollimator and --faces: what a polygon step run is read with (enc
    points, enc closure)."""
    f = click.option("--faces", type=int, default=None, callback=positive,
                     help="Faces of the polygon (default: the rig's).")(f)
    f = click.option("--autocollimator", default=None, metavar="COLUMN",
                     help="Autocollimator column (default: the only one).")(f)
    return heads("Heads averaged into the encoder reading (default: the rig's measuring "
                 "heads).")(f)


def ref(help: str, dest: str = "ref", metavar: str = "HEAD", **kw: Any) -> Callable[..., Any]:
    """--ref (also --reference): the reference a command measures against."""
    if not kw.get("required"):  # a default, even None, would satisfy a required option
        kw.setdefault("default", None)
    kw.setdefault("shell_complete", complete_heads)
    return click.option("--ref", "--reference", dest, metavar=metavar, help=help, **kw)


#: the highest harmonic order, and the most grid points, a command accepts: beyond, its
#: arrays outgrow a workstation's memory (MemoryError) and no rig resolves them anyway
MAX_ORDER = 1 << 20


def band(help: str, default: int | None = 100, dest: str = "band",
         callback: Callable[..., Any] | None = positive) -> Callable[..., Any]:
    """--band K: the highest harmonic order n = 1..K a command fits, keeps or considers."""
    def check(ctx: click.Context, param: click.Parameter, value: Any) -> Any:
        if callback is not None:
            value = callback(ctx, param, value)
        if value is not None and value > MAX_ORDER:
            msg = f"must be <= {MAX_ORDER}, not {value}"
            raise click.BadParameter(msg)
        return value

    return click.option("--band", dest, type=int, default=default, metavar="K",
                        show_default=default is not None, callback=check, help=help)


def points(help: str, default: int, minimum: int = 1) -> Callable[..., Any]:
    """--points M: the points of an output curve's uniform grid."""
    return click.option("--points", type=click.IntRange(minimum, MAX_ORDER), default=default,
                        show_default=True, metavar="M", help=help)


def spectrum(help: str) -> Callable[..., Any]:
    """--spectrum FILE: also write the harmonics as a spectrum stream (format from FILE)."""
    return click.option("--spectrum", "spectrum_path", default=None, metavar="FILE",
                        type=click.Path(dir_okay=False), help=help)


def threshold(flag: str, help: str, dest: str | None = None,
              metavar: str = "ARCSEC") -> Callable[..., Any]:
    """--max-<figure> VALUE: exit 1 (CheckFailed) when the figure exceeds VALUE."""
    decls = [flag] if dest is None else [flag, dest]
    return click.option(*decls, type=float, default=None, callback=non_negative,
                        metavar=metavar, help=help)


def min_transfer(help: str = "Normalised |W(n)| below this is ill-conditioned.") \
        -> Callable[..., Any]:
    """--min-transfer: the normalised |W(n)| under which a harmonic is ill-conditioned."""
    return click.option("--min-transfer", "min_transfer", type=float, default=0.1,
                        show_default=True, callback=positive, help=help)


strict = click.option("--strict", is_flag=True, default=False,
                      help="Exit 2 when the band holds blind or ill-conditioned harmonics.")
unit = click.option("--unit", "unit", type=click.Choice(DISPLAY_UNITS), default=DISPLAY_UNITS[0],
                    envvar="ENC_UNIT", show_default=True,
                    help="Unit of the angle errors a person reads: text, HTML, PDF and CSV "
                         "(JSON and streams keep their documented units).")
as_json = click.option("--json", "as_json", is_flag=True, default=False,
                       help="Print the figures as JSON instead of text.")
json_summary = click.option("--json", "as_json", is_flag=True, default=False,
                            help="Print the summary as JSON on stdout instead of text on "
                                 "stderr (needs -o FILE when the command writes a stream).")


# A user's table (enc-points(1), TABLES): one set of column options for every command
# that takes points, handed to the command as one ``mapping`` (data.tablemap.Mapping).
_TABLE_ROLES = (("position", "the indicated angle (what the encoder reads)"),
                ("reference", "the reference angle (stage, polygon)"),
                ("measured", "the indicated angle beside --reference"),
                ("deviation", "indicated minus reference angle"),
                ("direction", "approach direction, +1 or -1"),
                ("run", "run number"))


#: the old spellings of the reference column's option (a command that reads tables
#: keeps them for one release: ``usage.renamed(options.TABLE_RENAMED)``)
TABLE_RENAMED = {"--ref": "--reference-column", "--reference": "--reference-column"}


def table_columns(f: Callable[..., Any]) -> Callable[..., Any]:
    """--position/--reference-column/--measured/--deviation/--direction/--run COL, a unit
    per angle column (--position-unit, ...), --counts-per-rev, --zero-offset,
    --decimal-comma, --deviation-sign and a wide table's --forward/--reverse COL,...: passed
    to the command as ``mapping`` (a ``Mapping``; its checks are one SettingsError line
    naming these options)."""
    reference = ("--reference-column",)
    from enctools.units import COLUMN_UNITS

    names = [r for r, _ in _TABLE_ROLES]
    units = [f"{r}_unit" for r in ("position", "reference", "measured", "deviation")]

    @functools.wraps(f)
    def with_mapping(*args: Any, **kwargs: Any) -> Any:
        from enctools.data.tablemap import Mapping

        given = {f"column_{k}": kwargs.pop(f"column_{k}") for k in names}
        given |= {k: kwargs.pop(k) for k in [*units, "counts_per_rev", "zero_offset"]}
        given["decimal_comma"] = kwargs.pop("decimal_comma") or None
        given |= {k: kwargs.pop(k) or None for k in ("columns_forward", "columns_reverse",
                                                      "deviation_sign")}
        return f(*args, mapping=Mapping(**given), **kwargs)

    g: Callable[..., Any] = with_mapping
    g = click.option("--deviation-sign", "deviation_sign",
                     type=click.Choice(["indicated-true", "actual-target"]), default=None,
                     help="The sign the table's deviations are printed in: indicated - true "
                          "(default), or ISO 230-2's and VDI/DGQ 3441's x = actual - target, "
                          "read as its negative.")(g)
    for side, sign in reversed((("forward", "+1"), ("reverse", "-1"))):
        g = click.option(f"--{side}", f"columns_{side}", multiple=True, metavar="COL[,COL...]",
                         help=f"A wide table: its deviation columns of the {side} direction "
                              f"({sign}), one a run (repeat it, or separate them by commas), "
                              "in place of --deviation, --direction and --run.")(g)
    g = click.option("--decimal-comma", is_flag=True, default=False,
                     help="A text table's numbers have a decimal comma (1,25); its columns "
                          "are then separated by tabs, semicolons or blanks.")(g)
    g = click.option("--zero-offset", type=click.Choice(["remove", "keep"]), default=None,
                     help="Remove or keep the constant offset between indicated and reference "
                          "angle (default: remove with --reference and --measured, keep a "
                          "deviation column's).")(g)
    g = click.option("--counts-per-rev", type=int, default=None, metavar="N",
                     help="Counts a revolution, for a column in counts.")(g)
    for u in reversed(units):
        default = "arcsec" if u == "deviation_unit" else "deg"
        g = click.option(f"--{u.replace('_', '-')}", u, type=click.Choice(COLUMN_UNITS),
                         default=None, help=f"Unit of that column (default: its title's, "
                         f"else {default}).")(g)
    for role, what in reversed(_TABLE_ROLES):
        flags = list(reference) if role == "reference" else [f"--{role}"]
        g = click.option(*flags, f"column_{role}", default=None, metavar="COL",
                         help=f"Table column of {what} (title or number; default: found by "
                              "its title).")(g)
    return g


class LazyChoice(click.Choice):
    """A choice whose values are read each time they are asked for (a library registry's
    names: one registered later is a choice too)."""

    def __init__(self, values: Callable[[], Sequence[str]]) -> None:
        self._values = values
        super().__init__(())

    @property
    def choices(self) -> tuple[str, ...]:
        return tuple(self._values())

    @choices.setter
    def choices(self, _: Any) -> None:
        """Set by click.Choice's constructor: the values are read from ``values``."""
