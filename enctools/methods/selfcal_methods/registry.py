"""The self-calibration methods by name: one :class:`~.base.SelfcalMethod` each.

enc selfcal, enc design and their command lines read the methods from here, never a
list of names: a method is one module of this package calling :func:`register` (found
and imported on first use), or one :func:`register` call of one's own before the run.
The modules stay light: numpy is imported when a method computes, so a command's help
lists the methods without it.
"""

from __future__ import annotations

from enctools.errors import SettingsError
from enctools.methods.selfcal_methods.base import SelfcalMethod
from enctools.registry import Registry

__all__ = ["default", "find", "get", "names", "records", "register", "unregister"]

#: the methods, registered by the modules of this package (its others are not methods)
_METHODS: Registry[SelfcalMethod] = Registry(
    "self-calibration method", lambda m: m.name, __name__.rpartition(".")[0],
    skip=frozenset({"base", "registry"}))
#: add a method (a name registered twice is an error unless ``replace``); the record
register = _METHODS.register
#: remove the method ``name`` (one registered for a while, as a test does)
unregister = _METHODS.unregister


def records(command: str) -> list[SelfcalMethod]:
    """The methods ``command`` (``"selfcal"``, ``"design"``) offers, in its order."""
    return sorted((m for m in _METHODS.values() if command in m.listed),
                  key=lambda m: (m.listed[command], m.name))


def names(command: str) -> tuple[str, ...]:
    """The names of the methods ``command`` offers, in its order."""
    return tuple(m.name for m in records(command))


def find(name: str | None, command: str) -> SelfcalMethod | None:
    """The method ``name`` if ``command`` offers it, else None."""
    found = _METHODS.find(name or "")
    return found if found is not None and command in found.listed else None


def get(name: str, command: str) -> SelfcalMethod:
    """The method ``name`` that ``command`` offers; SettingsError naming `method` and
    the methods offered when there is none."""
    found = find(name, command)
    if found is None:
        msg = f"`method` must be one of {', '.join(names(command))}, not {name!r}"
        raise SettingsError(msg)
    return found


def default(count: int, command: str) -> SelfcalMethod:
    """The method chosen for ``count`` heads when none is given: the first by rank whose
    ``default_for`` takes them."""
    fits = [m for m in records(command) if m.default_for(count)]
    if not fits:
        msg = f"no self-calibration method takes {count} heads by default: give `method`"
        raise SettingsError(msg)
    return min(fits, key=lambda m: (m.rank, m.name))
