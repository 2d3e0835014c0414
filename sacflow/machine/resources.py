"""How much memory this process can still use, and on how many cores it may run.

:func:`usable_cores` is the one reader of the cores this process may run on (its CPU
affinity): the default FFT thread count, and the most threads worth asking for.

Used by the memory estimate of a case (refusing grids the machine cannot hold), by the kernel
set-up (choosing how many depth blocks to keep at once) and by campaigns (how many cases a
machine's workers may run at once). Linux's ``MemAvailable``, else the physical pages, never
more than what is left below the process's cgroup limit, nor below its own limits
(``ulimit -v``, ``ulimit -d``): a case the machine could hold but the process may not allocate
is refused before it starts, not ended by numpy's ``_ArrayMemoryError`` minutes later.
"""

from __future__ import annotations

import os
import resource
from pathlib import Path

__all__ = [
    "CGROUP_LIMIT",
    "CGROUP_USAGE",
    "MEMINFO",
    "PROCESS_LIMITS",
    "PROC_STATUS",
    "available_memory",
    "process_limit_left",
    "usable_cores",
]

#: Where Linux says how much memory can be given to a process without swapping.
MEMINFO = Path("/proc/meminfo")
#: The memory limit and use of this process's cgroup (v2), when it has one.
CGROUP_LIMIT = Path("/sys/fs/cgroup/memory.max")
CGROUP_USAGE = Path("/sys/fs/cgroup/memory.current")
#: This process's memory use as the kernel counts it against its limits (``VmSize``, ``VmData``).
PROC_STATUS = Path("/proc/self/status")
#: The process's own limits and the use each is checked against (proc(5), getrlimit(2)):
#: ``RLIMIT_AS`` (``ulimit -v``) bounds the whole address space, ``VmSize`` -- virtual, not
#: resident: the kernel refuses an mmap/brk that would take ``VmSize`` above it, whatever is
#: resident, so ``getrusage``'s peak resident size is not the use to subtract; ``RLIMIT_DATA``
#: (``ulimit -d``) bounds the data segment and private writable mappings, ``VmData``.
PROCESS_LIMITS = ((resource.RLIMIT_AS, "VmSize"), (resource.RLIMIT_DATA, "VmData"))


def usable_cores() -> int:
    """Return the number of cores this process may run on (its affinity mask), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def _read_int(path: Path) -> int | None:
    """Read an integer file of the kernel (cgroup files), or None (absent, ``max``, unreadable)."""
    try:
        text = path.read_text().strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


def available_memory() -> int:
    """Memory [bytes] this process can still use without swapping.

    Linux's ``MemAvailable`` (``/proc/meminfo``: free memory plus what the page cache and
    reclaimable slabs can give back), else the available physical pages (``os.sysconf``);
    never more than what is left below the limit of this process's cgroup (a container's or a
    batch job's memory limit), nor below the process's own limits (:func:`process_limit_left`).
    """
    available = _meminfo_available()
    if available is None:
        available = _sysconf_available()
    limit, usage = _read_int(CGROUP_LIMIT), _read_int(CGROUP_USAGE)
    if limit is not None:
        available = min(available, max(limit - (usage or 0), 0))
    left = process_limit_left()
    return available if left is None else min(available, left)


def process_limit_left() -> int | None:
    """Bytes this process may still allocate under its own limits, or None when it has none.

    For each of :data:`PROCESS_LIMITS` with a (soft) limit: the limit minus the process's
    current use of it (``VmSize`` for ``RLIMIT_AS``, ``VmData`` for ``RLIMIT_DATA``, from
    :data:`PROC_STATUS`); the smallest of them.
    """
    left = None
    status = _proc_status()
    for kind, key in PROCESS_LIMITS:
        soft = resource.getrlimit(kind)[0]
        if soft == resource.RLIM_INFINITY:
            continue
        room = max(soft - status.get(key, 0), 0)
        left = room if left is None else min(left, room)
    return left


def _proc_status() -> dict[str, int]:
    """Read the ``Vm*`` sizes of :data:`PROC_STATUS` [bytes] (empty where there is none)."""
    sizes = {}
    try:
        with open(PROC_STATUS) as fh:
            for line in fh:
                key, _, value = line.partition(":")
                if key.startswith("Vm") and value.strip().endswith("kB"):
                    sizes[key] = int(value.split()[0]) * 1024
    except (OSError, ValueError):
        pass
    return sizes


def _meminfo_available() -> int | None:
    """``MemAvailable`` of :data:`MEMINFO` [bytes], or None without it."""
    try:
        with open(MEMINFO) as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024  # kB
    except (OSError, ValueError, IndexError):
        pass
    return None


def _sysconf_available() -> int:
    """Available (else all) physical pages times the page size [bytes]."""
    page = os.sysconf("SC_PAGE_SIZE")
    for name in ("SC_AVPHYS_PAGES", "SC_PHYS_PAGES"):
        try:
            pages = os.sysconf(name)
        except (ValueError, OSError):
            continue
        if pages > 0:
            return int(pages) * int(page)
    raise OSError("cannot tell how much memory this machine has")  # pragma: no cover
