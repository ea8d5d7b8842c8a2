"""Shell completion of values: rigs, and the heads of the input a command is given.

Click calls these while the user presses TAB, with the options and arguments typed so
far in ``ctx.params``. They must be quick and must never fail: anything that goes wrong
(no input yet, a pipe, a file that is not a stream) completes nothing.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import click

from enctools.errors import EncError

if TYPE_CHECKING:  # imported when completing, not by every command
    from click.shell_completion import CompletionItem

#: field-metadata roles whose columns a head option can name
_ROLES = ("head", "deviation")


def complete_rig(ctx: click.Context, param: click.Parameter,
                 incomplete: str) -> list[CompletionItem]:
    """--rig: the bundled rigs that match, then files (*.toml)."""
    from click.shell_completion import CompletionItem

    from enctools.data.rig import bundled_rigs

    names = [CompletionItem(n) for n in bundled_rigs() if n.startswith(incomplete)]
    return [*names, CompletionItem(incomplete, type="file")]


def complete_heads(ctx: click.Context, param: click.Parameter,
                   incomplete: str) -> list[CompletionItem]:
    """A head option (--heads H1,H2, --ref, --device): the heads of the input or rig.

    Names come from the input file's schema (columns with role head, or the curves of a
    deviations stream), else from the rig (``--rig``, ``ENC_RIG``). In a comma list the
    last name is completed and the names already given are not offered again.
    """
    from click.shell_completion import CompletionItem

    done, _, last = incomplete.rpartition(",")
    given = set(done.split(",")) if done else set()
    prefix = f"{done}," if done else ""
    try:
        path = ctx.params.get("input") or _input_from_words(ctx.command)
        names = _names_from_input(path) or _names_from_rig(ctx.params)
    except (EncError, OSError, ValueError):  # a bad file or rig offers nothing
        return []
    return [CompletionItem(prefix + n) for n in names
            if n.startswith(last) and n not in given]


def _input_from_words(command: click.Command) -> str | None:
    """INPUT as typed on the line being completed, when click could not parse it.

    An option still waiting for its value (``--ref<TAB>``) stops click's parser before
    it reaches the arguments, so the words are read from ``COMP_WORDS``, which the
    completion script of every shell sets: the first word after the command name that is
    neither an option nor the value of one.
    """
    from click.shell_completion import split_arg_string

    words = split_arg_string(os.environ.get("COMP_WORDS", ""))
    takes_value = {name for p in command.params if isinstance(p, click.Option)
                   and not p.is_flag and not p.count for name in p.opts + p.secondary_opts}
    skip = False
    for word in words[2:]:
        if skip:
            skip = False
        elif word.startswith("-") and word != "-":
            skip = word in takes_value
        else:
            return word
    return None


def _names_from_input(path: Any) -> list[str]:
    """The head (or curve) columns of the stream file ``path``: its header only."""
    if not isinstance(path, str) or path == "-" or not os.path.isfile(path):
        return []
    from enctools.data import streams
    from enctools.data.schemas import columns_with_role

    with streams.open_input(path) as s:
        for role in _ROLES:
            names = columns_with_role(s.schema, role)
            if names:
                return names
    return []


def _names_from_rig(params: dict[str, Any]) -> list[str]:
    """The heads of the rig named by --rig or ENC_RIG."""
    rig = params.get("rig") or os.environ.get("ENC_RIG")
    if not rig:
        return []
    from enctools.data.rig import load_rig

    return load_rig(rig).head_names
