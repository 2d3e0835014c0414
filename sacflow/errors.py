"""Exceptions raised by sacflow.

Every failure a user can cause or meet is a :class:`SacflowError`: the command line prints its
message (never a traceback) and exits with 2 for an :class:`InputError` (a :class:`ConfigError`,
a file given as a run that is not one, a wrong comparison option), 1 for anything else.
Numerical failures are raised, never returned as a flag to forget.
"""

from __future__ import annotations

__all__ = [
    "BoxTooShallowError",
    "ConfigError",
    "ConvergenceError",
    "EnvironmentVariableError",
    "GridTooLargeError",
    "InputError",
    "OutputPathError",
    "SacflowError",
]


class SacflowError(Exception):
    """Base class of every error sacflow raises on purpose."""


class InputError(SacflowError):
    """Something the user gave is wrong (a description, a file, an option): fix it, run again."""


class ConfigError(InputError):
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
    advice : str or None
        What to do, when the loop knows better than the default (raise the iteration limit or
        refine the load increments), e.g. a residual that stopped falling.
    """

    def __init__(
        self,
        what: str,
        step: int,
        residual: float,
        tolerance: float,
        iterations: int | None = None,
        advice: str | None = None,
    ) -> None:
        self.what = what
        self.step = step
        self.residual = residual
        self.tolerance = tolerance
        self.iterations = iterations
        self.advice = advice
        after = f" after {iterations} iterations" if iterations is not None else ""
        hint = advice or f"raise solver.{what}_max_iterations or refine the load increments"
        super().__init__(
            f"{what} iteration did not converge at step {step}{after}: "
            f"residual {residual:.3e} > tolerance {tolerance:.3e} ({hint})"
        )

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        """Keep the exception picklable (dask workers send it back)."""
        return (
            type(self),
            (self.what, self.step, self.residual, self.tolerance, self.iterations, self.advice),
        )


class GridTooLargeError(SacflowError):
    """The requested grid needs more memory or cells than this machine or solver allows."""


class BoxTooShallowError(SacflowError):
    """Plastic strain reached the bottom layer of the cuboid box: the box must be deeper.

    :func:`sacflow.runner.run_case` catches it, grows the box to ``new_depth`` with
    ``new_nz`` layers (the same layer thickness) and runs the case again, saying so.

    Parameters
    ----------
    step : int
        Increment at which it happened.
    depth, new_depth : float
        Box depth now and the suggested one [m].
    nz, new_nz : int
        Cuboid layers now and for the suggested depth.
    """

    def __init__(self, step: int, depth: float, nz: int, new_depth: float, new_nz: int) -> None:
        self.step, self.depth, self.nz = step, depth, nz
        self.new_depth, self.new_nz = new_depth, new_nz
        super().__init__(
            f"step {step}: plastic strain reached the bottom of the cuboid box (depth "
            f"{depth:.4g} m, {nz} layers); set grid.depth = {new_depth:.4g} and grid.nz = "
            f"{new_nz} (sacflow run does this by itself)"
        )

    def __reduce__(self) -> tuple[type, tuple[object, ...]]:
        """Keep the exception picklable (dask workers send it back)."""
        return (type(self), (self.step, self.depth, self.nz, self.new_depth, self.new_nz))


class EnvironmentVariableError(ConfigError):
    """A ``SACFLOW_*`` environment variable has a value sacflow cannot use.

    Its message names the variable, the value found and the accepted values (see
    :mod:`sacflow.machine.environment`).
    """


class OutputPathError(ConfigError):
    """An output folder (``--out``) is a file, lies under a file, or cannot be written."""
