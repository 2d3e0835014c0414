"""Exceptions raised by sacflow.

Every failure a user can cause or meet is a :class:`SacflowError`: the command line prints its
message (never a traceback) and exits with 2 for a :class:`ConfigError`, 1 for anything else.
Numerical failures are raised, never returned as a flag to forget (STYLE 7).
"""

from __future__ import annotations

__all__ = ["ConfigError", "ConvergenceError", "GridTooLargeError", "SacflowError"]


class SacflowError(Exception):
    """Base class of every error sacflow raises on purpose."""


class ConfigError(SacflowError):
    """A case or campaign description is invalid; ``str()`` is a short, field-named message."""


class ConvergenceError(SacflowError):
    """An iterative solve did not reach its tolerance.

    Parameters
    ----------
    what : str
        Which loop failed: ``"contact"``, ``"plasticity"`` or ``"coupling"``.
    step : int
        Index of the load increment being solved.
    residual : float
        Last residual reached.
    tolerance : float
        Tolerance that was asked for.
    iterations : int or None
        Number of iterations done, if known.
    """

    def __init__(
        self,
        what: str,
        step: int,
        residual: float,
        tolerance: float,
        iterations: int | None = None,
    ) -> None:
        self.what = what
        self.step = step
        self.residual = residual
        self.tolerance = tolerance
        self.iterations = iterations
        after = f" after {iterations} iterations" if iterations is not None else ""
        super().__init__(
            f"{what} iteration did not converge at step {step}{after}: "
            f"residual {residual:.3e} > tolerance {tolerance:.3e} "
            f"(raise solver.{what}_max_iterations or refine the load increments)"
        )

    def __reduce__(self):  # keep the exception picklable (dask workers send it back)
        return (
            type(self),
            (self.what, self.step, self.residual, self.tolerance, self.iterations),
        )


class GridTooLargeError(SacflowError):
    """The requested grid needs more memory or cells than this machine or solver allows."""
