"""A registry of records by name, filled by the modules of one package.

The table formats (:mod:`enctools.models.romformats.registry`), the self-calibration
methods (:mod:`enctools.methods.selfcal_methods.registry`) and the instrument backends
(:mod:`enctools.hw.backends`) are each one :class:`Registry`: the modules of its package
register their records when first imported, and the package is imported on first use, so
that one more module is one more record; a record of one's own is one
:meth:`Registry.register` call (and :meth:`Registry.unregister` when done with it).
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable
from typing import Generic, TypeVar

__all__ = ["Registry"]

T = TypeVar("T")


class Registry(Generic[T]):
    """Records of one kind by name.

    ``what``: the kind in messages (``"table format"``); ``name``: a record's name;
    ``package``: the dotted name of the package whose modules register the records
    (those named in ``skip`` are not records).
    """

    def __init__(self, what: str, name: Callable[[T], str], package: str,
                 skip: frozenset[str] = frozenset()) -> None:
        self.what = what
        self._name = name
        self._package = package
        self._skip = skip
        self._records: dict[str, T] = {}
        self._found = False

    def register(self, record: T, replace: bool = False) -> T:
        """Add ``record``; a name registered already by another record is a ValueError
        unless ``replace``. Returns the record, for its module to keep."""
        self._discover()
        name = self._name(record)
        old = self._records.get(name)
        if old is not None and old is not record and not replace:
            msg = f"{self.what} {name!r} is registered already"
            raise ValueError(msg)
        self._records[name] = record
        return record

    def unregister(self, name: str) -> None:
        """Remove the record ``name`` (one registered for a while, as a test does)."""
        self._records.pop(name, None)

    def find(self, name: str) -> T | None:
        """The record ``name``, or None."""
        self._discover()
        return self._records.get(name)

    def values(self) -> list[T]:
        """Every record, in the order registered."""
        self._discover()
        return list(self._records.values())

    def _discover(self) -> None:
        """Import the package's modules, once: each registers its records."""
        if self._found:
            return
        self._found = True
        package = importlib.import_module(self._package)
        for info in pkgutil.iter_modules(package.__path__):
            if info.name not in self._skip:
                importlib.import_module(f"{self._package}.{info.name}")
