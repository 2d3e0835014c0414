"""Which steps of a run make the load cycle a fatigue criterion is evaluated on.

A fatigue criterion reads one load cycle of each material point: the minimum ball of its
deviatoric path and the largest hydrostatic stress on it. Which steps of a run are that cycle:

* **Several rolling passes** (a repeated-rolling run): the *stabilised* cycle, the last
  complete pass. A pass is complete when the material comes back to rest at its end (the load
  is lifted, or the run unloads after it); the cycle is the state the pass starts from (the last
  step of the pass before it: the residual state then) and every step of the pass. After
  shakedown the residual stress no longer changes from pass to pass, so this is the cycle the
  material repeats for the rest of its life.
* **One pass, or a vertical load**: the whole history, from the virgin body through loading,
  rolling and unloading to the residual state. This is the first cycle, not a stabilised one:
  its path runs from zero residual stress to the residual stress the pass left, so where a dent
  leaves a large residual stress the ball encloses both ends. Cases compared on this cycle are
  still compared alike, each on its first passage of the load; for a verdict on the cycles
  that follow, run several passes (``roll.passes``) and let the stage take the last.
* **A named range of steps** (``"first:last"``, step numbers as stored, both included), for
  any other choice.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from sacflow.compare.core import CompareError, case_name

__all__ = ["AUTOMATIC", "WHOLE_HISTORY", "LoadCycle", "load_cycle"]

#: The default choice: the last complete pass of a multi-pass run, else the whole history.
AUTOMATIC = "auto"
#: Every stored step, whatever the passes.
WHOLE_HISTORY = "all"


@dataclass(frozen=True)
class LoadCycle:
    """Positions (along ``step``) of the steps of a cycle, and what the cycle is.

    Every cycle is a run of consecutive steps (a pass is, and so are the others):
    :attr:`steps` selects it as a slice, which reads a stored history block by block.
    """

    positions: np.ndarray
    description: str

    @property
    def steps(self) -> slice:
        """The cycle's positions as a slice along ``step``."""
        return slice(int(self.positions[0]), int(self.positions[-1]) + 1)


def load_cycle(ds: xr.Dataset, cycle: str = AUTOMATIC) -> LoadCycle:
    """Return the steps of ``ds`` that make its load cycle (module docstring).

    Parameters
    ----------
    ds : Dataset
        A run, with its ``step``, ``load`` and (for rolling runs) ``pass`` variables.
    cycle : str
        ``"auto"``, ``"all"`` or ``"first:last"`` (step numbers, both included).

    Raises
    ------
    CompareError
        An unknown choice, a range outside the run, or a cycle of fewer than two steps.
    """
    steps = np.asarray(ds["step"].values)
    if cycle == WHOLE_HISTORY:
        return LoadCycle(np.arange(steps.size), "the whole history")
    if cycle == AUTOMATIC:
        return _last_complete_pass(ds) or LoadCycle(np.arange(steps.size), "the whole history")
    return _named_range(ds, steps, cycle)


def _named_range(ds: xr.Dataset, steps: np.ndarray, cycle: str) -> LoadCycle:
    first, sep, last = cycle.partition(":")
    try:
        lo, hi = int(first), int(last)
    except ValueError:
        raise CompareError(
            f"cycle {cycle!r}: give 'auto', 'all' or a range of step numbers 'first:last'"
        ) from None
    positions = np.flatnonzero((steps >= lo) & (steps <= hi))
    if not sep or lo > hi or positions.size < 2:
        raise CompareError(
            f"cycle {cycle!r}: run {case_name(ds)!r} has steps {int(steps[0])} to "
            f"{int(steps[-1])}; give 'first:last' with first < last inside them"
        )
    return LoadCycle(positions, f"steps {lo} to {hi}")


def _last_complete_pass(ds: xr.Dataset) -> LoadCycle | None:
    """Return the last pass that ends at rest with the step before it (None: a single pass)."""
    if "pass" not in ds.variables:
        return None
    passes = np.asarray(ds["pass"].values)
    load = np.asarray(ds["load"].values, dtype=float)
    if passes.size == 0 or int(passes.max()) < 1:
        return None
    for index in range(int(passes.max()), 0, -1):
        members = np.flatnonzero(passes == index)
        if members.size and load[members[-1]] == 0.0 and members[0] > 0:
            positions = np.concatenate([[members[0] - 1], members])
            return LoadCycle(positions, f"pass {index} (the last complete pass), from the "
                             "residual state before it")
    return None
