"""enc closure: a closure run -> the encoder's points and the polygon's face errors."""

from __future__ import annotations

from typing import Any

import click

from enctools.cli import options


@click.command("closure")
@options.input_arg
@options.polygon_run
@click.option("--faces-out", default=None, metavar="FILE",
              help="Write the polygon's face errors as a certificate (enc points "
                   "--polygon-certificate reads it).")
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(input: str | None, heads: list[str] | None, autocollimator: str | None,
            faces: int | None, faces_out: str | None, as_json: bool, unit: str,
            output: str | None, force: bool, fmt: str | None) -> None:
    """Separate the encoder's and the polygon's errors of a closure run.

    INPUT is a readings stream from `enc acquire --mode closure`: the polygon measured at
    every table position in every setting on the table, turned by one face between
    settings. Writes the encoder's deviations (one point per table position, relative
    to the first, their standard uncertainty in the metadata) as a points stream, and
    with --faces-out the face angle errors with their standard uncertainty in the
    certificate format of enc-points(1).
    """
    import os

    import numpy as np

    from enctools.cli.summary import check_json, emit
    from enctools.cli.usage import UsageError
    from enctools.data import files, polygon, streams
    from enctools.data.header import history_line, output_folder, recorded_path
    from enctools.data.streams import with_history
    from enctools.data.summaries import from_meta
    from enctools.methods import closure, points

    check_json(as_json, output)
    streams.check_output(output, force, fmt)
    if faces_out is not None:
        if output is not None and os.path.abspath(faces_out) == os.path.abspath(output):
            msg = f"--faces-out and -o both name {faces_out}"
            raise UsageError(msg)
        files.check_new_file(faces_out, force)
    settings = points.Settings(None if heads is None else tuple(heads), autocollimator, faces)
    src = streams.open_input(input, "readings")
    run = closure.read_run(src, settings)
    header, found, sep = closure.closure_points(src.header, run, settings, src.source)
    header = with_history(header, output=output)
    with files.OutputGroup() as group:
        streams.write_table(output, header, found.table(), force, fmt, group=group,
                            unit=unit)
        if faces_out is not None:
            run_name = recorded_path(src.source, output_folder(faces_out))
            text = polygon.certificate_text(
                sep.face_error, np.full(sep.faces, sep.u_face), f"closure {run_name}",
                "circle closure (cross-calibration) on the rig itself: no external standard",
                (history_line(output=faces_out),), type_a_dof=sep.dof)
            group.write(faces_out, text.encode(), force=force)
    summary: dict[str, Any] = {"n_positions": sep.faces, "s_arcsec": sep.s, "dof": sep.dof,
                               "u_deviation_arcsec": sep.u_deviation,
                               "u_face_arcsec": sep.u_face,
                               "face_error_pp_arcsec": float(np.ptp(sep.face_error))}
    emit(summary | {"deviation": from_meta(header.meta["figures"])}, as_json, unit)
