"""enc average-heads: the mean of selected heads as a new head channel, with its A(n)."""

from __future__ import annotations

import click

from enctools.cli import options


def _groups(ctx: click.Context, param: click.Parameter,
            value: tuple[str, ...]) -> list[tuple[str | None, list[str]]]:
    out: list[tuple[str | None, list[str]]] = []
    for v in value:
        name, sep, rest = v.partition("=")
        if not sep:
            name, rest = "", v
        heads = [h.strip() for h in rest.split(",") if h.strip()]
        if not heads:
            raise click.BadParameter(f"expected NAME=H1,H2,... or H1,H2,..., not {v!r}")
        out.append((name.strip() or None, heads))
    return out


@click.command("average-heads")
@options.input_arg
@click.option("-a", "--average", "groups", multiple=True, callback=_groups,
              metavar="NAME=H1,H2,...",
              help="A new channel NAME = mean of the heads (repeatable; NAME defaults to "
                   "their common prefix). Default: each encoder's measuring heads.")
@options.band("Harmonics 1..K over which A(n) is summarised.")
@click.option("--drop", is_flag=True, default=False,
              help="Drop the averaged heads from the output (keep the new channels).")
@options.outputs
@options.verbosity
def command(input: str | None, groups: list[tuple[str | None, list[str]]], band: int, drop: bool,
            output: str | None, force: bool, fmt: str | None) -> None:
    """Add the mean of selected heads as a new head channel to a readings stream.

    H = mean(H1..H4) of four equally spaced heads keeps only the multiples of 4 of
    the graduation error and cancels radial motion (seed 000 eqs. (3)-(6)); the
    transfer function A(n) of each average is logged and kept in the field metadata.
    """
    from enctools.data import streams
    from enctools.methods import heads

    settings = heads.Settings(groups=tuple((name, tuple(hs)) for name, hs in groups),
                              band=band, drop=drop)
    streams.check_output(output, force, fmt)
    source = streams.open_input(input, "readings")
    header, batches = heads.run(source, settings)
    with streams.OutputStream(output, streams.with_history(header), force, fmt) as out:
        for b in batches:
            out.write(b)
