"""enc report: figures, uncertainty, ISO 230-2, plots, thresholds and drift history."""

from __future__ import annotations

import functools
from datetime import datetime
from typing import Any

import click

from enctools.cli import options, runner, usage

#: the options of one kind of input or output, under a heading of their own in --help;
#: given where they do not apply, the command refuses or ignores them as it says
MODES = {
    "HTML and PDF document": ("html_path", "pdf_path", "title", "certificate_path",
                              "certificate_number", "record_path"),
    "Thresholds (exit 1 when one is exceeded)": (
        "max_pp", "max_std", "max_abs", "max_u", "max_radial_pp", "max_harmonic", "max_iso",
        "max_vdi"),
    "Step runs (positioning)": ("standard", "servo_loop"),
    "Nightly history": ("history_dir", "history_rig", "since"),
    "Tables read as points": (
        "column_position", "column_reference", "column_measured", "column_deviation",
        "column_direction", "column_run", "position_unit", "reference_unit", "measured_unit",
        "deviation_unit", "counts_per_rev", "zero_offset", "decimal_comma", "columns_forward",
        "columns_reverse"),
}


@usage.renamed(options.TABLE_RENAMED | {"--rig": "--history-rig"})
@click.command("report", cls=usage.ModeCommand, modes=MODES)
@click.argument("inputs", nargs=-1, metavar="[INPUT...]",
                type=click.Path(dir_okay=False, allow_dash=True))
@options.as_json
@click.option("--html", "html_path", default=None, metavar="FILE", type=click.Path(dir_okay=False),
              help="Write a standalone HTML calibration report (plots embedded).")
@click.option("--pdf", "pdf_path", default=None, metavar="FILE", type=click.Path(dir_okay=False),
              help="Write the plots and tables as a PDF.")
@click.option("--title", default=None, help="Title of the HTML/PDF report.")
@click.option("--certificate", "certificate_path", default=None, metavar="FILE",
              type=click.Path(dir_okay=False),
              help="Make the HTML/PDF a calibration certificate with the laboratory's "
              "fields of FILE (TOML; enc-certificate(5)).")
@click.option("--certificate-number", default=None, metavar="TEXT",
              help="The certificate's number (replaces the file's [certificate] number).")
@click.option("--record", "record_path", default=None, metavar="FILE",
              type=click.Path(dir_okay=False),
              help="With --certificate: write the laboratory's record of it to FILE (each "
              "result's input, settings and history: what the certificate leaves out).")
@click.option("--top", "top_harmonics", type=click.IntRange(1, 10000), default=5,
              show_default=True, metavar="N", help="List the N largest harmonics per curve.")
@options.band("Highest harmonic order K considered.", dest="nmax")
@options.threshold("--max-pp", "Fail (exit 1) when a curve's peak-to-peak exceeds this.")
@options.threshold("--max-std", "Fail when a curve's Bessel standard deviation exceeds this.")
@options.threshold("--max-abs", "Fail when a curve's largest |deviation| exceeds this.")
@options.threshold("--max-u", "Fail when the expanded uncertainty U (k as stated, else 2) "
                   "exceeds this.")
@options.threshold("--max-radial-pp", "Fail when radial error motion peak-to-peak exceeds "
                   "this [nm].", metavar="NM")
@click.option("--max-harmonic", multiple=True, metavar="N:ARCSEC",
              help="Fail when harmonic N's amplitude exceeds ARCSEC (repeatable).")
@click.option("--max-iso", multiple=True, metavar="FIG:ARCSEC",
              help="Fail when an ISO 230-2 figure (A, R, E, B, M, A_up, ...) exceeds ARCSEC.")
@click.option("--standard", type=click.Choice(["iso230-2", "vdi3441"]), default="iso230-2",
              show_default=True, help="The positioning figures of step runs: ISO 230-2:2014 "
              "or VDI/DGQ 3441 (1977).")
@click.option("--servo-loop", is_flag=True,
              help="Give the positioning figures of a step run read on the axis' feedback "
              "encoder anyway, as the servo loop's (they do not describe the axis).")
@click.option("--max-vdi", multiple=True, metavar="FIG:ARCSEC",
              help="With --standard vdi3441: fail when a VDI/DGQ 3441 figure (P, Pa, Ps_max, "
              "U_max, U_mean) exceeds ARCSEC.")
