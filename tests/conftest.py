"""Test-session settings shared by every test module."""

from __future__ import annotations

import os

# The kernel cache is off in the tests (each test computes its kernels, as before the cache):
# the tests must not read or fill the user's cache, nor depend on what an earlier run left
# there. tests/test_kernel_cache.py switches it on in temporary directories.
os.environ["SACFLOW_CACHE_DIR"] = "off"
