"""sacflow: a three-dimensional semi-analytical elastic-plastic contact code.

The code of Jacq et al., ASME J. Tribol. 124 (2002) 653, and the xarray/netCDF experiment
pipeline around it.

Notebook API: :func:`load_case`, :func:`run`, :func:`open_run`, :func:`open_campaign`, and the
eigenstrain operators :func:`residual_stress`, :func:`residual_displacement`.
"""

from __future__ import annotations

# Importing the storage layer installs the reader of the files a case's id covers (a measured
# surface, a chained case's source run; sacflow.storage.fingerprints), so that a case built in a
# notebook with ``Case(**data)`` has its id.
from sacflow import storage  # noqa: F401
from sacflow.lazy_exports import lazy_exports

__all__ = [
    "ConfigError",
    "load_case",
    "open_campaign",
    "open_run",
    "residual_displacement",
    "residual_stress",
    "run",
]
__version__ = "0.1.0"

# Public names and the module defining each, imported on first use so that ``import sacflow``
# (and ``sacflow validate``) stays fast: xarray and netCDF load only for ``open_run``.
_EXPORTS = {
    "ConfigError": "sacflow.errors",
    "load_case": "sacflow.storage.case_file",
    "open_run": "sacflow.storage.run_reader",
    "open_campaign": "sacflow.campaign.opening",
    "residual_stress": "sacflow.kernels.eigenstrain",
    "residual_displacement": "sacflow.kernels.eigenstrain",
    "run": "sacflow.runner",
}


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
