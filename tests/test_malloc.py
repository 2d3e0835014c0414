"""glibc malloc settings: large arrays reuse freed heap memory instead of fresh pages."""

from __future__ import annotations

import platform
import subprocess
import sys

import pytest

from sacflow.machine.malloc import MALLOC_ENV, tune_malloc

GLIBC = platform.system() == "Linux" and platform.libc_ver()[0] == "glibc"

# A 2 MB array freed, then a 3 MB one: by default glibc maps the larger block afresh (its
# adaptive threshold only rose to 2 MB), so each of its pages faults; with the settings it is
# carved from the heap the first array left, and only the extra 1 MB faults. (Below 4 MB:
# numpy asks for huge pages for larger arrays, which fault 2 MB at a time.)
FAULTS = """
import resource, sys
import numpy as np
if sys.argv[1] == "tuned":
    from sacflow.machine.malloc import tune_malloc
    assert tune_malloc()
first, second = (int(v) * 2**20 // 8 for v in sys.argv[2:4])
a = np.ones(first); del a
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
b = np.ones(second)
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def faults(mode: str, env: dict[str, str] | None = None, sizes: tuple[int, int] = (2, 3)) -> int:
    """Page faults of the second array (sizes in MB of the first, freed, and the second)."""
    run = subprocess.run([sys.executable, "-c", FAULTS, mode, *map(str, sizes)],
                         capture_output=True, text=True, check=True, env=env)
    return int(run.stdout.split()[-1])


@pytest.mark.skipif(not GLIBC, reason="glibc only")
def test_tuned_process_reuses_freed_memory_for_a_larger_array():
    import os

    plain = {k: v for k, v in os.environ.items() if k not in MALLOC_ENV}
    default = faults("default", plain)
    tuned = faults("tuned", plain)
    from_env = faults("default", {**plain, **MALLOC_ENV})  # how campaign workers get it
    pages = 3 * 2**20 // 4096
    assert default > pages // 2, f"default glibc: {default} faults for {pages} pages"
    assert tuned < default / 2, f"tuned: {tuned} faults, default {default}"
    assert from_env < default / 2, f"environment: {from_env} faults, default {default}"


@pytest.mark.skipif(not GLIBC, reason="glibc only")
def test_tuned_process_reuses_a_freed_box_size_array():
    """A 48 MB array (a 128 × 128 × 64 box's vector of six components) freed, then another:
    above glibc's largest mmap threshold, so by default mapped and faulted in afresh; tuned,
    every block comes from the heap and the second array reuses the first's pages."""
    import os

    plain = {k: v for k, v in os.environ.items() if k not in MALLOC_ENV}
    default = faults("default", plain, (48, 48))
    tuned = faults("tuned", plain, (48, 48))
    from_env = faults("default", {**plain, **MALLOC_ENV}, (48, 48))
    huge_pages = 48 * 2**20 // (2 * 2**20)  # the fewest faults of a fresh 48 MB array
    assert default >= huge_pages, f"default glibc: {default} faults for 48 MB"
    assert tuned < default / 2, f"tuned: {tuned} faults, default {default}"
    assert from_env < default / 2, f"environment: {from_env} faults, default {default}"


def test_tune_malloc_reports_whether_it_applied():
    assert tune_malloc() is GLIBC
