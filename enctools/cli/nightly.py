"""enc-nightly: the nightly recheck for cron (bin/enc-nightly runs ``python -m
enctools.cli.nightly``); the work is :mod:`enctools.report.nightly`'s."""

from __future__ import annotations

import contextlib
import os
import signal
import sys

if __name__ == "__main__":  # a signal ends the process as documented from here on, before
    # the imports below (runner.prologue then puts its own handlers)
    from enctools.errors import ending_signals, signal_name  # light: re and the exceptions

    def _ended(signum: int, frame: object) -> None:
        name = signal_name(signum)
        why = "terminated" if name == "SIGTERM" else f"stopped by {name}"
        if sys.stderr is not None:
            with contextlib.suppress(OSError, ValueError):
                sys.stderr.write(f"enc-nightly: error: {why}\n")
                sys.stderr.flush()
        # not SystemExit: raised inside an import's class body, Python wraps it in a
        # RuntimeError (a traceback, exit 1); nothing is open yet that needs closing
        os._exit(128 + signum)

    for _sig in ending_signals(sigint=False):  # an ignored one (nohup's SIGHUP) stays so
        signal.signal(_sig, _ended)
from pathlib import Path

import click

from enctools.cli import runner
from enctools.cli.campaign import DEFAULT_TEXT

PROG = "enc-nightly"


@click.command(PROG, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--rig", envvar="ENC_RIG", required=True, metavar="NAME|PATH",
              help="Rig to re-acquire on (passed to a --campaign script as $RIG).")
@click.option("--history", "history_dir", envvar="ENC_NIGHTLY_HISTORY", required=True,
              metavar="DIR|URI", type=click.Path(file_okay=False),
              help="The history (a Delta table): a folder or an s3://, az://, gs:// URI; "
              "one transaction a night is appended.")
@click.option("--calibration", required=True, metavar="FILE", type=click.Path(dir_okay=False),
              help="The stored calibration (points or deviations stream) to compare with.")
@click.option("--init", is_flag=True, default=False,
              help="When FILE does not exist, store this run as the calibration.")
@click.option("--campaign", envvar="ENC_NIGHTLY_CAMPAIGN", default=None, metavar="CMD",
              help="Shell command writing $OUT/result.parquet, run as a process of its own "
              f"[default: the polygon check, {DEFAULT_TEXT}, run in this process]")
@click.option("--campaign-timeout", "campaign_timeout_s", type=float, default=None,
              metavar="SECONDS", callback=lambda ctx, p, v: _positive(v),
              help="Stop a --campaign script still running after SECONDS (exit 3; default: "
              "no limit).")
@click.option("--max-drift", "--tolerance", "tolerance", type=float, default=0.5,
              show_default=True, metavar="ARCSEC",
              help="Largest allowed |drift| against the calibration.")
@click.option("--keep", default=None, metavar="DIR", type=click.Path(file_okay=False),
              help="Keep the campaign's outputs in a new subfolder DIR/RUN_ID each night "
              "(default: a removed temporary folder).")
@click.option("--html", default=None, metavar="FILE", type=click.Path(dir_okay=False),
              help="Also write this run's HTML report with the history.")
@click.option("--force", is_flag=True, default=False,
              help="Replace an existing --html FILE (a nightly report usually wants it).")
def command(rig: str, history_dir: str, calibration: str, init: bool, campaign: str | None,
            campaign_timeout_s: float | None, tolerance: float, keep: str | None,
            html: str | None, force: bool) -> None:
    """Nightly recheck: re-acquire, run the campaign, compare, append to the history.

    Exit status: 0 within tolerance, 1 drift beyond it, 2 bad usage or input or a file
    that cannot be written (full disk, permission), 3 device fault in the campaign or
    --campaign-timeout run out, 128 + n stopped by signal n (130 SIGINT, 143 SIGTERM,
    129 SIGHUP).
    """
    import functools

    from enctools.cli import campaign as campaigns
    from enctools.cli import usage
    from enctools.data.files import check_new_file
    from enctools.errors import DataError
    from enctools.report.nightly import Settings, os_message, run_nightly

    if html is not None:  # refused before the night is run and recorded
        try:  # as for the history, the calibration
            Path(html).parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise DataError(f"--html {html}: " + os_message(exc)) from None
        check_new_file(html, force)
    if campaign_timeout_s is not None and campaign is None:
        raise click.UsageError("--campaign-timeout limits a --campaign script; give one")
    what = (campaigns.DEFAULT if campaign is None
            else campaigns.script(campaign, campaign_timeout_s))
    night = run_nightly(Settings(rig, history_dir, calibration, what, tolerance, init,
                                 keep, html),
                        words=functools.partial(usage.flag_for, command=command, name=PROG))
    if night.summary is not None and night.code in (0, 1):  # a verdict, not a failure
        click.echo(night.summary)
    for level, text in night.messages:
        if level == "error":
            runner.error(text)
        else:
            sys.stderr.write(f"{PROG}: {text}\n")
    raise click.exceptions.Exit(night.code)


def _positive(value: float | None) -> float | None:
    if value is not None and not value > 0:
        raise click.BadParameter(f"must be > 0 seconds, not {value:g}")
    return value


def main(argv: list[str] | None = None) -> None:
    """Entry point of bin/enc-nightly and of the installed enc-nightly: the prologue and the
    error handling of every command."""
    args = sys.argv[1:] if argv is None else argv
    if argv is None:  # the process itself: started with a standard stream closed? (as enc)
        runner.standard_streams()
        from enctools.cli.campaign import adopt_orphans

        adopt_orphans()  # what a campaign leaves running is reaped here once stopped
    _enc_on_path()
    runner.set_program(PROG, command)
    runner.prologue()

    def invoke() -> None:
        with command.make_context(PROG, list(args)) as ctx:
            command.invoke(ctx)

    from enctools.cli.tuning import without_pandas

    with without_pandas():  # as in enc: pyarrow would import pandas to ask about each array
        code = runner.run(invoke, debug=os.environ.get("ENC_DEBUG", "") not in ("", "0"))
    try:  # a full disk under a redirected stdout fails here: one line, not a traceback
        if sys.stdout is not None:  # None: started with stdout closed, the summary unread
            sys.stdout.flush()
    except OSError as exc:
        runner.error(f"stdout: {exc.strerror or exc}")
        code = code if code not in (0, 1) else 2
        with contextlib.suppress(OSError, ValueError):
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    # the night is over and told: a signal now would only turn its status into -15
    # (the interpreter's shutdown puts the default handlers back)
    from enctools.errors import ending_signal_numbers

    for sig in ending_signal_numbers():
        signal.signal(sig, signal.SIG_IGN)
    sys.exit(code)


def _enc_on_path() -> None:
    """The campaign's ``enc`` is this environment's: its folder first on PATH (cron's PATH
    holds neither a virtual environment's bin nor ~/.local/bin)."""
    here = Path(sys.executable).parent
    if (here / "enc").exists():
        os.environ["PATH"] = os.pathsep.join([str(here), os.environ.get("PATH", "")])


if __name__ == "__main__":
    main()
