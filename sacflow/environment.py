"""The ``SACFLOW_*`` environment variables: one reader each, every bad value a clear message.

sacflow reads two variables (both optional; unset or empty means the default):

``SACFLOW_FFT_THREADS``
    Threads of the FFTs and of the eigenstrain operators' spectral products: a whole number
    >= 1 (default: every usable core; campaign workers set 1). ``solver.fft_threads`` of a case
    takes precedence.
``SACFLOW_FFTW_PLANNER``
    FFTW planner rigour: ``estimate`` or ``measure`` (case-insensitive; default: measured plans
    for large transforms, estimated ones for small transforms).

A value that is not one of these raises :class:`EnvironmentVariableError` (a
:class:`~sacflow.errors.ConfigError`) naming the variable, the value found and the fix, so that
the command line prints ``error: ...`` instead of silently ignoring it or failing deep inside
a run. :func:`check_environment` reads them all; ``sacflow run``, ``campaign`` and ``validate``
call it before anything is computed.
"""

from __future__ import annotations

import os
import re

from sacflow.errors import EnvironmentVariableError

__all__ = [
    "FFTW_PLANNER_ENV",
    "FFT_THREADS_ENV",
    "PLANNER_CHOICES",
    "check_environment",
    "fft_threads_from_env",
    "fftw_planner_from_env",
]

#: Variable limiting the FFT threads.
FFT_THREADS_ENV = "SACFLOW_FFT_THREADS"
#: Variable forcing the FFTW planner rigour.
FFTW_PLANNER_ENV = "SACFLOW_FFTW_PLANNER"
#: Accepted values of :data:`FFTW_PLANNER_ENV` (lower case).
PLANNER_CHOICES: tuple[str, ...] = ("estimate", "measure")
_WHOLE_NUMBER = re.compile(r"[0-9]+")


def _value(name: str) -> str | None:
    """Return the stripped value of ``name``; None when unset or empty (the default applies)."""
    value = os.environ.get(name, "").strip()
    return value or None


def fft_threads_from_env() -> int | None:
    """``SACFLOW_FFT_THREADS`` as a thread count >= 1, or None when it is unset or empty.

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


def check_environment() -> None:
    """Read every ``SACFLOW_*`` variable once; raise on the first bad value (see module doc)."""
    fft_threads_from_env()
    fftw_planner_from_env()
