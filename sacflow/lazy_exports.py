"""Public names of a package imported on first use, so that ``import sacflow`` stays quick.

``sacflow`` and ``sacflow.compare`` export functions whose modules pull in xarray, netCDF,
matplotlib or the numerical kernels; :func:`lazy_exports` gives such a package the module-level
``__getattr__`` and ``__dir__`` (PEP 562) that import a name's module only when the name is first
used, so that ``sacflow validate`` does not pay for what it does not run.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from importlib import import_module
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, exports: Mapping[str, str], names: Iterable[str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """Return the ``__getattr__`` and ``__dir__`` of a package with lazily imported exports.

    Parameters
    ----------
    package : str
        The package's dotted name, for the error message of an unknown attribute.
    exports : mapping of str to str
        Each public name and the dotted name of the module that defines it.
    names : iterable of str
        The names ``dir(package)`` lists besides the package's own globals (its ``__all__``).

    Returns
    -------
    (getattr, dir)
        Functions to assign to the package's ``__getattr__`` and ``__dir__``.
    """
    listed = sorted(set(names))

    def getattr_(name: str) -> Any:
        if name in exports:
            return getattr(import_module(exports[name]), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def dir_() -> list[str]:
        return sorted({*vars(import_module(package)), *listed})

    return getattr_, dir_
