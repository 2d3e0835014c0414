"""A run's states kept light (sacflow.solver.history): the same numbers, without the arrays."""

from __future__ import annotations

import gc
import weakref
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from sacflow.config.solver_inputs import simulation_for
from sacflow.solver.history import light_history, scalars_only
from sacflow.solver.state import State
from sacflow.storage.case_file import load_case

ROOT = Path(__file__).resolve().parents[1]
#: A small elastic-plastic indentation: loading and unloading, a few increments each.
CASE = ROOT / "configs" / "nanoindentation-190mN.toml"
SMALL = ["grid.nx=16", "grid.ny=16", "grid.nz=6", "load_path.0.increments=3",
         "load_path.1.increments=2", "output.volume_every=1"]


def fake_states(loads: list[float], refs: list[weakref.ref]) -> Iterator[State]:
    """States with a pressure of ``load`` everywhere, and weak references to their arrays."""
    for step, load in enumerate(loads):
        surface = {"pressure": np.full((4, 4), load)}
        restart = {"plastic_strain": np.zeros((4, 4, 2, 6))}
        refs.extend([weakref.ref(surface["pressure"]), weakref.ref(restart["plastic_strain"])])
        yield State(step=step, segment=0, load=load, approach=0.0, load_x1=0.0, load_x2=0.0,
                    contact_area=0.0, max_pressure=load, contact_iterations=1,
                    plasticity_iterations=0, surface=surface, restart=restart)


def test_the_last_state_keeps_its_fields_the_others_only_their_scalars() -> None:
    refs: list[weakref.ref] = []
    history = light_history(fake_states([1.0, 3.0, 2.0], refs))
    assert [s.load for s in history] == [1.0, 3.0, 2.0]
    assert [bool(s.surface) for s in history] == [False, False, True]
    assert all(not s.restart and not s.volume for s in history)
    gc.collect()
    alive = [r() is not None for r in refs]
    # only the last state's pressure survives: every restart, and the others' fields, are freed
    assert alive == [False, False, False, False, True, False]


def test_a_key_chooses_the_first_of_its_largest() -> None:
    refs: list[weakref.ref] = []
    history = light_history(fake_states([1.0, 3.0, 2.0, 3.0], refs), fields_of=lambda s: s.load)
    assert [bool(s.surface) for s in history] == [False, True, False, False]
    assert history[1].surface["pressure"][0, 0] == 3.0
    chosen = max(history, key=lambda s: s.load)
    assert chosen is history[1]


def test_scalars_only_keeps_the_scalars() -> None:
    state = next(fake_states([2.5], []))
    light = scalars_only(state)
    assert light.scalars() == state.scalars()
    assert not light.surface and not light.restart and not light.volume


@pytest.mark.parametrize("key", [None, "load"])
def test_a_run_kept_light_gives_the_same_numbers(key: str | None) -> None:
    case = load_case(CASE, SMALL)
    full = list(simulation_for(case).run())
    sim = simulation_for(case)
    light = light_history(sim.run(), None if key is None else (lambda s: s.load))
    assert [s.scalars() for s in light] == [s.scalars() for s in full]
    index = len(full) - 1 if key is None else int(np.argmax([s.load for s in full]))
    kept = light[index]
    assert set(kept.surface) == set(full[index].surface) and kept.surface
    assert set(kept.volume) == set(full[index].volume) and kept.volume
    for name, array in full[index].volume.items():
        np.testing.assert_array_equal(kept.volume[name], array)
    for name, array in full[index].surface.items():
        np.testing.assert_array_equal(kept.surface[name], array)
    assert all(not s.surface for i, s in enumerate(light) if i != index)
    assert any(s.restart for s in full) and not any(s.restart for s in light)
    np.testing.assert_array_equal(sim.equivalent_plastic_strain,
                                  full[-1].restart["equivalent_plastic_strain"])
