"""Automatic cutback: an increment that does not converge is solved again in two halves.

The stored step is the state at the end of the increment either way; ``substeps`` records how
many sub-increments it took. Cut in two, a step equals the same load path given as two
increments, bit for bit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import ConvergenceError
from sacflow.solver.layout import StepPlan, halfway
from sacflow.solver.simulation import MAX_CUTBACKS, Simulation
from sacflow.storage.case_file import load_case

ROOT = Path(__file__).resolve().parents[1]
INDENT = ROOT / "configs" / "nanoindentation-650mN.toml"
TINY = ["grid.nx=16", "grid.ny=16", "grid.nz=8", "load_path.1.increments=1"]


def test_a_step_that_fails_once_is_solved_in_two_halves(monkeypatch):
    real = Simulation.solve_increment
    loads = []

    def fails_first(self, step, plan):
        loads.append(plan.load)
        if len(loads) == 1:
            raise ConvergenceError("plasticity", step=step, residual=1.0, tolerance=1e-6,
                                   iterations=1)
        return real(self, step, plan)

    monkeypatch.setattr(Simulation, "solve_increment", fails_first)
    cut = simulation_for(load_case(INDENT, [*TINY, "load_path.0.increments=1"]))
    states = list(cut.run())
    monkeypatch.undo()
    assert [s.substeps for s in states] == [2, 1]
    assert loads[:3] == [0.65, 0.325, 0.65]

    two = simulation_for(load_case(INDENT, [*TINY, "load_path.0.increments=2"]))
    reference = list(two.run())
    np.testing.assert_array_equal(cut.plastic_strain, two.plastic_strain)
    np.testing.assert_array_equal(cut.residual_displacement, two.residual_displacement)
    assert states[0].max_pressure == reference[1].max_pressure
    assert states[0].approach == reference[1].approach
    assert states[0].plasticity_iterations == (
        reference[0].plasticity_iterations + reference[1].plasticity_iterations)


def test_a_step_too_hard_for_its_iteration_limit_is_cut_until_it_converges():
    """The 650 mN load in one increment takes 17 plasticity iterations at this grid: with a
    limit of 14 it is cut back (into sub-increments of the load) and converges; the plastic
    strain is that of the finer load path, within 1 % of the one-increment result."""
    whole = simulation_for(load_case(INDENT, [*TINY, "load_path.0.increments=1"]))
    first = next(whole.run())
    assert first.substeps == 1 and first.plasticity_iterations > 14
    limited = simulation_for(load_case(INDENT, [*TINY, "load_path.0.increments=1",
                                           "solver.plasticity_max_iterations=14"]))
    states = list(limited.run())
    assert states[0].substeps > 1 and states[0].converged
    assert float(limited.equivalent_plastic_strain.max()) == pytest.approx(
        float(whole.equivalent_plastic_strain.max()), rel=1e-2)


def test_cutting_back_stops_at_its_limit(monkeypatch):
    loads = []

    def always_fails(self, step, plan):
        loads.append(plan.load)
        raise ConvergenceError("plasticity", step=step, residual=1.0, tolerance=1e-6,
                               iterations=1)

    monkeypatch.setattr(Simulation, "solve_increment", always_fails)
    sim = simulation_for(load_case(INDENT, [*TINY, "load_path.0.increments=1"]))
    with pytest.raises(ConvergenceError, match="at step 0"):
        next(sim.run())
    # the whole step, then ever smaller first parts, down to 2**-MAX_CUTBACKS of it
    assert loads == [0.65 / 2**k for k in range(MAX_CUTBACKS + 1)]


def test_halfway_rolls_half_the_way_only_while_loaded():
    roll_start = StepPlan(segment=1, load=100.0, position=(0.0, 0.0))
    roll_end = StepPlan(segment=1, load=100.0, position=(2e-4, 1e-4), pass_end=True)
    middle = halfway(roll_start, roll_end)
    assert middle.position == (1e-4, 5e-5) and middle.load == 100.0
    assert not middle.pass_end  # the end of a pass is where the step ends
    lifted = StepPlan(segment=1, load=0.0, position=(2e-4, 0.0))
    put_down = StepPlan(segment=1, load=50.0, position=(0.0, 0.0), pass_index=1)
    middle = halfway(lifted, put_down)
    assert middle.position == (0.0, 0.0) and middle.load == 25.0 and middle.pass_index == 1
