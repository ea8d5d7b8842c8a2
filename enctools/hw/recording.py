"""A live run written as it is read: every batch to every output, and on any ending the
outputs closed with every batch read.

:func:`open_outputs` opens the outputs of a run (a copy first, then the stream itself),
:func:`record` pumps the batches of a run into them. The copy is written first: a pipe
closed downstream finds the batch already in it. SIGINT and SIGTERM are held except
while waiting for the next batch (the device), so the files hold whole batches and a
batch read is never dropped on its way. An output that fails (disk full) is dropped: the
batch still goes to the others, the run stops, and the others are closed with every
batch read; the error then names the output that failed and where the rows were kept.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import signal
import threading
from collections.abc import Iterable, Iterator, Sequence
from typing import Any

import pyarrow as pa

from enctools.data.streams import Header, OutputStream
from enctools.errors import Interrupted, OutputError, ending_signals

log = logging.getLogger("enctools")


def open_outputs(header: Header, targets: Sequence[tuple[str | None, str | None]],
                 force: bool = False, unit: str | None = None) -> list[OutputStream]:
    """The outputs of a run, each ``(path, format)`` (path None: stdout; format None: by
    the extension), kept whole however the run ends; none is left if one cannot open.
    ``unit``: of the angle errors in a CSV or TSV output (arcsec unless given)."""
    outs: list[OutputStream] = []
    try:
        for path, fmt in targets:
            outs.append(OutputStream(path, header, force, fmt, keep_partial=True, unit=unit))
    except BaseException:
        for o in outs:
            o.abort(False)
        raise
    return outs


def record(batches: Iterable[pa.RecordBatch], outs: Sequence[OutputStream]) -> int:
    """Write every batch to every output as it arrives; the rows read.

    Whatever ends the run (a device fault, a signal, the pipe downstream closed) ends it
    after the outputs are closed with what they hold, and is raised again (a closed pipe
    logged); outputs that failed raise one :class:`OutputError` naming them and where the
    rows are kept. Signals are handled as described above from the main thread only.
    """
    failed: dict[OutputStream, BaseException] = {}
    with _SignalGuard() as guard:
        ending, rows = _pump(iter(batches), outs, failed, guard)
        kept = _finish(outs, failed, ending)
        if ending is None and guard.pending is not None:
            ending = guard.interruption()
    broken = {o: e for o, e in failed.items() if not closed_pipe(e)}
    if broken:
        raise _output_failure(broken, kept, rows)
    if ending is not None:
        if closed_pipe(ending):
            log.info("the pipe downstream closed after %d rows; kept in %s", rows,
                     ", ".join(kept) or "no file")
        raise ending
    return rows


def closed_pipe(exc: BaseException) -> bool:
    """Whether ``exc`` is the pipe downstream closed."""
    return isinstance(exc, BrokenPipeError) or (isinstance(exc, OSError)
                                                and exc.errno == errno.EPIPE)


def _pump(it: Iterator[pa.RecordBatch], outs: Sequence[OutputStream],
          failed: dict[OutputStream, BaseException],
          guard: _SignalGuard) -> tuple[BaseException | None, int]:
    """Write the batches to every output until the end: the exception that ended the run
    (None: all read) and the rows read. ``failed``: the outputs that failed, with why."""
    rows = 0
    batch = None  # read, not yet written (a signal just as the wait ends)
    try:
        while True:
            with guard.released():
                batch = next(it, None)
            if batch is None:
                return None, rows
            got, batch = batch, None
            rows += _to_all(outs, got, failed)
            if failed:
                raise next(iter(failed.values()))
    except BaseException as exc:  # noqa: BLE001 - every ending closes the outputs first
        guard.hold()
        if batch is not None:
            rows += _to_all(outs, batch, failed)
        with contextlib.suppress(Exception):
            close = getattr(it, "close", None)
            if close is not None:
                close()  # stop the table and the sampling
        return exc, rows


def _to_all(outs: Sequence[OutputStream], batch: pa.RecordBatch,
            failed: dict[OutputStream, BaseException]) -> int:
    """Write a batch to every output that has not failed; its rows."""
    for o in outs:
        if o not in failed:
            try:
                o.write(batch)
            except Exception as exc:  # noqa: BLE001 - the batch still goes to the others
                failed[o] = exc
    return int(batch.num_rows)


def _finish(outs: Sequence[OutputStream], failed: dict[OutputStream, BaseException],
            ending: BaseException | None) -> list[str]:
    """Close the outputs: the failed ones leave nothing, the others keep what they hold
    (unless the ending is bad usage or input). The names of the outputs kept."""
    kept = []
    for o in outs:
        if o in failed:
            o.abort(False)
        elif ending is None or o.keeps(ending):
            try:
                o.close()
            except Exception as exc:  # noqa: BLE001 - reported with the others' failures
                failed[o] = exc
                o.abort(False)
                continue
            kept.append(o.path or "stdout")
        else:
            o.abort(False)
    return kept


def _output_failure(failed: dict[OutputStream, BaseException], kept: list[str],
                    rows: int) -> OutputError:
    """One error for outputs that could not be written: which, why, and where the rows are."""
    why = "; ".join(e.template if isinstance(e, OutputError)
                    else f"output {o.path or 'stdout'}: {e}" for o, e in failed.items())
    where = (f"the {rows} rows read are kept in {' and '.join(kept)}" if kept
             else "no output could keep them")
    return OutputError(f"{why}; {where}", next(iter(failed)).path)


class _SignalGuard:
    """SIGINT -> KeyboardInterrupt (130), SIGTERM and the other ``ENDING_SIGNALS`` ->
    Interrupted (128 + the number); held (deferred) except inside :meth:`released`.
    Outside the main thread, signals are left alone."""

    def __init__(self) -> None:
        self._held = True
        self.pending: int | None = None
        self._old: dict[int, Any] = {}

    def __enter__(self) -> _SignalGuard:
        if threading.current_thread() is threading.main_thread():
            for sig in ending_signals():  # an ignored one stays ignored
                self._old[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)

    def interruption(self) -> BaseException:
        """The exception of the signal received."""
        if self.pending is None or self.pending == signal.SIGINT:
            return KeyboardInterrupt()
        return Interrupted.by_signal(self.pending)

    def _handle(self, signum: int, frame: Any) -> None:
        if self.pending is None:
            self.pending = signum
        if not self._held:
            raise self.interruption()

    def hold(self) -> None:
        """Defer signals again (the end of a wait that a signal cut short)."""
        self._held = True

    @contextlib.contextmanager
    def released(self) -> Iterator[None]:
        """Let a signal stop the run at once (a wait for the device)."""
        if self.pending is not None:
            raise self.interruption()
        self._held = False
        try:
            yield
        finally:
            self._held = True
