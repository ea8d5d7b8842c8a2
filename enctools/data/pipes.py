"""Pipes and read-ahead: what lets a filter keep pace with its neighbours in a pipeline.

- :class:`Prefixed`: a read-only file made of bytes already read (the magic number)
  and the rest of a pipe; it can be told to stop waiting on a quiet pipe.
- :class:`ReadAhead`: iterate on a daemon thread a few items ahead of the caller, so
  reading (which releases the GIL) overlaps the caller's work.
- :func:`one_stream`: the batches of an Arrow IPC stream, and nothing after its end.
- :func:`enlarge_pipe`: ask the kernel for a larger pipe buffer (Linux).
"""

from __future__ import annotations

import io
import os
from collections.abc import Iterator
from typing import IO, Any

from enctools.errors import DataError


class Cancelled(Exception):
    """A read given up because the reader of the stream was told to stop."""


class Prefixed(io.RawIOBase):
    """A read-only file: some bytes already read, then the rest of another file.

    With ``cancel`` and a pipe under ``rest``, every read first waits (in 50 ms
    polls) for the pipe to be readable and raises :class:`Cancelled` once ``cancel``
    is set: a read-ahead thread is never stuck in a read of a pipe whose writer went
    quiet.
    """

    def __init__(self, prefix: bytes, rest: IO[bytes], cancel: Any = None) -> None:
        self._prefix = prefix
        self._rest = rest
        self._cancel = cancel
        self.owner: Any = None  # an object to keep alive as long as this file
        self._poll: Any = None
        if cancel is not None:
            import select

            self._poll = select.poll()
            self._poll.register(rest.fileno(), select.POLLIN | select.POLLPRI)

    def readable(self) -> bool:
        return True

    def readinto(self, b: Any) -> int:
        if self._prefix:
            n = min(len(b), len(self._prefix))
            b[:n] = self._prefix[:n]
            self._prefix = self._prefix[n:]
            return n
        if self._poll is not None:
            while not self._poll.poll(50):
                if self._cancel.is_set():
                    raise Cancelled("read-ahead stopped")
        readinto = getattr(self._rest, "readinto", None)
        if readinto is not None:
            return int(readinto(b))  # straight into Arrow's buffer: no extra copy
        data = self._rest.read(len(b))  # a file object without readinto
        n = len(data)
        b[:n] = data
        return n


def read_fully(f: IO[bytes], n: int) -> bytes:
    out = b""
    while len(out) < n:
        chunk = f.read(n - len(out))
        if not chunk:
            break
        out += chunk
    return out


def one_stream(reader: Any, f: IO[bytes], source: str) -> Iterator[Any]:
    """The record batches of the Arrow IPC stream ``reader`` reads from ``f``, then a
    check that ``f`` ends there: a second stream concatenated after the first one's
    end-of-stream marker, or any other bytes, are a DataError, not silently dropped."""
    yield from reader
    if f.read(1):
        msg = (f"{source}: more bytes follow the end of the Arrow stream (a second stream "
               "or other data); a command reads one stream")
        raise DataError(msg)


class _Failed:
    """An exception raised on the reader thread, to be raised again in the caller's."""

    def __init__(self, exc: BaseException) -> None:
        self.exc = exc


class ReadAhead:
    """Iterate ``items`` on a daemon thread, at most ``depth`` items ahead of the caller.

    Exceptions of the reader are raised in the caller's thread at the point they
    occurred. :meth:`stop` ends the thread after its current item: the thread must
    not outlive the caller into interpreter shutdown, where a daemon thread inside
    Arrow's C++ aborts the process. ``event`` (set by :meth:`stop`) also interrupts
    a wait on a pipe (:class:`Prefixed`).
    """

    _END = object()

    def __init__(self, items: Iterator[Any], depth: int, event: Any = None) -> None:
        import queue
        import threading

        self._queue: queue.Queue[Any] = queue.Queue(maxsize=depth)
        self._stop = event if event is not None else threading.Event()
        self._thread = threading.Thread(target=self._work, args=(items,), daemon=True,
                                        name="enc-read-ahead")
        self._thread.start()

    def _put(self, item: Any) -> bool:
        import queue

        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def _work(self, items: Iterator[Any]) -> None:
        try:
            for item in items:
                if not self._put(item):
                    return
            self._put(self._END)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread
            self._put(_Failed(exc))

    def __iter__(self) -> ReadAhead:
        return self

    def __next__(self) -> Any:
        item = self._queue.get()
        if item is self._END:
            self._queue.put(self._END)  # stay exhausted
            raise StopIteration
        if isinstance(item, _Failed):
            raise item.exc
        return item

    def stop(self, timeout: float = 10.0) -> bool:
        """Stop the reader; True once it has ended (within ``timeout`` [s])."""
        self._stop.set()
        self._thread.join(timeout)
        return not self._thread.is_alive()


#: pipe buffer asked for on the pipes a command reads and writes (Linux F_SETPIPE_SZ)
PIPE_BUFFER = 1 << 20


def read_at_most(raw: IO[bytes], limit: int) -> bytes:
    """What a pipe holds up to its end, or the first ``limit`` + 1 bytes of it."""
    parts, n = [], 0
    while n <= limit:
        chunk = raw.read(min(1 << 20, limit + 1 - n))
        if not chunk:
            break
        parts.append(chunk)
        n += len(chunk)
    return b"".join(parts)


def enlarge_pipe(f: Any, size: int = PIPE_BUFFER) -> int | None:
    """Ask for a ``size``-byte kernel buffer on the pipe behind ``f``; its size, or None.

    The default 64 KiB makes a reader of a fast producer wake up for every 64 KiB
    and roughly halves the throughput of a pipeline; anything that is not a pipe,
    a system without F_SETPIPE_SZ, or a size above the user's limit
    (/proc/sys/fs/pipe-max-size) leaves things as they are.
    """
    import stat

    try:
        fd = f if isinstance(f, int) else f.fileno()
        if not stat.S_ISFIFO(os.fstat(fd).st_mode):
            return None
        import fcntl

        setsz = getattr(fcntl, "F_SETPIPE_SZ", 1031)
        getsz = getattr(fcntl, "F_GETPIPE_SZ", 1032)
        if fcntl.fcntl(fd, getsz) >= size:
            return fcntl.fcntl(fd, getsz)
        return fcntl.fcntl(fd, setsz, size)
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        return None


def is_fifo(f: IO[bytes]) -> bool:
    import stat

    try:
        return stat.S_ISFIFO(os.fstat(f.fileno()).st_mode)
    except (OSError, ValueError, io.UnsupportedOperation):
        return False
