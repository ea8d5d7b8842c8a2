"""The ``enc`` driver: one click group whose subcommands are imported only when run.

Commands are registered in :data:`COMMANDS` (name -> module, one-line help); a
command whose module is not present is not listed. ``enc --help`` imports click and
nothing of numpy, scipy, pyarrow, h5py or matplotlib.
"""

from __future__ import annotations

import importlib
import os
import sys
from typing import Any

import click

from enctools import __version__
from enctools.cli import runner

#: name -> (module under enctools.cli, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "acquire": ("acquire", "Acquire readings from a rig (simulator, replay or instruments)."),
    "average-heads": ("average_heads", "Average heads into a new channel; report A(n)."),
    "selfcal": ("selfcal", "Self-calibrate graduation error from several heads of a scale."),
    "design": ("design", "Analyse and optimise head arrangements for self-calibration."),
    "compare": ("compare", "Deviation of a device against a reference."),
    "interp-check": ("interp_check", "Interpolation error within a signal period."),
    "fit-rbf": ("fit_rbf", "Fit an RBF or Fourier error model to sparse points."),
    "make-rom": ("make_rom", "Evaluate a model into a correction table (ROM)."),
    "correct": ("correct", "Apply a correction table as the hardware would: error before, after."),
    "latency": ("latency", "Dynamic error and code-skip speed from readout latency."),
    "points": ("points", "Turn step-run readings into calibration points."),
    "closure": ("closure", "Separate encoder and polygon errors of a closure run."),
    "report": ("report", "Figures, uncertainty, ISO 230-2, plots and thresholds."),
    "info": ("info", "Describe a stream: kind, columns, units, rows, history."),
    "rig": ("rig", "List the bundled rigs, print one to edit, check a rig file."),
    "history": ("history", "Show, compact or migrate the nightly history (a Delta table)."),
}


def _available() -> list[str]:
    here = os.path.dirname(__file__)  # a file test: find_spec would import importlib.util
    return [name for name, (mod, _) in COMMANDS.items()
            if os.path.exists(os.path.join(here, f"{mod}.py"))]


def envvar_name(command: str, option: click.Option) -> str:
    """ENC_<COMMAND>_<OPTION>, from the option's first long flag (--interval -> INTERVAL)."""
    flag = next((o for o in option.opts if o.startswith("--")), option.opts[0])
    return f"ENC_{command}_{flag.lstrip('-')}".upper().replace("-", "_")


def set_envvars(command: click.Command, name: str) -> None:
    """Give every valued option without an explicit variable its ENC_<COMMAND>_<OPTION>.

    Plain flags (--force, --pace) get none: an environment must not force an overwrite.
    """
    for p in command.params:
        if not isinstance(p, click.Option) or p.envvar is not None:
            continue
        if not p.is_flag or p.secondary_opts:
            p.envvar = envvar_name(name, p)


class LazyGroup(click.Group):
    """A group that imports a subcommand's module only when that command runs."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        return _available()

    def get_command(self, ctx: click.Context, name: str) -> click.Command | None:
        if name not in COMMANDS or name not in _available():
            return None
        runner.set_command(name)
        module = importlib.import_module(f"enctools.cli.{COMMANDS[name][0]}")
        command: click.Command = module.command
        set_envvars(command, name)
        from enctools.cli.options import text_options

        text_options(command)
        runner.set_command(name, command)
        return command

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rows = [(name, COMMANDS[name][1]) for name in self.list_commands(ctx)]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


def _version(ctx: click.Context, _param: click.Parameter, value: bool) -> None:
    """``--version``: enctools' version and which per-sample passes run (enctools.kernel)."""
    if not value or ctx.resilient_parsing:
        return
    from enctools import kernel

    click.echo(f"enctools, version {__version__}\nkernel: {kernel.name()}")
    ctx.exit()


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--version", is_flag=True, expose_value=False, is_eager=True, callback=_version,
              help="Show the version and the kernel in use, and exit.")
@click.option("--debug", is_flag=True, default=False, envvar="ENC_DEBUG",
              help="Show a traceback on errors.")
def cli(debug: bool) -> None:
    """enctools: calibrate angle encoders and precision rotary tables.

    Small commands that pass typed tables (Arrow IPC on pipes; Parquet, HDF5 or
    Arrow files) to each other. See enc(1) and enc COMMAND --help.
    """


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``enc`` executable."""
    args = sys.argv[1:] if argv is None else argv
    if "_ENC_COMPLETE" in os.environ:  # shell completion: click's own entry point
        cli.main(args=args, prog_name="enc", complete_var="_ENC_COMPLETE")
    if argv is None:  # the enc process itself: started with a standard stream closed?
        runner.standard_streams()
    debug = "--debug" in args or os.environ.get("ENC_DEBUG", "") not in ("", "0")
    from enctools.cli.tuning import one_blas_thread, without_pandas

    one_blas_thread()  # before any command imports numpy

    def invoke() -> Any:
        # make_context + invoke rather than cli.main: click's own handling of a closed
        # pipe (exit 1) and of errors (several lines) is replaced by runner.run's.
        with cli.make_context("enc", list(args)) as ctx:
            return cli.invoke(ctx)

    with without_pandas():
        status = runner.run(invoke, debug)
    if argv is None:  # the enc process itself: its outputs are closed, nothing is left to do
        runner.exit_now(status)
    sys.exit(status)


if __name__ == "__main__":
    main()
