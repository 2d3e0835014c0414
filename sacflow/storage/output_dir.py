"""Output folders (``--out``): checked before anything is computed.

``sacflow run``, ``campaign`` and ``compare`` write into the folder given by ``--out``. It may
exist already (it must then be a folder) or not (it is created when the first file is written,
with its parents). A path that names a file, lies under a file, or where this user cannot
create a folder or write a file is reported in one line naming the path, what is wrong and the
fix -- before the first case is loaded or the first increment computed, not as a raw
``[Errno 17]`` after minutes of work. The check leaves nothing behind: an invalid case does
not leave an empty output folder.
"""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path

from sacflow.errors import OutputPathError

__all__ = ["COMMAND_LINE", "PYTHON", "check_output_dir", "prepare_output_dir"]

#: The fix printed with every problem (``{example}``: how the folder is given).
_FIX = "give a folder path you can write to (e.g. {example})"
#: How a folder is given on the command line, and to the Python functions (their parameter).
COMMAND_LINE, PYTHON = "--out", "out_dir"


def _fix(option: str) -> str:
    """Say the fix in the words of the option (``--out runs/``) or parameter (``out_dir=``)."""
    example = f"{option} runs/" if option.startswith("-") else f'{option}="runs"'
    return _FIX.format(example=example)
#: Prefix of the folder made (and removed at once) to see that folders can be made.
_PROBE_PREFIX = ".sacflow-out-check-"


def check_output_dir(path: str | Path, option: str = PYTHON) -> Path:
    """Check, without leaving anything behind, that ``path`` can be the output folder.

    ``path`` must be a folder or not exist; its nearest existing ancestor must be a folder in
    which this user can create a folder (tried: a folder is made there and removed at once,
    which also catches read-only file systems and places such as ``/proc``).

    Parameters
    ----------
    path : str or Path
        The folder (existing or not).
    option : str
        How the user gave it, for the message: a function's parameter (default ``out_dir``:
        :func:`sacflow.run`, :func:`sacflow.campaign.run_campaign`), or ``--out``.

    Returns
    -------
    Path
        ``path`` with ``~`` expanded.

    Raises
    ------
    OutputPathError
        When ``path`` is an existing file, lies under a file, or cannot be created or written
        in; the message names the path, what is wrong and the fix.
    """
    folder = Path(path).expanduser()
    where = f"{option} {str(path)!r}"
    ancestor = None
    try:
        ancestor = _existing_ancestor(folder, where, option)
        os.rmdir(tempfile.mkdtemp(prefix=_PROBE_PREFIX, dir=ancestor))
    except OutputPathError:
        raise
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the path
        verb = "write in this folder" if ancestor == folder else "create this folder"
        raise OutputPathError(f"{where}: cannot {verb} ({_reason(exc)}); {_fix(option)}") from None
    return folder


def prepare_output_dir(path: str | Path, option: str = PYTHON) -> Path:
    """:func:`check_output_dir`, then create the folder (and its parents); return it."""
    folder = check_output_dir(path, option)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # changed since the check
        raise OutputPathError(
            f"{option} {str(path)!r}: cannot create this folder ({_reason(exc)}); {_fix(option)}"
        ) from None
    return folder


def _existing_ancestor(folder: Path, where: str, option: str) -> Path:
    """``folder`` if it exists, else its nearest existing ancestor; raise if that is a file."""
    if folder.exists():
        if not folder.is_dir():
            raise OutputPathError(
                f"{where}: is an existing file, not a folder; {_fix(option)}, or move the file "
                "away"
            )
        return folder
    for parent in folder.parents:
        if parent.exists():
            if not parent.is_dir():
                raise OutputPathError(
                    f"{where}: {str(parent)!r} is a file, so no folder can be created under "
                    f"it; {_fix(option)}"
                )
            return parent
    return Path.cwd()  # pragma: no cover - a relative path's parents end at "."


def _reason(exc: BaseException) -> str:
    """Return the OS's short reason (``Permission denied``), with a hint for the common ones."""
    if not isinstance(exc, OSError):
        return str(exc)
    reason = exc.strerror or str(exc)
    if exc.errno in (errno.EACCES, errno.EPERM):
        return f"{reason}: no permission to write there"
    if exc.errno == errno.EROFS:
        return f"{reason}: the file system is read-only"
    if exc.errno == errno.ENOENT:
        return f"{reason}: this file system does not take new folders there"
    return reason
