"""The command line's words for the library's settings, and the options' life cycle.

The library names a setting by its field, between backticks in an error's message
(``SettingsError("`band` must be >= 0")``);
this module is the one place that turns a field into the option a user typed:

- :func:`flag_for`: a field is the option whose click parameter has the field's name
  (``band`` -> ``--band``), else the entry of :data:`FIELD_FLAGS` (the command's own,
  then ``"*"``), else the field itself;
- :func:`message`: an error (:class:`~enctools.errors.EncError`, a ``SettingsError``
  mostly) as the command line shows it;
- :func:`renamed`: an option's old spelling kept for one release, with a warning;
- :class:`ModeCommand`: options that apply in one mode only, shown under their mode in
  ``--help`` and refused, in one line, in another mode.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Callable, Mapping
from typing import Any

import click
from click.core import ParameterSource

from enctools.errors import EncError

__all__ = ["FIELD_FLAGS", "RENAMED", "ModeCommand", "UsageError", "flag_for", "message",
           "renamed", "take_deferred"]


class UsageError(EncError):
    """Bad options or option values, said in the command line's words: exit 2. Only the
    commands raise it; the library names its settings by field (``SettingsError``)."""

    exit_code = 2


#: fields whose option is not spelt as the field: command name ("*": every command) ->
#: field -> the option (or words) that sets it
FIELD_FLAGS: dict[str, dict[str, str]] = {
    # options every command (that writes, or reports) has
    "*": {"force": "--force", "fmt": "--format", "format": "--format", "unit": "--unit",
          "as_json": "--json"},
    "make-rom": {"detection_unit_deg": "--detection-unit"},
    "correct": {"fmt": "--target", "detection_unit_deg": "--detection-unit"},
    "fit-rbf": {"goal_arcsec": "--goal", "allow_no_gain": "--allow-no-gain"},
    "history": {"history_dir": "DIR|URI", "old": "OLD", "new": "NEW",
                "retention_hours": "--retention-hours"},
}

#: the old spellings still accepted, with a warning: (command, old) -> new
RENAMED: dict[tuple[str, str], str] = {}
#: warnings found while the options are parsed, logged by the prologue
_DEFERRED: list[str] = []


def take_deferred() -> list[str]:
    """The warnings found while the options were parsed (an old spelling), for the
    prologue to log once the command's logging is set: ``enc CMD: WARNING: text``,
    silenced by -q."""
    taken = list(_DEFERRED)
    _DEFERRED.clear()
    return taken


def _long_opt(param: click.Parameter) -> str:
    opts = [o for o in param.opts if o.startswith("--")] or list(param.opts)
    return opts[0] if opts else str(param.name)


def flag_for(field: str, command: click.Command | None, name: str | None = None) -> str:
    """The option of ``command`` (called ``name``: ``make-rom``) that sets ``field``."""
    table = FIELD_FLAGS.get(name or "", {})
    if field in table:
        return table[field]
    if command is not None:
        for p in command.params:
            if isinstance(p, click.Option) and not p.hidden and p.name == field:
                return _long_opt(p)
        wanted = "--" + field.replace("_", "-").replace(".", "-")
        for p in command.params:
            if isinstance(p, click.Option) and not p.hidden and wanted in p.opts:
                return wanted
    return FIELD_FLAGS["*"].get(field, field)


def message(exc: EncError, command: click.Command | None, name: str | None = None) -> str:
    """``exc`` with its fields named as ``command``'s options."""
    return exc.render(lambda field: flag_for(field, command, name))


def renamed(spellings: Mapping[str, str]) -> Callable[[click.Command], click.Command]:
    """Decorator above ``@click.command``: each old spelling (``--ref``) of an option
    still sets the option now spelt ``spellings[old]`` (``--ref-head``) for one release,
    with a warning on stderr; both given is a usage error. The old spelling is hidden
    from ``--help`` and listed in :data:`RENAMED`."""
    def rename(command: click.Command) -> click.Command:
        pairs: list[tuple[str, click.Option, click.Option]] = []
        for old, new in spellings.items():
            target = next((p for p in command.params
                           if isinstance(p, click.Option) and new in p.opts), None)
            if target is None:
                msg = f"{command.name}: no option {new} to rename {old} to"
                raise ValueError(msg)
            alias = copy.copy(target)
            alias.opts, alias.secondary_opts = [old], []
            alias.name = f"{target.name}__{old.lstrip('-').replace('-', '_')}"
            alias.hidden, alias.required, alias.envvar = True, False, None
            alias.default = False if target.is_flag else None
            command.params.append(alias)
            pairs.append((old, target, alias))
            RENAMED[(str(command.name), old)] = new
        callback = command.callback
        if callback is None:
            return command

        @functools.wraps(callback)
        def merged(*args: Any, **kwargs: Any) -> Any:
            ctx = click.get_current_context()
            for old, target, alias in pairs:
                value = kwargs.pop(str(alias.name))
                if ctx.get_parameter_source(str(alias.name)) != ParameterSource.COMMANDLINE:
                    continue
                new = _long_opt(target)
                if ctx.get_parameter_source(str(target.name)) == ParameterSource.COMMANDLINE:
                    msg = f"{old} is the old spelling of {new}: give {new} alone"
                    raise UsageError(msg)
                _DEFERRED.append(
                    f"{old} is now spelt {new}; {old} will not be accepted after this release")
                kwargs[str(target.name)] = value
            return callback(*args, **kwargs)

        command.callback = merged
        return command

    return rename


class ModeCommand(click.Command):
    """A command whose options belong to modes: ``--help`` shows each mode's options
    under a heading of their own, and an option given on the command line in a mode it
    does not belong to is a usage error naming the mode it belongs to.

    ``modes``: heading -> the parameter names of that mode's options; ``mode_of``: the
    parsed parameters -> the heading of the mode chosen (None: no check); options in no
    mode apply in every mode. ``shared``: a heading of options that several modes take
    -> the headings of those modes.
    """

    def __init__(self, *args: Any, modes: Mapping[str, tuple[str, ...]] | None = None,
                 mode_of: Callable[[Mapping[str, Any]], str | None] | None = None,
                 shared: Mapping[str, tuple[str, ...]] | None = None,
                 **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.modes = dict(modes or {})
        self.mode_of = mode_of
        self.shared = dict(shared or {})

    def _mode(self, param: click.Parameter) -> str | None:
        return next((m for m, names in self.modes.items() if param.name in names), None)

    def format_options(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        common: list[tuple[str, str]] = []
        by_mode: dict[str, list[tuple[str, str]]] = {m: [] for m in self.modes}
        for p in self.get_params(ctx):
            # arguments are in the usage line, not among the options (as click's own)
            record = None if isinstance(p, click.Argument) else p.get_help_record(ctx)
            if record is None:
                continue
            mode = self._mode(p)
            (common if mode is None else by_mode[mode]).append(record)
        if common:
            with formatter.section("Options"):
                formatter.write_dl(common)
        for mode, rows in by_mode.items():
            if rows:
                with formatter.section(mode):
                    formatter.write_dl(rows)

    def invoke(self, ctx: click.Context) -> Any:
        if self.mode_of is not None:
            chosen = self.mode_of(ctx.params)
            if chosen is not None:
                for p in self.params:
                    mode = self._mode(p)
                    if (mode is not None and chosen not in self.shared.get(mode, (mode,))
                            and p.name is not None
                            and ctx.get_parameter_source(p.name) == ParameterSource.COMMANDLINE):
                        msg = f"{_long_opt(p)} applies to {mode}, not to {chosen}"
                        raise UsageError(msg)
        return super().invoke(ctx)
