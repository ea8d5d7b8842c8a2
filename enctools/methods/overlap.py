"""One step of a per-item computation on a worker thread, overlapped with the caller's next.

A streaming method reads its items (revolutions) on the stream's reader thread and, on
the caller's thread, both analyses each and folds the analysis into its running sums.
:func:`ahead` moves the analysis (the compiled kernel, FFTs: work that releases the GIL)
to one worker thread that runs up to ``depth`` items ahead, so that on two cores a filter
costs about the largest of its reading, its analysis and its folding, not the sum of the
last two. Items are still taken, and results still yielded, in order on the caller's
thread; memory holds at most ``depth`` + 1 items.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")
R = TypeVar("R")

#: items analysed ahead of the caller: two keep the worker busy while the caller folds one
DEPTH = 2


def ahead(items: Iterable[T], work: Callable[[T], R], depth: int = DEPTH
          ) -> Iterator[tuple[T, R]]:
    """``(item, work(item))`` for each of ``items`` in order, ``work`` run on one worker
    thread at most ``depth`` items ahead of the caller.

    ``work`` must not touch state the caller changes meanwhile; each call sees the items
    in order (one worker). Its exception is raised here, at its item; one raised by
    ``items`` or by the caller (closing the generator) waits for the running ``work`` and
    drops the rest.
    """
    from collections import deque
    from concurrent.futures import Future, ThreadPoolExecutor

    if depth < 1:
        raise ValueError(f"depth must be at least 1, not {depth}")
    pool = ThreadPoolExecutor(1, thread_name_prefix="enc-work")
    pending: deque[tuple[T, Future[R]]] = deque()
    try:
        for item in items:
            pending.append((item, pool.submit(work, item)))
            if len(pending) > depth:
                first, done = pending.popleft()
                yield first, done.result()
        while pending:
            first, done = pending.popleft()
            yield first, done.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
