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
