"""sacflow."""

from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["ConfigError", "load_case", "open_run"]

# Public names and the module defining each, imported on first use so that ``import sacflow``
# (and ``sacflow validate``) stays fast: xarray and netCDF load only for ``open_run``.
_EXPORTS = {
    "ConfigError": "sacflow.errors",
    "load_case": "sacflow.config",
    "open_run": "sacflow.store",
}


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'sacflow' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
