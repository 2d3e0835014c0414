"""BLAS thread limit of the numerical core (sacflow.machine.threads)."""

import subprocess
import sys

CODE = """
import sys
import numpy  # its BLAS: loaded before the core runs, as by every module that calls it
from threadpoolctl import threadpool_info, threadpool_limits
from sacflow.machine.threads import single_threaded_blas

def blas_threads():
    return sorted(p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas")

with threadpool_limits(limits=2, user_api="blas"):
    with single_threaded_blas():
        inside = blas_threads()
    print(inside, blas_threads(), "scipy.linalg" in sys.modules)
    import scipy.linalg  # SciPy's own BLAS appears: limited too from the next block on
    before = blas_threads()
    with single_threaded_blas():
        inside = blas_threads()
    print(len(inside), set(inside), blas_threads() == before)
"""


def test_blas_limited_to_one_thread_without_importing_scipy_linalg_and_after_it():
    """numpy's BLAS is limited inside the block and restored after; scipy.linalg is not
    imported for it, and its BLAS, loaded later, is limited by the next block."""
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, check=True)
    first, second = out.stdout.splitlines()
    assert first == "[1] [2] False"
    count, limits = second.split(" ", 1)
    assert int(count) >= 1  # numpy's and SciPy's BLAS: two libraries with the pip wheels
    assert limits == "{1} True"  # every one of them limited inside, restored after


def test_over_ranges_covers_every_index_once_in_order_and_keeps_small_passes_on_one_thread():
    """Contiguous ranges in order, one per thread, the first on the caller; a pass below
    SPLIT_ITEMS stays whole on the calling thread."""
    import threading

    from sacflow.machine.threads import SPLIT_ITEMS, over_ranges

    def record(seen, first, last):
        seen.append((first, last))
        return first, last, threading.get_ident()

    count = 2 * SPLIT_ITEMS
    seen: list = []
    results = over_ranges(record, count, 3, seen)
    bounds = [r[:2] for r in results]
    assert len(bounds) == 3 and bounds[0][0] == 0 and bounds[-1][1] == count
    assert all(a[1] == b[0] for a, b in zip(bounds[:-1], bounds[1:], strict=True))  # contiguous
    assert max(b - a for a, b in bounds) - min(b - a for a, b in bounds) <= 1
    assert results[0][2] == threading.get_ident()
    assert all(r[2] != results[0][2] for r in results[1:])  # the others on the pool's threads
    assert sorted(seen) == [r[:2] for r in results]
    assert over_ranges(record, 100, 3, []) == [(0, 100, threading.get_ident())]
    assert over_ranges(record, 100, 3, [], weight=SPLIT_ITEMS)[-1][:2] == (67, 100)
    assert over_ranges(record, count, 1, [])[0][:2] == (0, count)
