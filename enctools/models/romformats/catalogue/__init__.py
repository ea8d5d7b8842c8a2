"""The correction-table formats of enctools: one module a format, each registering its
:class:`~enctools.models.romformats.record.TableFormat` record with
:func:`enctools.models.romformats.registry.register` when imported (the registry
imports them all on first use). The writers and readers they name live beside them
in :mod:`enctools.models.romformats`."""
