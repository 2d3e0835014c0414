"""FFTW's wisdom kept beside the kernel cache: a measured plan is searched for once per machine.

A measured FFTW plan of a large batch of transforms (the eigenstrain operator's lateral
transforms at 128 × 128 × 64 cuboids) takes FFTW from 0.1 s to more than 1 s to find, at every
start of a process, and varies with the load of the machine: it was the larger part of a set-up
from the kernel cache (``docs/performance.md``). FFTW records the plans it found as *wisdom*;
this module loads the wisdom from the kernel cache directory before the process's first plan and
writes what the process added when it exits, so that the next process plans a known transform at
once, with the same plan.

Wisdom is specific to the processor and to the FFTW build: the file's name carries both (the
processor model, the machine type, the pyfftw version), so a cache directory shared by different
machines keeps one file per kind. The file is written to a temporary name and renamed into
place (concurrent processes: the last one's wisdom stays, each one's complete). A file that
FFTW does not accept is ignored (and replaced at exit). ``SACFLOW_CACHE_DIR=off`` turns this
off with the cache; ``sacflow cache clear`` removes the files.
"""

from __future__ import annotations

import atexit
import base64
import contextlib
import hashlib
import json
import os
import platform
import tempfile
from pathlib import Path
from typing import Any

__all__ = ["WISDOM_PREFIX", "load_wisdom", "wisdom_path"]

#: File names of the wisdom files in the cache directory (then a hash of the machine kind).
WISDOM_PREFIX = "fftw-wisdom-"
_state: dict[str, Any] = {"loaded": False, "imported": None}


def _machine_kind() -> str:
    """Processor model, machine type and pyfftw version: what makes wisdom valid."""
    model = ""
    with contextlib.suppress(OSError), open("/proc/cpuinfo") as fh:
        for line in fh:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    from sacflow.kernels.fft import pyfftw

    version = getattr(pyfftw, "__version__", "")
    return f"{model}|{platform.machine()}|{platform.processor()}|pyfftw {version}"


def wisdom_path(root: Path) -> Path:
    """Return the wisdom file of this kind of machine in the cache directory ``root``."""
    digest = hashlib.sha256(_machine_kind().encode()).hexdigest()[:16]
    return root / f"{WISDOM_PREFIX}{digest}.json"


def load_wisdom() -> None:
    """Import the stored wisdom once per process and arrange for it to be saved at exit.

    Called before the first FFTW plan (:class:`sacflow.kernels.fft.RealFFT`,
    :class:`~sacflow.kernels.fft.RealToReal`); does nothing without pyfftw or with the cache off.
    """
    if _state["loaded"]:
        return
    _state["loaded"] = True
    from sacflow.kernels.fft import pyfftw
    from sacflow.machine.kernel_cache import cache_directory

    root = cache_directory()
    if pyfftw is None or root is None:
        return
    path = wisdom_path(root)
    with contextlib.suppress(OSError, ValueError, KeyError, TypeError):
        record = json.loads(path.read_text())
        wisdom = tuple(base64.b64decode(record[key]) for key in ("double", "single", "long"))
        pyfftw.import_wisdom(wisdom)  # entries FFTW does not accept are skipped
    _state["imported"] = pyfftw.export_wisdom()
    atexit.register(_save_wisdom, path)


def _save_wisdom(path: Path) -> None:
    """Write the process's wisdom to ``path`` if it holds plans the stored file did not."""
    from sacflow.kernels.fft import pyfftw

    wisdom = pyfftw.export_wisdom()
    if wisdom == _state["imported"]:
        return
    record = {key: base64.b64encode(part).decode() for key, part
              in zip(("double", "single", "long"), wisdom, strict=True)}
    with contextlib.suppress(OSError):
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        try:
            with os.fdopen(fd, "w") as fh:
                json.dump(record, fh)
            os.replace(temporary, path)
        finally:
            with contextlib.suppress(OSError):
                os.remove(temporary)
    _state["imported"] = wisdom
