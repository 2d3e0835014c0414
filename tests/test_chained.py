"""Chained cases: a case that starts from a stored run's state (``initial_state``)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import ConfigError
from sacflow.mechanics.initial_state import InitialStateError
from sacflow.runner import run_case
from sacflow.storage.case_file import case_from_dict
from sacflow.storage.initial_state_file import read_initial_state

#: The seed's 650 mN indentation (rigid sphere R = 105 µm on Swift steel), coarse, on one fixed
#: window so that every case below has the same body grid.
GRID = {"nx": 24, "ny": 24, "nz": 10, "extent": [32e-6, 32e-6], "depth": 20e-6}
BODY = {"E": 210e9, "nu": 0.3,
        "hardening": {"law": "swift", "B": 1240e6, "C": 30.0, "n": 0.085,
                      "strain_unit": "microstrain"}}
LOAD_UNLOAD = [{"kind": "load", "to": 0.65, "increments": 4},
               {"kind": "unload", "to": 0.0, "increments": 2}]
RELOAD = [{"kind": "load", "to": 0.9, "increments": 4},
          {"kind": "unload", "to": 0.0, "increments": 2}]
FIELDS = ["load", "pressure", "residual_displacement", "plastic_strain",
          "equivalent_plastic_strain", "residual_stress"]


def _case(name: str, load_path: list, **extra) -> dict:
    return {"name": name, "body": BODY, "counterbody": {"kind": "rigid", "radius": 105e-6},
            "grid": GRID, "load_path": load_path, "output": {"fields": FIELDS}, **extra}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("chained")
    run_case(case_from_dict(_case("first", LOAD_UNLOAD)), out, progress=False)
    run_case(case_from_dict(_case("whole", LOAD_UNLOAD + RELOAD)), out, progress=False)
    chained = case_from_dict(_case("chained", RELOAD,
                                   initial_state={"run": str(out / "first.nc"), "step": -1}))
    run_case(chained, out, progress=False)
    return out


def test_reload_as_a_chained_case_equals_the_whole_run(runs):
    with xr.open_dataset(runs / "whole.nc") as whole, xr.open_dataset(runs / "chained.nc") as ch:
        # the chained run's steps are the whole run's last six
        for name in ("plastic_strain", "equivalent_plastic_strain", "residual_displacement",
                     "residual_stress", "pressure"):
            a = whole[name].isel(step=slice(-6, None)).values
            b = ch[name].values
            scale = float(np.abs(a).max())
            # Measured: identical to round-off (the same arrays in, the same solves after).
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * scale, err_msg=name)
        np.testing.assert_allclose(ch["load"].values, whole["load"].values[-6:])
        assert ch.attrs["initial_state_step"] == int(np.asarray(whole["step"])[5])
    with xr.open_dataset(runs / "first.nc") as first, xr.open_dataset(runs / "chained.nc") as ch:
        assert ch.attrs["initial_state_case_id"] == first.attrs["case_id"]


def test_chained_start_reproduces_the_source_state(runs):
    case = case_from_dict(_case("start", RELOAD, initial_state={"run": str(runs / "first.nc")}))
    sim = simulation_for(case, initial=read_initial_state(case))
    with xr.open_dataset(runs / "first.nc") as first:
        last = first.isel(step=-1)
        u = last["residual_displacement"].values
        np.testing.assert_allclose(sim.residual_displacement, u, atol=1e-9 * np.abs(u).max())
        s = last["residual_stress"].values
        np.testing.assert_allclose(sim.residual_stress, s, atol=1e-9 * np.abs(s).max())
        np.testing.assert_array_equal(sim.equivalent_plastic_strain,
                                      last["equivalent_plastic_strain"].values)


def test_offset_moves_the_stored_state(runs):
    # One cell along x1: the interpolation lands on the source's cell centres, shifted.
    cell = GRID["extent"][0] / GRID["nx"]
    case = case_from_dict(_case("shifted", RELOAD, initial_state={
        "run": str(runs / "first.nc"), "offset": [cell, 0.0]}))
    sim = simulation_for(case, initial=read_initial_state(case))
    with xr.open_dataset(runs / "first.nc") as first:
        eqps = first["equivalent_plastic_strain"].isel(step=-1).values
    np.testing.assert_allclose(sim.equivalent_plastic_strain[1:], eqps[:-1], rtol=1e-12, atol=1e-15)
    assert not sim.equivalent_plastic_strain[0].any()


def test_case_id_follows_the_source_run_not_its_path(runs, tmp_path):
    spec = {"run": str(runs / "first.nc")}
    here = case_from_dict(_case("c", RELOAD, initial_state=spec))
    copy = tmp_path / "moved.nc"
    copy.write_bytes((runs / "first.nc").read_bytes())
    moved = case_from_dict(_case("c", RELOAD, initial_state={"run": str(copy)}))
    other = case_from_dict(_case("c", RELOAD, initial_state={"run": str(runs / "whole.nc")}))
    assert here.case_id == moved.case_id != other.case_id


def test_mistakes_name_the_fix(runs, tmp_path):
    def chained(**spec):
        case = case_from_dict(_case("bad", RELOAD, initial_state=spec))
        return read_initial_state(case)

    # checked when the case is read (sacflow validate), one line naming the fix
    with pytest.raises(ConfigError, match="no such run file"):
        chained(run=str(tmp_path / "absent.nc"))
    with pytest.raises(ConfigError, match="stores 6 steps"):
        chained(run=str(runs / "first.nc"), step=6)
    with pytest.raises(ConfigError, match="does not store plastic_strain"):
        bare = tmp_path / "bare"
        case = _case("bare", LOAD_UNLOAD)
        case["output"] = {"fields": ["load", "pressure"]}
        run_case(case_from_dict(case), bare, progress=False)
        chained(run=str(bare / "bare.nc"))
    small = case_from_dict(_case("small", RELOAD, initial_state={"run": str(runs / "first.nc")},
                                 grid={**GRID, "depth": 3e-6, "nz": 3}))
    with pytest.raises(InitialStateError, match="plastic zone"):
        simulation_for(small, initial=read_initial_state(small))
    with pytest.raises(ConfigError, match="initial_hardening"):
        case_from_dict(_case("both", RELOAD, initial_state={"run": str(runs / "first.nc")},
                             body={**BODY, "initial_hardening": {
                                 "depth": [0.0], "equivalent_plastic_strain": [0.01]}}))


def test_a_campaign_sweeps_the_source_run(runs, tmp_path):
    import json

    from sacflow.campaign import run_campaign

    base = _case("x", RELOAD[:1], initial_state={"run": "first.nc"})
    base.pop("name")
    text = "\n".join([
        'name = "from-sources"',
        f"base = {json.dumps(base)}".replace('": ', '" = ').replace("{", "{ "),
        "[[sweep]]",
        'mode = "product"',
        'parameters = { "initial_state.run" = ["first.nc", "whole.nc"] }',
    ])
    (runs / "from-sources.toml").write_text(text)
    summary = run_campaign(runs / "from-sources.toml", tmp_path, workers=1, progress=False)
    assert not summary.failed
    for record in summary.records:
        source = runs / ("first.nc" if "first" in record.name else "whole.nc")
        with xr.open_dataset(tmp_path / record.path.name) as run, xr.open_dataset(source) as src:
            assert run.attrs["initial_state_case_id"] == src.attrs["case_id"]
