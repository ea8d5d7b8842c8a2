"""enc selfcal: graduation error (and radial motion) of a scale from several of its heads.

Its ``--method`` choices and their help are the registry's
(:mod:`enctools.methods.selfcal_methods`), read when they are shown or checked, so a
method registered before the command runs is offered and one unregistered is refused;
enc design takes its ``--method`` the same way (:func:`method_option`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import click

from enctools.cli import options, runner, usage


class MethodChoice(click.Choice):
    """The methods the registry offers a command, read when they are needed."""

    def __init__(self, command: str) -> None:
        self.command = command
        super().__init__([])

    @property  # type: ignore[override]
    def choices(self) -> Sequence[str]:
        from enctools.methods import selfcal_methods

        return selfcal_methods.names(self.command)

    @choices.setter
    def choices(self, value: Sequence[str]) -> None:
        pass


class MethodOption(click.Option):
    """``--method``: its help is a line per method of the registry, then ``tail``."""

    def __init__(self, *args: Any, command: str = "selfcal", tail: str = "",
                 **kwargs: Any) -> None:
        self.command, self.tail = command, tail
        kwargs["type"] = MethodChoice(command)
        super().__init__(*args, **kwargs)

    @property
    def help(self) -> str:
        from enctools.methods import selfcal_methods

        lines = [f"{m.name}: {m.about}" for m in selfcal_methods.records(self.command)]
        return "; ".join(lines) + (f" ({self.tail})" if self.tail else ".")

    @help.setter
    def help(self, value: str | None) -> None:
        pass


#: what sets the sample interval of a run: the recording's option
ACQUIRE_INTERVAL = "enc acquire --interval"


def method_option(command: str, tail: str) -> Callable[..., Any]:
    """``--method NAME`` of ``command`` (``"selfcal"``, ``"design"``): one of the
    registry's methods, default None (the registry's default for the number of heads)."""
    return click.option("--method", cls=MethodOption, command=command, tail=tail,
                        default=None)


usage.FIELD_FLAGS["selfcal"] = {"interval_s": ACQUIRE_INTERVAL}


@usage.renamed({"--ref": "--ref-head", "--reference": "--ref-head"})
@click.command("selfcal")
@options.input_arg
@method_option("selfcal", "default: esa with 4 heads, else fourier")
@click.option("--ref-head", "ref", default=None, metavar="HEAD",
              shell_complete=options.complete_heads,
              help="Reference head (default: the encoder's head nearest 0 deg).")
@options.heads("The other heads (default: the encoder's heads that do not measure).")
@options.heads("Heads whose mean is the angle coordinate (default: the encoder's measuring "
               "heads, else the reference).", flag="--angle-from", dest="angle_from")
@options.band("Highest harmonic K solved for.")
@options.points("Points of the output angle grid.", 1024)
@options.min_transfer("Harmonics whose normalised |W(n)| is below this are ill-conditioned.")
@options.strict
@options.spectrum("Also write the spectrum (|W(n)|, u per harmonic) to FILE.")
@options.json_summary
@options.unit
@options.outputs
@options.verbosity
def command(input: str | None, method: str | None, ref: str | None, heads: list[str] | None,
            angle_from: list[str] | None, band: int, points: int, min_transfer: float,
            strict: bool, spectrum_path: str | None, as_json: bool, unit: str,
            output: str | None, force: bool, fmt: str | None) -> None:
    """Self-calibrate a scale's graduation error from a continuous run of its heads.

    Reads a readings stream, averages the revolutions and writes a deviations
    stream: the graduation error [arcsec] on a uniform grid of the scale angle, its
    standard uncertainty, and with esa the spindle's radial error motion x, y [nm].
    """
    from enctools.cli import summary
    from enctools.data import streams
    from enctools.data.files import OutputGroup
    from enctools.methods import selfcal

    settings = selfcal.Settings(method=method, ref=ref,
                                heads=None if heads is None else tuple(heads),
                                angle_from=None if angle_from is None else tuple(angle_from),
                                band=band, points=points, min_transfer=min_transfer,
                                strict=strict)
    options.check_curve_outputs(output, spectrum_path, force, fmt, as_json)
    source = streams.open_input(input, "readings")
    deviations, spectrum = selfcal.run(source, settings, runner.Progress("revolutions", "rev"))
    with OutputGroup() as outputs:  # both files, or neither
        if spectrum_path is not None:
            streams.write_table(spectrum_path,
                                streams.with_history(spectrum[0], output=spectrum_path),
                                spectrum[1], force, group=outputs, unit=unit)
        streams.write_table(output, streams.with_history(deviations[0], output=output),
                            deviations[1], force, fmt, group=outputs, unit=unit)
    meta = deviations[0].meta
    summary.emit({"method": meta["settings"].get("method"),
                  "n_revolutions": meta["settings"].get("revolutions"),
                  "blind": list(meta.get("blind", [])),
                  "ill_conditioned": list(meta.get("ill_conditioned", [])),
                  "blind_radial": (list(meta["blind_radial"]) if "blind_radial" in meta
                                   else None),
                  "n_iterations": sum(meta["iterations"][k] for k in ("first_revolution", "mean")),
                  "last_change_arcsec": meta["iterations"]["last_change_arcsec"],
                  "curves": summary.curves(*deviations)}, as_json, unit)
