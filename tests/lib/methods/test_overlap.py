"""overlap.ahead: results in order, on one worker thread, a bounded number of items ahead;
failures of the work, of the items and of the caller end it cleanly."""

from __future__ import annotations

import threading

import pytest

from enctools.methods.overlap import ahead


def test_results_come_in_order_each_with_its_item_and_off_the_callers_thread():
    caller = threading.get_ident()
    seen: list[int] = []

    def work(x: int) -> tuple[int, int]:
        seen.append(threading.get_ident())
        return x * x, threading.get_ident()

    got = list(ahead(range(50), work))
    assert [item for item, _ in got] == list(range(50))
    assert [r[0] for _, r in got] == [x * x for x in range(50)]
    assert len(set(seen)) == 1 and caller not in seen  # one worker, not the caller


def test_at_most_depth_items_are_taken_ahead_of_the_caller():
    taken = 0

    def items():
        nonlocal taken
        for x in range(20):
            taken += 1
            yield x

    for depth in (1, 2, 4):
        taken = 0
        for item, _ in ahead(items(), lambda x: x, depth):
            # the item yielded, then at most depth more already taken from items
            assert taken <= item + 1 + depth


def test_a_failed_work_is_raised_at_its_item_and_the_earlier_results_are_kept():
    def work(x: int) -> int:
        if x == 3:
            raise ValueError("bad item 3")
        return x

    got = []
    with pytest.raises(ValueError, match="bad item 3"):
        for item, _ in ahead(range(10), work):
            got.append(item)
    assert got == [0, 1, 2]


def test_a_failure_of_the_items_waits_for_the_running_work_and_leaves_no_thread():
    done = []

    def items():
        yield from range(3)
        raise RuntimeError("truncated stream")

    before = threading.active_count()
    with pytest.raises(RuntimeError, match="truncated stream"):
        for _ in ahead(items(), done.append):
            pass
    assert threading.active_count() == before


def test_a_caller_that_stops_early_leaves_no_thread_and_drops_the_rest():
    calls = []
    before = threading.active_count()
    gen = ahead(range(1000), calls.append, depth=2)
    next(gen)
    gen.close()
    assert threading.active_count() == before
    assert len(calls) <= 4  # the one taken, the two ahead, at most one more running


def test_depth_below_one_is_refused():
    with pytest.raises(ValueError, match="depth"):
        list(ahead([1], lambda x: x, 0))
