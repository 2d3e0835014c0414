"""How much memory this process can still use: the one reader of the machine's memory.

Used by the memory estimate of a case (refusing grids the machine cannot hold) and by the kernel
set-up (choosing how many depth blocks to keep at once). Linux's ``MemAvailable``, else the
physical pages, never more than what is left below the process's cgroup limit.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["CGROUP_LIMIT", "CGROUP_USAGE", "MEMINFO", "available_memory"]

#: Where Linux says how much memory can be given to a process without swapping.
MEMINFO = Path("/proc/meminfo")
#: The memory limit and use of this process's cgroup (v2), when it has one.
CGROUP_LIMIT = Path("/sys/fs/cgroup/memory.max")
CGROUP_USAGE = Path("/sys/fs/cgroup/memory.current")


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
    batch job's memory limit).
    """
    available = _meminfo_available()
    if available is None:
        available = _sysconf_available()
    limit, usage = _read_int(CGROUP_LIMIT), _read_int(CGROUP_USAGE)
    if limit is not None:
        available = min(available, max(limit - (usage or 0), 0))
    return available


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
