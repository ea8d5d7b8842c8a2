"""enc correct: apply a correction table to points or readings as the hardware would, and
report the error before and after."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import click

from enctools.cli import options

#: the formats of enc make-rom (enc-make-rom(1)): memories and motion controls
TARGETS = ("bin", "ihex", "mif", "coe", "mem", "csv", "acs", "siemens", "linuxcnc", "twincat",
           "fanuc", "heidenhain")

if TYPE_CHECKING:
    from collections.abc import Callable

    from enctools.data.streams import Header
    from enctools.data.tablemap import Mapping
    from enctools.models.corrected import Residuals
    from enctools.models.correction import Correction


@click.command("correct")
@options.input_arg
@click.option("--table", "table_path", required=True, metavar="FILE",
              type=click.Path(dir_okay=False),
              help="The correction: a table file (bin, ihex, mif, coe, mem, csv, acs, siemens), "
                   "a rom stream, a model stream or a deviations stream.")
@click.option("--target", type=click.Choice(TARGETS), default=None,
              help="The table file's format (default: from its extension, else its content).")
@click.option("--bits", "code_bits", type=int, default=None,
              help="Bits n of the code the table is for (default: from its comment or "
                   "sidecar, else the input's 2^n-count encoder).")
@click.option("--address-bits", type=int, default=None,
              help="The table is addressed by the code's top M bits (default: from its size).")
@click.option("--width", type=int, default=None,
              help="Word width [bit] of bin and ihex tables (default: from the comment, else 16).")
@click.option("--lsb", type=float, default=None,
              help="Counts of the code per LSB of a value (default: from the comment, else 1).")
@click.option("--endian", type=click.Choice(["little", "big"]), default=None,
              help="bin and ihex: byte order of the words (default: from the sidecar, "
                   "else little).")
@click.option("--array", "array_name", default="ENC_COMP", show_default=True,
              help="acs: name of the REAL array holding the map.")
@click.option("--sign", type=click.Choice(["correction", "error"]), default=None,
              help="acs, fanuc, heidenhain: the file stores the correction or the error "
                   "(as make-rom was given it).")
@click.option("--comp-type", type=click.IntRange(0, 1), default=0, show_default=True,
              help="linuxcnc: the file's COMP_FILE_TYPE.")
@click.option("--axis", default=None, metavar="NAME",
              help="heidenhain: the table's axis column.")
@click.option("--curve", default=None, metavar="NAME",
              help="A deviations stream as the correction: the curve to use.")
@options.heads("Readings: heads averaged into the encoder's code (default: the rig's "
               "measuring heads).")
@options.ref("Readings: the reference angle: 'truth' (simulator) or heads of a reference "
             "encoder (default: truth).", dest="reference", metavar="truth|H1,...",
             callback=options.name_list)
@options.points("Readings: bins of the output deviations curves.", 1024)
@options.table_columns
@options.threshold("--max-pp", "Exit 1 when the corrected peak-to-peak exceeds this.")
@options.threshold("--max-std", "Exit 1 when the corrected Bessel s exceeds this.")
@options.threshold("--max-abs", "Exit 1 when the largest corrected |deviation| exceeds this.")
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(input: str | None, table_path: str, target: str | None, code_bits: int | None,
            address_bits: int | None, width: int | None, lsb: float | None, endian: str | None,
            array_name: str, sign: str | None, comp_type: int, axis: str | None,
            curve: str | None, heads: list[str] | None,
            reference: list[str] | None, points: int, max_pp: float | None,
            max_std: float | None, max_abs: float | None, as_json: bool, unit: str,
            output: str | None, force: bool, fmt: str | None, mapping: Mapping) -> None:
    """Apply a correction table to points or readings as an FPGA or a controller would.

    INPUT is a points stream or a table (position = the indicated angle; column options
    as enc points', the reference column spelt --reference-column), or a
    continuous readings stream with a reference angle (--ref). Memory tables are looked
    up by the code's top bits and their integer added in LSBs; controller tables are
    interpolated between their points, modulo 360 deg; a model is applied unquantised.
    The error before and after goes to stderr (or stdout with --json); -o writes the
    corrected points (or, from readings, a deviations stream of both curves).
    """
    from enctools.cli.summary import check_json, emit
    from enctools.data import streams
    from enctools.data.summaries import before_after
    from enctools.errors import CheckFailed
    from enctools.models import correction
    from enctools.report.thresholds import Thresholds, figure_limits

    if output == "-":
        check_json(as_json, output)
    if output is not None:
        streams.check_output(output, force, fmt)
    settings = correction.TableSettings(target, code_bits, address_bits, width, lsb, endian,
                                        array_name, sign, comp_type, axis)
    def table_for(rig_bits: int | None) -> Correction:
        return correction.load(table_path, settings, curve, rig_bits)

    header, out, res, extra, table = _apply(input, table_for, heads, reference, points,
                                            mapping)
    described = {"file": table_path} | table.describe()
    if output is not None:
        kind = "deviations" if header.kind == "readings" else "points"
        out_header = header.derive(kind, out.schema, source=extra["input"]["source"],
                                   settings={"table": described})
        streams.write_table(output, streams.with_history(out_header), out, force, fmt)
    figures = before_after(res.figures_before, res.figures_after)
    constant = {"constant": {"added_arcsec": res.constant,
                             "after_rms_with_it_arcsec": res.rms_with_constant}}
    emit({"table": described} | extra | dict(list(figures.items())[:2]) | constant | figures
         | ({"output": output} if output is not None else {}), as_json, unit)
    bad = figure_limits(res.figures_after, Thresholds(max_pp, max_std, max_abs),
                        f"the corrected {header.kind} of {extra['input']['source']}")
    if bad:
        raise CheckFailed("; ".join(bad))


def _apply(input: str | None, table_for: Callable[[int | None], Correction],
           heads: list[str] | None, reference: list[str] | None, points: int,
           mapping: Mapping) -> tuple[Header, Any, Residuals, dict[str, Any], Correction]:
    """The input's header, the corrected stream's rows, the residuals, what the summary
    says of the input, and the table (``table_for(the bits of the input's 2^n-count
    code, or None)``)."""
    from enctools.data import streams
    from enctools.errors import UsageError
    from enctools.methods.points import check_points, from_table, is_table_file, read_points
    from enctools.models.corrected import correct_points
    from enctools.models.correction import rig_code_bits

    given = [o for o, v in (("--heads", heads), ("--ref", reference)) if v is not None]
    if input is not None and is_table_file(input):
        header, pts = read_points(input, mapping)
        source = input
    else:
        if mapping.given():
            msg = f"{', '.join(mapping.given())}: for a table; {input or 'stdin'} is a stream"
            raise UsageError(msg)
        src = streams.open_input(input, ("points", "readings"))
        header, source = src.header, src.source
        if header.kind == "readings":
            return _readings(src, table_for, heads, reference, points)
        pts = check_points(from_table(src.read_all(), source, header.meta), source)
    if given:
        msg = f"{given[0]} applies to readings; {source} holds points"
        if given[0] == "--ref" and input is not None and is_table_file(input):
            msg += " (a table's reference column is --reference-column)"
        raise UsageError(msg)
    table = table_for(rig_code_bits(header.meta))
    fixed, res = correct_points(pts, table, source)
    return header, fixed.table(), res, {"input": {"kind": "points", "source": source,
                                                  "n_rows": len(pts)}}, table


def _readings(src: Any, table_for: Callable[[int | None], Correction],
              heads: list[str] | None, reference: list[str] | None, points: int
              ) -> tuple[Header, Any, Residuals, dict[str, Any], Correction]:
    """A continuous run's residuals against its reference, and both curves binned."""
    import numpy as np

    from enctools.data.curves import Column, deviations_table
    from enctools.data.readings import head_info, measuring_heads
    from enctools.errors import DataError
    from enctools.methods.harmonics import bin_average, grid
    from enctools.methods.reference_angle import reference_angle, times
    from enctools.models.corrected import correct_readings, encoder_code

    header = src.header
    if "step" in header.schema.names:
        msg = (f"{src.source}: a steps run; make its points first "
               "(enc points RUN | enc correct --table ...)")
        raise DataError(msg)
    names = heads or measuring_heads(header.schema, header.meta, src.source)
    infos = [head_info(header.schema, h, src.source) for h in names]
    cpr = infos[0].counts_per_rev
    if any(i.counts_per_rev != cpr for i in infos):
        raise DataError(f"{src.source}: heads {', '.join(names)} count differently per turn")
    table = table_for(cpr.bit_length() - 1 if cpr > 0 and cpr & (cpr - 1) == 0 else None)
    rows = src.read_all()
    code = encoder_code([rows.column(i.name).to_numpy(zero_copy_only=False) for i in infos], cpr)
    ref = reference_angle(rows, header.schema, header.meta, times(rows, src.source), reference,
                          src.source)
    angle, res = correct_readings(code, cpr, ref, table, src.source)
    curves = bin_average(angle, np.stack([res.before, res.after]), points)
    out = deviations_table(grid(points), [Column("before", curves[0]), Column("after", curves[1])])
    return header, out, res, {"input": {"kind": "readings", "source": src.source,
                                        "n_samples": int(code.size),
                                        "heads": names, "reference": reference or ["truth"]},
                              "zero_offset_arcsec": res.zero_offset}, table

