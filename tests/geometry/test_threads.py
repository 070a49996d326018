import threading
import time

import numpy as np
import pytest

from conformorph.geometry.threads import available_threads, map_in_threads, row_blocks


def test_results_in_item_order_whatever_the_finishing_order():
    def slow_first(i):
        time.sleep(0.02 if i == 0 else 0.0)  # item 0 finishes last
        return i * i

    assert map_in_threads(slow_first, range(6), threads=3) == [0, 1, 4, 9, 16, 25]
    assert map_in_threads(slow_first, [], threads=3) == []
    assert map_in_threads(slow_first, [7], threads=3) == [49]


def test_runs_on_several_threads_and_on_the_caller_with_one():
    seen = set()
    barrier = threading.Barrier(2, timeout=5)

    def meet(i):
        seen.add(threading.get_ident())
        barrier.wait()  # only passes if two items run at the same time
        return i

    assert map_in_threads(meet, [0, 1], threads=2) == [0, 1]
    assert len(seen) == 2
    idents = map_in_threads(lambda _: threading.get_ident(), range(3), threads=1)
    assert set(idents) == {threading.get_ident()}


def test_first_failing_item_in_order_raises_after_all_ran():
    ran = []

    def f(i):
        if i == 3:
            time.sleep(0.02)
        ran.append(i)
        if i in (1, 3):
            raise ValueError(f"item {i}")
        return i

    with pytest.raises(ValueError, match="item 1"):
        map_in_threads(f, range(5), threads=2)
    assert sorted(ran) == [0, 1, 2, 3, 4]


def test_same_numbers_as_one_thread():
    rng = np.random.default_rng(0)
    blocks = [rng.standard_normal((200, 3)) for _ in range(5)]
    fn = lambda x: np.sort(np.linalg.norm(x, axis=1))  # noqa: E731
    for a, b in zip(map_in_threads(fn, blocks), map_in_threads(fn, blocks, threads=1), strict=True):
        np.testing.assert_array_equal(a, b)


def test_validation_and_available_threads():
    assert 1 <= available_threads() <= 8
    with pytest.raises(ValueError, match="threads"):
        map_in_threads(abs, [1], threads=0)


def test_row_blocks_bound_rows_and_feed_every_thread(monkeypatch):
    import importlib

    th = importlib.import_module("conformorph.geometry.threads")
    monkeypatch.setattr(th, "available_threads", lambda: 2)
    x = np.arange(10_000)
    sizes = [b.size for b in row_blocks(x, 4096, 1024)]
    assert sizes == [3334, 3333, 3333] and np.array_equal(
        np.concatenate(row_blocks(x, 4096, 1024)), x
    )
    assert [b.size for b in row_blocks(x[:3000], 4096, 1024)] == [1500, 1500]  # one per thread
    assert [b.size for b in row_blocks(x[:1500], 4096, 1024)] == [1500]  # too few to split
    assert [b.size for b in row_blocks(x[:0], 4096, 1024)] == [0]


def test_the_callers_errstate_holds_on_every_thread():
    """np.errstate is a context variable: the worker threads run in the caller's context,
    so an overflow the caller chose to ignore warns nowhere, and one it made an error raises."""
    import warnings

    def overflow(_):
        return np.float64(1e300) * np.float64(1e300)

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with np.errstate(over="ignore"):
            assert map_in_threads(overflow, range(4), threads=2) == [np.inf] * 4
    with np.errstate(over="raise"), pytest.raises(FloatingPointError):
        map_in_threads(overflow, range(4), threads=2)
