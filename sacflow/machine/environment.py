"""The ``SACFLOW_*`` environment variables: one reader each, every bad value a clear message.

sacflow reads four variables (all optional; unset or empty means the default):

``SACFLOW_FFT_THREADS``
    Threads of the FFTs and of the eigenstrain operators' spectral products: a whole number
    >= 1 (default: every usable core; campaign workers set 1). ``solver.fft_threads`` of a case
    takes precedence. A number above the usable cores is capped at them, with a warning: more
    threads than cores only slow the FFTs down, and each thread takes its own buffers in the
    kernels' set-up (the memory estimate counts them).
``SACFLOW_FFTW_PLANNER``
    FFTW planner rigour: ``estimate`` or ``measure`` (case-insensitive; default: measured plans
    for large transforms, estimated ones for small transforms).
``SACFLOW_CACHE_DIR``
    Directory of the kernel cache (:mod:`sacflow.machine.kernel_cache`), or ``off`` to run without
    it
    (default: ``$XDG_CACHE_HOME/sacflow/kernels``, ``~/.cache/sacflow/kernels``).
``SACFLOW_CACHE_MAX_BYTES``
    Size limit of the kernel cache: bytes, or a number with a K, M, G or T suffix (``20G``);
    default 16G. The least recently used entries go first.

A value that is not one of these raises :class:`EnvironmentVariableError` (a
:class:`~sacflow.errors.ConfigError`) naming the variable, the value found and the fix, so that
the command line prints ``error: ...`` instead of silently ignoring it or failing deep inside
a run. :func:`check_environment` reads them all; ``sacflow run``, ``campaign`` and ``validate``
call it before anything is computed.
"""

from __future__ import annotations

import os
import re
import warnings

from sacflow.errors import EnvironmentVariableError
from sacflow.machine import resources

__all__ = [
    "CACHE_DIR_ENV",
    "CACHE_MAX_BYTES_ENV",
    "FFTW_PLANNER_ENV",
    "FFT_THREADS_ENV",
    "PLANNER_CHOICES",
    "cache_dir_from_env",
    "cache_max_bytes_from_env",
    "check_environment",
    "fft_threads_from_env",
    "fftw_planner_from_env",
]

#: Variable limiting the FFT threads.
FFT_THREADS_ENV = "SACFLOW_FFT_THREADS"
#: Variable forcing the FFTW planner rigour.
FFTW_PLANNER_ENV = "SACFLOW_FFTW_PLANNER"
#: Variables of the kernel cache: its directory (or "off") and its size limit.
CACHE_DIR_ENV = "SACFLOW_CACHE_DIR"
CACHE_MAX_BYTES_ENV = "SACFLOW_CACHE_MAX_BYTES"
#: Values of :data:`CACHE_DIR_ENV` that switch the cache off (lower case).
CACHE_OFF: tuple[str, ...] = ("off", "none", "0", "false")
_SIZE = re.compile(r"([0-9]+(?:\.[0-9]*)?)\s*([KMGT]?)I?B?", re.IGNORECASE)
_SIZE_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
#: Accepted values of :data:`FFTW_PLANNER_ENV` (lower case).
PLANNER_CHOICES: tuple[str, ...] = ("estimate", "measure")
_WHOLE_NUMBER = re.compile(r"[0-9]+")


#: Values of :data:`FFT_THREADS_ENV` already warned about as above the cores (one warning each).
WARNED_FFT_THREADS: set[str] = set()


def _value(name: str) -> str | None:
    """Return the stripped value of ``name``; None when unset or empty (the default applies)."""
    value = os.environ.get(name, "").strip()
    return value or None


def fft_threads_from_env() -> int | None:
    """``SACFLOW_FFT_THREADS`` as a thread count >= 1, or None when it is unset or empty.

    A count above :func:`~sacflow.machine.resources.usable_cores` is capped at it, with a
    ``RuntimeWarning`` naming the variable, the cores and the fix.

    Raises
    ------
    EnvironmentVariableError
        When the value is not a whole number >= 1 (``abc``, ``0``, ``-1``, ``1.5``).
    """
    value = _value(FFT_THREADS_ENV)
    if value is None:
        return None
    if not _WHOLE_NUMBER.fullmatch(value) or int(value) < 1:
        raise EnvironmentVariableError(
            f"environment variable {FFT_THREADS_ENV}={value!r} is not a thread count; "
            f"set it to a whole number >= 1 (e.g. export {FFT_THREADS_ENV}=2) "
            f"or unset it to use every core"
        )
    cores = resources.usable_cores()
    if int(value) > cores:
        if value not in WARNED_FFT_THREADS:  # once per process: the variable is read often
            WARNED_FFT_THREADS.add(value)
            warnings.warn(
                f"environment variable {FFT_THREADS_ENV}={value} is more than the {cores} cores "
                f"this process may use; using {cores} threads (set it to at most {cores}, or "
                f"unset it to use every core)", RuntimeWarning, stacklevel=2)
        return cores
    return int(value)


def fftw_planner_from_env() -> str | None:
    """``SACFLOW_FFTW_PLANNER`` in lower case (one of :data:`PLANNER_CHOICES`), or None.

    Raises
    ------
    EnvironmentVariableError
        When the value is not ``estimate`` or ``measure``.
    """
    value = _value(FFTW_PLANNER_ENV)
    if value is None:
        return None
    if value.lower() not in PLANNER_CHOICES:
        choices = " or ".join(PLANNER_CHOICES)
        raise EnvironmentVariableError(
            f"environment variable {FFTW_PLANNER_ENV}={value!r} is not a planner rigour; "
            f"set it to {choices}, or unset it for the default (measured plans for large "
            f"transforms only)"
        )
    return value.lower()


def cache_dir_from_env() -> str | None:
    """``SACFLOW_CACHE_DIR`` as given (``"off"`` and the like included), or None when unset."""
    return _value(CACHE_DIR_ENV)


def cache_max_bytes_from_env() -> int | None:
    """``SACFLOW_CACHE_MAX_BYTES`` in bytes (``20G``, ``500M``, ``1048576``), or None if unset.

    Raises
    ------
    EnvironmentVariableError
        For anything but a non-negative size with an optional K, M, G or T suffix.
    """
    value = _value(CACHE_MAX_BYTES_ENV)
    if value is None:
        return None
    match = _SIZE.fullmatch(value.strip())
    if match is None:
        raise EnvironmentVariableError(
            f"environment variable {CACHE_MAX_BYTES_ENV}={value!r} is not a size; set it to "
            f"bytes or a number with a K, M, G or T suffix (e.g. 20G), or unset it for the "
            f"default (16G)"
        )
    return int(float(match.group(1)) * _SIZE_UNITS[match.group(2).upper()])


def check_environment() -> None:
    """Read every ``SACFLOW_*`` variable once; raise on the first bad value (see module doc)."""
    fft_threads_from_env()
    fftw_planner_from_env()
    cache_max_bytes_from_env()
