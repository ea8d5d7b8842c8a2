"""enc points: a steps-mode readings stream (polygon + autocollimator) or a table -> points."""

from __future__ import annotations

from typing import Any

import click

from enctools.cli import options, usage
from enctools.units import ANGLE_UNITS, factor

STEPS = "Step runs (INPUT a readings stream)"
TABLE = "Tables (INPUT is a table: text, Parquet, Arrow, HDF5)"
#: the options of one kind of input, refused with the other (the library refuses them too)
MODES = {STEPS: ("heads", "autocollimator", "faces", "certificate", "certificate_unit",
                 "first_face"),
         TABLE: ("column_position", "column_reference", "column_measured", "column_deviation",
                 "column_direction", "column_run", "position_unit", "reference_unit",
                 "measured_unit", "deviation_unit", "counts_per_rev", "zero_offset",
                 "decimal_comma", "columns_forward", "columns_reverse")}


def _mode(params: Any) -> str:
    from enctools.data.usertables import is_table_file

    return TABLE if is_table_file(params.get("input")) else STEPS


@usage.renamed(options.TABLE_RENAMED)
@click.command("points", cls=usage.ModeCommand, modes=MODES, mode_of=_mode)
@options.input_arg
@options.polygon_run
@click.option("--polygon-certificate", "certificate", default=None, metavar="FILE",
              help="The polygon's certificate (CSV: face, error, U or u): its face errors "
                   "applied to the reference angle.")
@click.option("--certificate-unit", default=None,
              type=click.Choice(list(ANGLE_UNITS)),
              help="Unit of the certificate's values when it states none (default: arcsec).")
@click.option("--first-face", type=int, default=None, metavar="N",
              help="The certificate's face at the run's first position (default: its first).")
@options.table_columns
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(input: str | None, heads: list[str] | None, autocollimator: str | None,
            faces: int | None, certificate: str | None, certificate_unit: str | None,
            first_face: int | None, mapping: Any, as_json: bool, unit: str, output: str | None,
            force: bool, fmt: str | None) -> None:
    """Turn a polygon step run, or a table, into a points stream.

    INPUT is a readings stream from `enc acquire --mode steps` on a rig with a
    polygon and an autocollimator (one point per position: mean of the measuring
    heads relative to the first position, against the polygon angle), or a table:
    CSV, TSV or blank-separated text with # comment lines and any header, or Parquet,
    Arrow or HDF5 without enctools metadata, its columns found by title or named with
    --position/--reference/--measured/--deviation. A point's position is the indicated
    angle (the encoder's reading); the zero offset to the reference is reported.
    With --polygon-certificate the polygon's face angle errors correct the reference
    angle of a step run, and the points carry the certificate's uncertainty.
    """
    from enctools.cli.summary import check_json, emit
    from enctools.data import streams, usertables
    from enctools.data.polygon import read_certificate
    from enctools.data.streams import with_history
    from enctools.data.summaries import from_meta
    from enctools.methods import points

    check_json(as_json, output)
    streams.check_output(output, force, fmt)
    settings = points.Settings(None if heads is None else tuple(heads), autocollimator, faces,
                               certificate, certificate_unit, first_face)
    cert = None
    if certificate is not None and not usertables.is_table_file(input):
        cert = read_certificate(certificate, None, certificate_unit)
    given = usertables.open_input(input, "readings", bool(mapping.decimal_comma))
    header, found = points.make_points(given, settings, mapping, cert)
    streams.write_table(output, with_history(header, output=output), found.table(), force, fmt,
                        unit=unit)
    summary: dict[str, Any] = {"n_rows": len(found)}
    if "zero_offset_arcsec" in header.meta:
        summary |= {"zero_offset_arcsec": header.meta["zero_offset_arcsec"],
                    "zero_offset_removed": header.meta["zero_offset_removed"]}
    if header.meta.get("axis") == "linear":     # no turn: no targets over one
        emit(summary | {"axis": "linear", "zero_offset_um": header.meta["zero_offset_um"],
                        "zero_offset_removed": header.meta["zero_offset_removed"]},
             as_json, unit)
        return
    if "polygon_certificate" in header.meta:
        summary["polygon_face_u_max_arcsec"] = header.meta["polygon_certificate"]["u_max_arcsec"]
    t = header.meta["targets"]
    summary["targets"] = {"n_targets": t["targets"], "n_visits": t["visits"],
                          "tolerance_arcsec": t["tolerance_deg"] * factor("deg", "arcsec"),
                          "step_deg": t["step_deg"]}
    emit(summary | {"distinct_positions": from_meta(header.meta["figures"])}, as_json, unit)
