"""Incremental elastic-plastic solver: limits, yield onset, consistency, unloading, errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import ConvergenceError
from sacflow.mechanics.hertz import composite_modulus, hertz_contact
from sacflow.mechanics.stress_measures import von_mises
from sacflow.storage.case_file import case_from_dict

E, NU, R = 210e9, 0.3, 105e-6


def sphere_case(hardening, load_path, nx=32, nz=12, depth=None, **solver):
    data = {
        "name": "test",
        "body": {"E": E, "nu": NU, "hardening": hardening},
        "counterbody": {"kind": "rigid", "radius": R},
        "grid": {"nx": nx, "ny": nx, "nz": nz, "half_width": 1.6},
        "load_path": load_path,
        "solver": solver,
    }
    if depth is not None:
        data["grid"]["depth"] = depth
    return case_from_dict(data)


def run_all(case):
    sim = simulation_for(case)
    return sim, list(sim.run())


def load_for_ratio(ratio, sigma_y):
    """Load W giving a Hertz peak pressure p0 = ratio · σ_Y (rigid sphere R on E, ν)."""
    e_star = composite_modulus(E, NU)
    p0 = ratio * sigma_y
    a = np.pi * R * p0 / (2 * e_star)
    return 2 * np.pi * a**2 * p0 / 3


def test_elastic_limit_equals_elastic_solver():
    path = [{"kind": "load", "to": 0.3, "increments": 2}, {"kind": "unload", "increments": 1}]
    _, elastic = run_all(sphere_case({"law": "elastic"}, path, depth=8e-6))
    sim, high = run_all(sphere_case(
        {"law": "linear", "yield_stress": 1e15, "modulus": 0.0}, path, depth=8e-6))
    for a, b in zip(elastic, high, strict=True):
        assert_allclose(b.surface["pressure"], a.surface["pressure"], rtol=0, atol=1e-9 * 1e10,
                        err_msg=f"pressure, step {a.step}")
        assert_allclose(b.approach, a.approach, rtol=1e-12, atol=1e-18, err_msg="approach")
    assert not sim.equivalent_plastic_strain.any(), "no plastic strain may appear"
    assert_allclose(high[1].volume["stress"], elastic[1].volume["stress"], atol=1.0,
                    err_msg="stress field")


def test_yield_onset_at_hertz_ratio():
    """First plastic strain at p0/σ_Y ≈ 1.61 (ν = 0.3, Johnson §6.2), bracketed within 2 %."""
    sigma_y = 2e9
    ratios = np.arange(1.54, 1.70, 0.02)
    path = [{"kind": "load", "to": float(load_for_ratio(ratios[0], sigma_y)), "increments": 1}]
    path += [{"kind": "load", "to": float(load_for_ratio(r, sigma_y)), "increments": 1}
             for r in ratios[1:]]
    case = sphere_case({"law": "linear", "yield_stress": sigma_y, "modulus": 0.1 * E}, path,
                       nx=48, nz=32, depth=0.9 * hertz_contact(path[-1]["to"], R,
                                                               composite_modulus(E, NU)).a)
    sim = simulation_for(case)
    first, load = None, None
    for state, ratio in zip(sim.run(), ratios, strict=True):
        load = state.load
        if sim.equivalent_plastic_strain.max() > 0:
            first = ratio
            break
    assert first is not None, "no yield up to p0/σ_Y = 1.68"
    assert 1.61 * 0.98 <= first <= 1.61 * 1.02 + 0.02, f"first yield at p0/σ_Y = {first}"
    p = sim.equivalent_plastic_strain
    depth = sim.coords.x3[np.unravel_index(p.argmax(), p.shape)[2]]
    a = hertz_contact(load, R, composite_modulus(E, NU)).a
    assert 0.40 < depth / a < 0.56, f"first yield at x3 = {depth / a:.3f} a"


@pytest.fixture(scope="module")
def indentation():
    """A coarse 190 mN Swift indentation: load in 4, unload in 2 increments."""
    path = [{"kind": "load", "to": 0.19, "increments": 4}, {"kind": "unload", "increments": 2}]
    case = sphere_case({"law": "swift", "B": 1240e6, "C": 30.0, "n": 0.085,
                        "strain_unit": "microstrain"}, path, nx=32, nz=16)
    sim = simulation_for(case)
    states, eqps = [], []
    for state in sim.run():
        states.append(state)
        eqps.append(sim.equivalent_plastic_strain.copy())
    return sim, states, eqps


def test_consistency_at_convergence(indentation):
    sim, states, _ = indentation
    loaded = states[3]
    vm = von_mises(loaded.volume["stress"])
    sy = loaded.volume["yield_stress"]
    tol = sim.inputs.settings.plasticity_tolerance
    assert (vm <= sy * (1 + 1e-6)).all(), f"max VM/σ_Y = {(vm / sy).max()}"
    active = loaded.volume["equivalent_plastic_strain"] > 0
    assert active.any()
    # on points that yielded in the last loading increment, von Mises equals the yield stress
    just = active & (loaded.volume["equivalent_plastic_strain"] > 0)
    assert_allclose(vm[just] / sy[just], 1.0, atol=max(10 * tol, 1e-5),
                    err_msg="von Mises = σ_Y on plastic points")
    trace = loaded.volume["plastic_strain"][..., :3].sum(-1)
    assert np.abs(trace).max() < 1e-12 * np.abs(loaded.volume["plastic_strain"]).max() + 1e-16


def test_no_plastic_strain_while_unloading(indentation):
    _, states, eqps = indentation
    assert_allclose(eqps[-1], eqps[3], atol=1e-12, err_msg="plastic strain changed on unloading")
    assert states[-1].surface["residual_displacement"].max() > 0, "a residual indent remains"


def test_unloading_curve_shifts_and_changes_shape(indentation):
    """Seed Fig. 11: the unloading branch is not the elastic curve shifted (geometry effect)."""
    sim, states, _ = indentation
    e_star = composite_modulus(E, NU)
    hertz_approach = [hertz_contact(s.load, R, e_star).approach for s in states]
    loaded = states[3]
    assert loaded.approach > hertz_approach[3], "elastic-plastic approach exceeds Hertz"
    shift_top = loaded.approach - hertz_approach[3]
    mid = states[4]
    shift_mid = mid.approach - hertz_approach[4]
    assert shift_mid > 0 and abs(shift_mid - shift_top) > 0.02 * shift_top, (
        f"unloading branch: shift {shift_top:.3e} at max load, {shift_mid:.3e} mid-way")


def test_plasticity_non_convergence_raises_named_error():
    path = [{"kind": "load", "to": 0.19, "increments": 1}]
    case = sphere_case({"law": "swift", "B": 1240e6, "C": 30.0, "n": 0.085,
                        "strain_unit": "microstrain"}, path, nx=24, nz=8,
                       plasticity_max_iterations=2)
    with pytest.raises(ConvergenceError, match="plasticity.*step 0") as info:
        run_all(case)
    assert info.value.residual > case.solver.plasticity_tolerance


def test_coupled_and_nested_schemes_agree():
    """The one-loop scheme and the seed's nested loops converge to the same increment."""
    sigma_y = 4.0e9
    path = [{"kind": "load", "to": load_for_ratio(2.0, sigma_y), "increments": 2},
            {"kind": "unload", "to": 0.0, "increments": 1}]
    law = {"law": "linear", "yield_stress": sigma_y, "modulus": 0.05 * E}
    runs = {}
    for scheme in ("coupled", "nested"):
        sim, states = run_all(sphere_case(law, path, nx=24, nz=10, scheme=scheme))
        runs[scheme] = (sim, states)
    (a, sa), (b, sb) = runs["coupled"], runs["nested"]
    scale = np.abs(b.plastic_strain).max()
    assert scale > 0
    # both stop at a relative plastic residual of 1e-6 (and coupling 1e-6): agree to ~1e-5
    assert_allclose(a.plastic_strain, b.plastic_strain, rtol=0, atol=1e-5 * scale)
    assert_allclose(a.residual_displacement, b.residual_displacement, rtol=0,
                    atol=1e-5 * np.abs(b.residual_displacement).max())
    for x, y in zip(sa, sb, strict=True):
        assert_allclose(x.approach, y.approach, rtol=1e-6)
    # the coupled scheme needs fewer residual-stress applications on the loading steps
    assert sum(s.plasticity_iterations for s in sa) < sum(s.plasticity_iterations for s in sb)


