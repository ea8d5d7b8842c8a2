"""enc average-heads: the mean of selected heads as a new head channel, with its A(n)."""

from __future__ import annotations

from typing import Any

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
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(input: str | None, groups: list[tuple[str | None, list[str]]], band: int, drop: bool,
            as_json: bool, unit: str, output: str | None, force: bool, fmt: str | None) -> None:
    """Add the mean of selected heads as a new head channel to a readings stream.

    H = mean(H1..H4) of four equally spaced heads keeps only the multiples of 4 of
    the graduation error and cancels radial motion (seed 000 eqs. (3)-(6)); the
    transfer function A(n) of each average is logged and kept in the field metadata.
    """
    from enctools.cli import runner, summary
    from enctools.data import streams
    from enctools.methods import heads

    settings = heads.Settings(groups=tuple((name, tuple(hs)) for name, hs in groups),
                              band=band, drop=drop)
    summary.check_json(as_json, output)
    streams.check_output(output, force, fmt)
    source = streams.open_input(input, "readings")
    header, batches = heads.run(source, settings)
    progress = runner.Progress("rows", "rows").every(runner.expected_rows(source.meta))
    rows = 0
    with streams.OutputStream(output, streams.with_history(header, output=output), force, fmt,
                              unit=unit) as out:
        for b in batches:
            out.write(b)
            rows += b.num_rows
            progress(rows)
    summary.emit({"n_rows": rows, "averages": _averages(source.schema, header.meta["averages"],
                                                        band)}, as_json)


def _averages(schema: Any, averages: dict[str, list[str]], band: int) -> list[dict[str, Any]]:
    """Per average: its heads, their angles [deg], the harmonics 1..band it passes,
    cancels and attenuates, and the part of the radial motion it keeps."""
    import numpy as np

    from enctools.data.readings import head_info
    from enctools.methods.heads import summarize_average

    out = []
    for name, hs in averages.items():
        s = summarize_average(np.array([head_info(schema, h).alpha for h in hs]), band)
        out.append({"name": name, "heads": list(hs), "alphas_deg": list(s.alphas_deg),
                    "passed": list(s.passed), "cancelled": list(s.cancelled),
                    "attenuated": list(s.partial),
                    "radial_gain": s.radial_gain if s.radial_gain > 1e-12 else 0.0})
    return out
