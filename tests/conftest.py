"""Test-session settings shared by every test module."""

from __future__ import annotations

import os

import pytest

from sacflow.machine.resources import usable_cores

# The kernel cache is off in the tests (each test computes its kernels, as before the cache):
# the tests must not read or fill the user's cache, nor depend on what an earlier run left
# there. tests/test_kernel_cache.py switches it on in temporary directories.
os.environ["SACFLOW_CACHE_DIR"] = "off"

#: Most test processes ``-n auto`` starts (pyproject.toml's addopts). The tests' grids are
#: small: most of their time is Python, one core each, so one process per core of the affinity
#: mask, up to this many: each process holds its own arrays, and a large machine's cores would
#: otherwise multiply the suite's memory.
MAX_TEST_WORKERS = 4


@pytest.hookimpl(tryfirst=True)
def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """Return how many processes ``-n auto`` runs the tests in (pytest-xdist's hook).

    ``PYTEST_XDIST_AUTO_NUM_WORKERS`` still decides when it is set; otherwise the cores this
    process may run on, at most :data:`MAX_TEST_WORKERS`. ``pytest -n 0`` runs in one process.
    """
    requested = os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS", "")
    if requested.isdigit():
        return int(requested)
    return min(usable_cores(), MAX_TEST_WORKERS)
