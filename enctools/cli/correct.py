"""enc correct: apply a correction table to points or readings as the hardware would, and
report the error before and after."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import click

from enctools.cli import options, usage

if TYPE_CHECKING:
    from enctools.data.tablemap import Mapping
    from enctools.models.applied import Applied, ReadingsSettings, TableFor


def formats() -> tuple[str, ...]:
    """The table formats of the registry (enc-make-rom(1)): memories and controls."""
    from enctools.models.romformats import registry

    return registry.names()


#: options of one kind of input or table, under their heading in --help (where the code
#: refuses them for another: readings' options for points, a layout for a stream)
MODES = {"Readings (a continuous run)": ("heads", "reference", "points"),
         "A table file's layout (memories: bin, ihex, mif, coe, mem, csv)":
         ("code_bits", "address_bits", "width", "lsb", "endian"),
         "A controller's table file": ("array_name", "sign", "comp_type", "axis",
                                       "detection_unit")}


@usage.renamed({"--ref": "--reference"})
@click.command("correct", cls=usage.ModeCommand, modes=MODES)
@options.input_arg
@click.option("--table", "table_path", required=True, metavar="FILE",
              type=click.Path(dir_okay=False),
              help="The correction: a table file (any --target), a rom stream, a model "
                   "stream or a deviations stream.")
@click.option("--target", type=options.LazyChoice(formats), default=None,
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
              help="acs, fanuc, heidenhain, twincat-nc: the file stores the correction or "
                   "the error (as make-rom was given it).")
@click.option("--comp-type", type=click.IntRange(0, 1), default=0, show_default=True,
              help="linuxcnc: the file's COMP_FILE_TYPE.")
@click.option("--axis", default=None, metavar="NAME",
              help="heidenhain: the table's axis column; fanuc-param: the axis number.")
@click.option("--detection-unit", type=float, default=1e-3, show_default=True,
              help="fanuc-param: the axis's detection unit [deg] (the file does not state it).")
@click.option("--curve", default=None, metavar="NAME",
              help="A deviations stream as the correction: the curve to use.")
@options.heads("Readings: heads averaged into the encoder's code (default: the rig's "
               "measuring heads).")
@click.option("--reference", "reference", default=None, metavar="truth|H1,...",
              callback=options.name_list, shell_complete=options.complete_heads,
              help="Readings: the reference angle: 'truth' (simulator) or heads of a "
                   "reference encoder (default: truth).")
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
            detection_unit: float, curve: str | None, heads: list[str] | None,
            reference: list[str] | None, points: int, max_pp: float | None,
            max_std: float | None, max_abs: float | None, as_json: bool, unit: str,
            output: str | None, force: bool, fmt: str | None, mapping: Mapping) -> None:
    """Apply a correction table to points or readings as an FPGA or a controller would.

    INPUT is a points stream or a table (position = the indicated angle; column options
    as enc points', the reference column spelt --reference-column), or a
    continuous readings stream with a reference angle (--reference). Memory tables are
    looked up by the code's top bits and their integer added in LSBs; controller tables
    are interpolated between their points, modulo 360 deg; a model is applied unquantised.
    The error before and after goes to stderr (or stdout with --json); -o writes the
    corrected points (or, from readings, a deviations stream of both curves).
    """
    from enctools.cli.summary import check_json, emit
    from enctools.data import streams
    from enctools.data.summaries import before_after
    from enctools.errors import CheckFailed
    from enctools.models import correction
    from enctools.models.applied import ReadingsSettings
    from enctools.report.thresholds import Thresholds, figure_limits

    if output == "-":
        check_json(as_json, output)
    if output is not None:
        streams.check_output(output, force, fmt)
    settings = correction.TableSettings(
        fmt=target, code_bits=code_bits, address_bits=address_bits, width=width, lsb=lsb,
        endian=endian, array_name=array_name, sign=sign, comp_type=comp_type, axis=axis,
        detection_unit_deg=detection_unit, options_given=_given_read_settings())

    def table_for(rig_bits: int | None) -> correction.Correction:
        return correction.load(table_path, settings, curve, rig_bits)

    header, applied = _apply(input, table_for, ReadingsSettings(heads, reference, points),
                             mapping)
    res, extra = applied.residuals, applied.about
    described = {"file": table_path} | applied.table.describe()
    if output is not None:
        kind = "deviations" if header.kind == "readings" else "points"
        out_header = header.derive(kind, applied.rows.schema, source=extra["input"]["source"],
                                   settings={"table": described})
        streams.write_table(output, streams.with_history(out_header, output=output),
                            applied.rows, force, fmt, unit=unit)
    figures = before_after(res.figures_before, res.figures_after)
    constant = {"constant": {"added_arcsec": res.constant,
                             "after_rms_with_it_arcsec": res.rms_with_constant}}
    emit({"table": described} | extra | dict(list(figures.items())[:2]) | constant | figures
         | ({"output": output} if output is not None else {}), as_json, unit)
    bad = figure_limits(res.figures_after, Thresholds(max_pp, max_std, max_abs),
                        f"the corrected {header.kind} of {extra['input']['source']}")
    if bad:
        raise CheckFailed("; ".join(bad))


#: the options a controller's file reader is told -> the field of TableSettings each sets
READ_OPTIONS = {"sign": "sign", "array_name": "array_name", "comp_type": "comp_type",
                "axis": "axis", "detection_unit": "detection_unit_deg"}


def _given_read_settings() -> frozenset[str]:
    """The fields of :data:`READ_OPTIONS` set by an option given (not its default): the
    library refuses each for a table whose reader is not told it."""
    from click.core import ParameterSource

    ctx = click.get_current_context()
    return frozenset(field for param, field in READ_OPTIONS.items()
                     if ctx.get_parameter_source(param) not in (ParameterSource.DEFAULT, None))


def _apply(input: str | None, table_for: TableFor, readings: ReadingsSettings,
           mapping: Mapping) -> tuple[Any, Applied]:
    """The input's header and the table applied to it (``models.applied``): its points,
    or a continuous run's readings; readings' options refused for points."""
    from enctools.cli.usage import UsageError
    from enctools.data import streams, usertables
    from enctools.methods.points import check_points, from_table, is_table_file, read_points
    from enctools.models import applied

    given = [o for o, v in (("--heads", readings.heads), ("--reference", readings.reference))
             if v is not None]
    if input is not None and is_table_file(input):
        header, pts = read_points(usertables.read(input, bool(mapping.decimal_comma)), mapping)
        source = input
    else:
        if mapping.given():
            msg = f"{', '.join(mapping.given())}: for a table; {input or 'stdin'} is a stream"
            raise UsageError(msg)
        src = streams.open_input(input, ("points", "readings"))
        header, source = src.header, src.source
        if header.kind == "readings":
            return header, applied.to_readings(src, table_for, readings)
        pts = check_points(from_table(src.read_all(), source, header.meta), source)
    if given:
        msg = f"{given[0]} applies to readings; {source} holds points"
        if given[0] == "--reference" and input is not None and is_table_file(input):
            msg += " (a table's reference column is --reference-column)"
        raise UsageError(msg)
    return header, applied.to_points(header, pts, table_for, source)
