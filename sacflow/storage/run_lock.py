"""One process per run file: the lock :class:`~sacflow.storage.run_writer.RunWriter` holds.

Two ``sacflow run`` of the same case into the same folder used to compute everything twice and
then trip over each other's part files (issue #31). While a run is being written, its writer
holds ``<out>/.<name>.nc.lock``: an exclusive ``flock`` on that file, which also records who
holds it (process id, host, start time, as JSON) for the message a second writer gets
(:class:`RunBusyError`). The operating system releases a ``flock`` when its process ends, however
it ends, so a lock file left by a killed process is simply taken over by the next writer: no
stale lock blocks a run. On a network file system the lock is as good as its ``flock`` (NFS v4
emulates it with byte-range locks); where the file system refuses locks, the run goes on
unlocked with a warning, and on Windows (no ``flock``) runs are not locked.
"""

from __future__ import annotations

import errno
import json
import os
import socket
import sys
import warnings
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sacflow.errors import SacflowError

if sys.platform != "win32":  # no flock on Windows: runs are written unlocked there
    import fcntl

__all__ = ["RunBusyError", "RunLock", "lock_path"]


class RunBusyError(SacflowError):
    """Another process is writing the run file (its pid, host and start time are named)."""


def lock_path(path: str | Path) -> Path:
    """Lock file of the run file ``path``: ``<folder>/.<name>.nc.lock``."""
    path = Path(path)
    return path.with_name(f".{path.name}.lock")


class RunLock:
    """Exclusive lock on the run file ``path`` for this process (see the module docstring).

    Parameters
    ----------
    path : str or Path
        The run file ``<out>/<name>.nc``.

    Raises
    ------
    RunBusyError
        From :meth:`acquire`, when another process holds it.
    """

    def __init__(self, path: str | Path) -> None:
        self.run_path = Path(path)
        self.path = lock_path(path)
        self._fd: int | None = None

    @property
    def held(self) -> bool:
        """Tell whether this object holds the lock."""
        return self._fd is not None

    def acquire(self) -> None:
        """Take the lock, or raise :class:`RunBusyError` naming the process holding it."""
        if sys.platform == "win32":  # pragma: no cover
            return
        while self._fd is None:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                holder = _read_holder(fd)
                os.close(fd)
                if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    raise RunBusyError(self._busy_message(holder)) from None
                warnings.warn(f"{self.path}: the file system refuses locks ({exc}); writing "
                              "the run unlocked", RuntimeWarning, stacklevel=2)
                return
            if not _same_file(fd, self.path):  # removed by its last holder meanwhile: retry
                os.close(fd)
                continue
            os.ftruncate(fd, 0)
            os.write(fd, json.dumps(_holder()).encode())
            self._fd = fd

    def release(self) -> None:
        """Remove the lock file and let the lock go (nothing when not held)."""
        if self._fd is None:
            return
        self.path.unlink(missing_ok=True)  # while still locked: the next writer makes its own
        os.close(self._fd)
        self._fd = None

    def _busy_message(self, holder: dict[str, Any]) -> str:
        who = (f"process {holder.get('pid', '?')} on host {holder.get('host', '?')}, "
               f"started {holder.get('started', '?')}")
        return (
            f"{self.run_path} is being written by another sacflow run ({who}; lock file "
            f"{self.path}). Nothing was changed. Wait for it to finish, or stop it, then run "
            "again: this case resumes after the steps it stored (a lock left by a process that "
            "has ended is taken over by itself)."
        )

    def __enter__(self) -> RunLock:
        """Acquire the lock."""
        self.acquire()
        return self

    def __exit__(self, *_: object) -> None:
        """Release the lock."""
        self.release()


def _holder() -> dict[str, Any]:
    """Who holds the lock: this process (pid, host, start time)."""
    return {"pid": os.getpid(), "host": socket.gethostname(),
            "started": datetime.now(UTC).isoformat(timespec="seconds")}


def _read_holder(fd: int) -> dict[str, Any]:
    """Read what the holder wrote in the lock file (empty when unreadable)."""
    try:
        data = json.loads(os.pread(fd, 4096, 0) or b"{}")
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _same_file(fd: int, path: Path) -> bool:
    """Tell whether the open file ``fd`` is still the one at ``path`` (not removed)."""
    try:
        return os.path.samestat(os.fstat(fd), os.stat(path))
    except FileNotFoundError:
        return False