@click.option("--history", "history_dir", default=None, metavar="DIR",
              type=click.Path(file_okay=False),
              help="Tabulate (and plot, with --html/--pdf) the nightly history in DIR.")
@options.table_columns
@click.option("--history-rig", "history_rig", default=None, metavar="NAME",
              envvar=["ENC_REPORT_HISTORY_RIG", "ENC_REPORT_RIG"],
              help="With --history: only this rig's runs (its partition alone is read).")
@click.option("--since", default=None, metavar="DATE",
              type=click.DateTime(["%Y-%m-%d", "%Y-%m-%dT%H:%M", "%Y-%m-%dT%H:%M:%S"]),
              help="With --history: only runs at or after DATE (UTC; YYYY-MM-DD[THH:MM[:SS]]).")
@options.unit
@options.force
@options.verbosity
def command(inputs: tuple[str, ...], as_json: bool, html_path: str | None,
            pdf_path: str | None, title: str | None, certificate_path: str | None,
            certificate_number: str | None, record_path: str | None, top_harmonics: int, nmax: int,
            max_pp: float | None, max_std: float | None, max_abs: float | None,
            max_u: float | None, max_radial_pp: float | None, max_harmonic: tuple[str, ...],
            max_iso: tuple[str, ...], standard: str, servo_loop: bool,
            max_vdi: tuple[str, ...],
            history_dir: str | None, history_rig: str | None,
            since: datetime | None, mapping: Any, unit: str, force: bool) -> None:
    """Summarise enctools streams: figures, harmonics, U (k=2), ISO 230-2 or VDI/DGQ 3441.

    Reads every INPUT (any kind, or a table read as points as by `enc points`, with
    its column options; stdin when none is given and no --history) and prints a
    summary per input on stdout. Thresholds turn it into a check for cron:
    exceeding any exits 1 and names it on stderr; the summary is still printed.
    Angle errors in the text, HTML and PDF are in --unit; --json and the thresholds
    keep arcsec. With --certificate the HTML and the A4 PDF are a calibration
    certificate.
    """
    from enctools.cli.tuning import collect_less
    from enctools.cli.usage import UsageError

    click.get_current_context().with_resource(collect_less())  # until the command ends
    from enctools.report.output import check_paths, run_report
    from enctools.report.sections import Options
    from enctools.report.thresholds import Thresholds, parse_pairs

    limits = Thresholds(max_pp=max_pp, max_std=max_std, max_abs=max_abs, max_u=max_u,
                        max_radial_pp=max_radial_pp,
                        max_harmonic=parse_pairs(max_harmonic, "max_harmonic", int),
                        max_iso=parse_pairs(max_iso, "max_iso", str),
                        max_vdi=parse_pairs(max_vdi, "max_vdi", str))
    wrong = {"iso230-2": "--max-vdi", "vdi3441": "--max-iso"}[standard]
    if (max_vdi if standard == "iso230-2" else max_iso):
        msg = f"{wrong} checks figures that --standard {standard} does not compute"
        raise UsageError(msg)
    if history_dir is None and (history_rig is not None or since is not None):
        msg = "--history-rig and --since select runs of --history DIR; give --history"
        raise UsageError(msg)
    options.distinct_outputs({"--html": html_path, "--pdf": pdf_path, "--record": record_path})
    check_paths([html_path, pdf_path, record_path], force)
    if record_path is not None and certificate_path is None and certificate_number is None:
        msg = "--record is the laboratory's record of a certificate: give --certificate"
        raise UsageError(msg)
    if (certificate_path or certificate_number is not None) and not (html_path or pdf_path):
        msg = "--certificate and --certificate-number make the --html or --pdf document"
        raise UsageError(msg)
    from enctools.report.certificate import load_certificate
    cert = load_certificate(certificate_path, certificate_number)
    sources: list[str | None] = list(inputs) if inputs else ([] if history_dir else [None])
    words = functools.partial(usage.flag_for, command=click.get_current_context().command,
                              name="report")
    run_report(sources, Options(top_harmonics, nmax, standard, servo_loop, words), limits,
               as_json=as_json,
               html_path=html_path, pdf_path=pdf_path, title=title, history_dir=history_dir,
               history_filter={"rig": history_rig, "since": since},
               prog=runner.command_name(), unit=unit,
               progress=runner.Progress("inputs and renderings"), mapping=mapping, cert=cert,
               words=words, record_path=record_path)
