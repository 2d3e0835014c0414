"""glibc malloc settings for sacflow's own processes: large arrays reuse memory, not fresh pages.

By default glibc maps every block above an adaptive threshold (128 kB at first, raised up to
32 MB as such blocks are freed) straight from the kernel and unmaps it when freed; the next
array of that size is mapped again and each of its pages is zero-filled on first touch (a page
fault). A case allocates and frees arrays of 1-50 MB every step, so a fresh process faults its
working set in several times over during its first case, and pays it again for every array above
the threshold in later ones. The settings cut the page faults several times over, and with them
the system time of a case (``docs/performance.md``).

:data:`MALLOC_ENV` serves every block from the heap (none is mapped on its own: the threshold
cannot be raised above 32 MB, and the vectors of a 128 × 128 × 64 cuboid box are 48 MB) and
keeps up to 1 GB of freed heap for the next arrays instead of returning it to the kernel. On a
virtual machine a fresh page costs more than a pass of arithmetic over it, and two threads
that fault in the pages of one new array contend for the process's memory map, so a new
box-size array written by two threads can take longer than by one. The price is memory the heap
keeps: a strongly plastic step's peak grows by a few percent (``docs/performance.md``).

sacflow applies the settings only to processes it owns: the campaign workers (environment of
the local cluster's workers, see :mod:`sacflow.campaign`) and the ``sacflow run`` command
(:func:`tune_malloc`); a notebook's own process is left alone.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import platform

__all__ = ["MALLOC_ENV", "tune_malloc"]

#: Largest block served from the heap [bytes]: glibc's maximum on 64-bit (HEAP_MAX_SIZE / 2).
MMAP_THRESHOLD = 32 * 2**20
#: Freed memory at the top of the heap kept for reuse [bytes].
TRIM_THRESHOLD = 2**30
#: Blocks mapped on their own at most: none (every block from the heap).
MMAP_MAX = 0
#: The same settings as environment variables, read by glibc when a process starts.
MALLOC_ENV = {
    "MALLOC_MMAP_THRESHOLD_": str(MMAP_THRESHOLD),
    "MALLOC_TRIM_THRESHOLD_": str(TRIM_THRESHOLD),
    "MALLOC_MMAP_MAX_": str(MMAP_MAX),
}
_M_TRIM_THRESHOLD = -1  # mallopt parameter numbers, <malloc.h>
_M_MMAP_THRESHOLD = -3
_M_MMAP_MAX = -4


def tune_malloc() -> bool:
    """Apply :data:`MALLOC_ENV` to this running process with ``mallopt``.

    Returns True when applied, False where the C library is not glibc (nothing is changed).
    """
    if platform.system() != "Linux" or platform.libc_ver()[0] != "glibc":
        return False
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
    settings = ((_M_MMAP_THRESHOLD, MMAP_THRESHOLD), (_M_TRIM_THRESHOLD, TRIM_THRESHOLD),
                (_M_MMAP_MAX, MMAP_MAX))
    # a list, not a generator: every setting is applied even when an earlier one is refused
    return all([libc.mallopt(parameter, value) == 1 for parameter, value in settings])
