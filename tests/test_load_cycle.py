"""The load cycle of the fatigue stage: the stabilised pass, the whole history, a named range.

An elastic body has no residual stress, so every rolling pass is the same cycle: the indices of
the last pass must equal those of the first, to round-off. A synthetic run checks which steps
each choice takes, including a run that ends under load (its last pass is not complete).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from sacflow.compare.core import CompareError
from sacflow.compare.fatigue_index import fatigue
from sacflow.compare.load_cycle import load_cycle
from sacflow.runner import run_case
from sacflow.storage.case_file import case_from_dict

E, NU, RADIUS, LOAD = 210e9, 0.3, 20e-3, 4200.0
#: Increments of the first loading, of each lift and of the last unloading.
LIFT = 2


def synthetic(passes, load):
    steps = np.arange(len(passes))
    return xr.Dataset({"pass": ("step", np.array(passes)), "load": ("step", np.array(load))},
                      coords={"step": steps}, attrs={"case": "{}"})


def test_the_last_complete_pass_starts_from_the_residual_state_before_it():
    # load (pass 0), roll 0, lift (0), reload (1), roll 1, lift (1), reload (2), roll 2, unload
    passes = [0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2]
    load = [1, 2, 2, 1, 0, 1, 2, 2, 0, 2, 2, 0.0]
    chosen = load_cycle(synthetic(passes, load))
    assert list(chosen.positions) == [8, 9, 10, 11], "pass 2 and the unloaded step before it"
    assert "pass 2" in chosen.description


def test_a_run_that_ends_loaded_takes_the_pass_before():
    passes = [0, 0, 0, 1, 1, 1, 1, 2, 2]
    load = [1, 2, 0, 1, 2, 2, 0, 2, 2.0]
    assert list(load_cycle(synthetic(passes, load)).positions) == [2, 3, 4, 5, 6]


def test_one_pass_and_all_take_the_whole_history_and_a_range_its_steps():
    ds = synthetic([0, 0, 0, 0], [1, 2, 2, 0.0])
    assert list(load_cycle(ds).positions) == [0, 1, 2, 3]
    several = synthetic([0, 0, 1, 1], [2, 0, 2, 0.0])
    assert list(load_cycle(several, "all").positions) == [0, 1, 2, 3]
    assert list(load_cycle(several, "1:2").positions) == [1, 2]


@pytest.mark.parametrize("cycle", ["last", "3:1", "0:0", "7:9", "1:x"])
def test_a_bad_cycle_is_refused_with_the_choices(cycle):
    with pytest.raises(CompareError, match="first:last"):
        load_cycle(synthetic([0, 0, 1, 1], [2, 0, 2, 0.0]), cycle)


@pytest.fixture(scope="module")
def two_passes(tmp_path_factory):
    """An elastic sphere rolled twice over an elastic flat, lifted between the passes.

    The first loading and the final unloading take as many increments as each lift, so that
    both passes sample the same load path (the stress under a Hertz contact is not
    proportional to the load: a half-load state is a point of its own on the path).
    """
    case = {
        "name": "two-passes",
        "body": {"E": E, "nu": NU, "hardening": {"law": "elastic"}},
        "counterbody": {"kind": "elastic", "E": E, "nu": NU, "radius": RADIUS},
        "grid": {"nx": 12, "ny": 12, "nz": 6, "half_width": 1.5, "depth": 1.0e-3},
        "load_path": [
            {"kind": "load", "to": LOAD, "increments": LIFT},
            {"kind": "roll", "distance": 4.0e-3, "steps": 16, "direction": [1.0, 0.0],
             "passes": 2, "lift_increments": LIFT},
            {"kind": "unload", "to": 0.0, "increments": LIFT},
        ],
    }
    out = tmp_path_factory.mktemp("cycle")
    return run_case(case_from_dict(case), out, progress=False).path


def test_an_elastic_body_repeats_its_first_cycle(two_passes):
    with xr.open_dataset(two_passes) as ds:
        passes = ds["pass"].values
        first_pass_end = int(ds["step"].values[np.flatnonzero(passes == 0)[-1]])
    last = fatigue(two_passes)
    first = fatigue(two_passes, cycle=f"0:{first_pass_end}")
    assert last.attrs["cycle"].startswith("pass 1")
    assert first.attrs["cycle_last_step"] == first_pass_end
    assert last.attrs["cycle_first_step"] == first_pass_end, "starts from the rest before it"
    scale = float(first["dang_van"].max())
    np.testing.assert_allclose(last["dang_van"].values, first["dang_van"].values,
                               atol=1e-9 * scale, err_msg="elastic passes are the same cycle")
    whole = fatigue(two_passes, cycle="all")
    np.testing.assert_allclose(whole["dang_van"].values, first["dang_van"].values,
                               atol=1e-9 * scale)