def test_too_shallow_box_grows_and_says_so(tmp_path):
    """Plastic strain at the bottom layer: the run is repeated with a deeper box, with a note."""
    from sacflow.errors import BoxTooShallowError
    from sacflow.runner import run_case
    from sacflow.storage.run_reader import is_complete, open_run

    sigma_y = 4.0e9
    load = load_for_ratio(2.2, sigma_y)
    a = hertz_contact(load, R, composite_modulus(E, NU)).a
    law = {"law": "linear", "yield_stress": sigma_y, "modulus": 0.05 * E}
    case = sphere_case(law, [{"kind": "load", "to": load, "increments": 1}], nx=24, nz=4,
                       depth=0.4 * a)
    with pytest.raises(BoxTooShallowError, match="grid.depth"):
        run_all(case)  # the simulation itself stops and names the setting
    with pytest.warns(RuntimeWarning, match="running again with depth"):
        summary = run_case(case, tmp_path, progress=False)
    ds = open_run(summary.path)
    assert float(ds["x3"].max()) > 0.4 * a, "the stored box is deeper than the one asked for"
    assert ds.attrs["requested_case_id"] == case.case_id
    eqps = ds["equivalent_plastic_strain"].isel(step=-1).values
    assert eqps.max() > 0 and not (eqps[..., -1] > 0).any(), "the grown box holds the zone"
    assert is_complete(summary.path, case.case_id)
    assert run_case(case, tmp_path, progress=False).skipped


def test_measured_surface_comes_as_arrays(tmp_path):
    """A flat measured surface (zero heights) gives the smooth case's contact; no file I/O inside.

    The simulation gets the heights as arrays; without them it says how to give them.
    """
    from sacflow.errors import SacflowError
    from sacflow.solver.state import MeasuredSurface
    from sacflow.storage.case_file import load_case
    from sacflow.storage.surface_file import load_surface

    hertz = Path(__file__).resolve().parents[1] / "configs" / "hertz-elastic.toml"
    sets = ["grid.nx=16", "grid.ny=16", "grid.nz=3"]
    points = np.linspace(-20e-6, 20e-6, 9)
    path = tmp_path / "flat.txt"
    path.write_text("".join(f"{x} {y} 0\n" for x in points for y in points))
    smooth = load_case(hertz, sets)
    measured = load_case(hertz, [*sets, "surface.kind=measured", f"surface.path={path}"])
    with pytest.raises(SacflowError, match="load_surface"):
        simulation_for(measured)
    surface = load_surface(measured)
    assert isinstance(surface, MeasuredSurface) and surface.height.shape == (9, 9)
    a = next(simulation_for(measured, surface=surface).run())
    b = next(simulation_for(smooth).run())
    np.testing.assert_array_equal(a.surface["pressure"], b.surface["pressure"])
