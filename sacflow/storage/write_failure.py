"""A run that cannot be written: a message naming the resource, not ``NetCDF: HDF error``.

When the disk fills up (``ENOSPC``), a quota is reached (``EDQUOT``), the file size limit
(``ulimit -f``, ``RLIMIT_FSIZE``: ``EFBIG``) is hit, or the device fails (``EIO``) while
:class:`~sacflow.storage.run_writer.RunWriter` writes a step or consolidates the run, HDF5
reports only ``NetCDF: HDF error`` (a ``RuntimeError``) and the errno is lost. :func:`reporting`
turns any such failure into :class:`RunWriteError`: the errno when Python has it, else what this
module finds (free space on the file system of the run, the file size limit), and that the
completed steps are kept (the writer keeps its sound parts) and resume at the next run.
"""

from __future__ import annotations

import errno
import resource
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from sacflow.errors import SacflowError

__all__ = ["LOW_FREE_BYTES", "RunWriteError", "describe_write_failure", "reporting"]

#: Free space below which a failed write is put down to a full disk [bytes].
LOW_FREE_BYTES = 64 << 20
#: errno values naming a resource, and what to say.
_RESOURCES = {
    errno.ENOSPC: "the disk is full (no space left on device)",
    errno.EDQUOT: "the disk quota is exceeded",
    errno.EFBIG: "the file size limit is reached (ulimit -f)",
    errno.EIO: "the device reported an input/output error",
    errno.EROFS: "the file system is read-only",
}


class RunWriteError(SacflowError):
    """A run file could not be written (disk full, quota, file size limit, device error)."""


def describe_write_failure(exc: BaseException, folder: Path) -> str:
    """Say which resource made a write in ``folder`` fail: from the errno, else by looking.

    Parameters
    ----------
    exc : BaseException
        The write's exception (``OSError`` with an errno, or netCDF's ``RuntimeError``).
    folder : Path
        Folder written in (its file system is examined when ``exc`` carries no errno).
    """
    code = getattr(exc, "errno", None)
    if code in _RESOURCES:
        return _RESOURCES[code]
    causes = []
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        free = None
    if free is not None and free < LOW_FREE_BYTES:
        causes.append(f"the disk is full ({free / 2**20:.1f} MiB free)")
    limit = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    if limit != resource.RLIM_INFINITY:
        causes.append(f"the file size limit (ulimit -f) is {limit} bytes")
    if not causes:
        causes.append("the disk or file system failed (full, quota, or a device error: see "
                      "the system log)")
    return "; ".join(causes)


@contextmanager
def reporting(what: str, path: Path, stored_steps: int) -> Iterator[None]:
    """Turn a failed write of ``what`` (of the run ``path``) into :class:`RunWriteError`.

    ``stored_steps`` completed steps stay on disk as parts; the message says they resume.
    """
    try:
        yield
    except (OSError, RuntimeError) as exc:
        if isinstance(exc, FileNotFoundError | PermissionError) and exc.errno not in _RESOURCES:
            raise
        resource_text = describe_write_failure(exc, path.parent)
        raise RunWriteError(
            f"{path}: writing {what} failed: {resource_text} ({type(exc).__name__}: {exc}). "
            f"The {stored_steps} completed steps are kept; free the resource and run the same "
            "case again to go on after them."
        ) from exc
