"""A run's states kept light: every step's scalars, the fields of one chosen step.

:meth:`sacflow.solver.simulation.Simulation.run` yields one :class:`State` per increment, and
each carries its surface and volume fields and its restart: copies of the plastic strain tensor
and of its equivalent, so that a run can resume from that step. A script that keeps every state
(``list(sim.run())``) keeps all of them. At the press's 96² × 128 cells the restart alone is
about 65 MB a step (7 values a cell), at 144² × 192 cells 0.2 GB, so a study holding a run of
tens of increments holds gigabytes it never reads.

:func:`light_history` keeps what such scripts read: every step's scalars, and the surface and
volume fields of the one step they look at (the last, or the step that maximises a key such as
the load or the peak pressure). The simulation's own attributes (its plastic strain, its grid)
stay what they were after the last increment.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterable

from sacflow.solver.state import State

__all__ = ["light_history", "scalars_only"]


def scalars_only(state: State) -> State:
    """``state`` without its arrays: its scalars only (surface, volume and restart emptied)."""
    return dataclasses.replace(state, restart={}, surface={}, volume={})


def light_history(states: Iterable[State],
                  fields_of: Callable[[State], float] | None = None) -> list[State]:
    """Consume ``states`` and keep every step's scalars and one step's fields.

    Parameters
    ----------
    states : iterable of State
        The states of a run, in order (e.g. ``sim.run()``); consumed as they come, so that at
        most two full states are alive at a time.
    fields_of : callable, optional
        Key of the step whose surface and volume fields are kept: the first state with the
        largest ``fields_of(state)`` (the choice of :func:`max` and :func:`numpy.argmax`), e.g.
        ``lambda s: s.load`` for the step of the peak load. By default the last state.

    Returns
    -------
    list of State
        One state per step, in order. All have an empty restart; all but the chosen one have
        empty surface and volume fields too.
    """
    history: list[State] = []
    chosen: int | None = None
    best = 0.0
    for state in states:
        history.append(scalars_only(state))
        value = 0.0 if fields_of is None else float(fields_of(state))
        if chosen is None or fields_of is None or value > best:
            if chosen is not None:
                history[chosen] = scalars_only(history[chosen])
            history[-1] = dataclasses.replace(state, restart={})
            chosen, best = len(history) - 1, value
    return history
