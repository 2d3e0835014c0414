"""The contact solved on sub-cells of the surface cells (``solver.contact_subcells``).

Against Hertz's closed form: the sub-cells take the sawtooth of the contact's edge off the
approach; the cell means carry the load exactly; the residual displacement reaches the
sub-cells through splines exact for cubics; the option reaches the solver, keeps the case id
of runs without it, and a plastic run with it balances the load at every increment.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow.config.solver_inputs import estimate_case_memory, simulation_for, solver_inputs
from sacflow.errors import ConfigError
from sacflow.kernels.convolution import Convolution
from sacflow.kernels.surface import rectangle_displacement
from sacflow.mechanics.contact import solve_contact
from sacflow.mechanics.hertz import hertz_contact
from sacflow.solver.state import GridCoords
from sacflow.solver.subcell_contact import SubcellContact
from sacflow.storage.case_file import load_case

R, W, E_STAR = 0.01, 100.0, 1e11
HERTZ = hertz_contact(W, R, E_STAR)
#: contact radii per cell of the Hertz windows: the edge runs through more than a cell
CELLS_PER_RADIUS = np.linspace(6.0, 7.0, 11)
CONFIGS = Path(__file__).resolve().parent.parent / "configs"


def sphere_geometry(cells_per_radius: float) -> SimpleNamespace:
    """The contact window of a sphere R (a stand-in for the solver's LoadGeometry)."""
    h = HERTZ.a / cells_per_radius
    n = int(np.ceil(2.6 * cells_per_radius)) // 2 * 2
    x = (np.arange(n) - n / 2 + 0.5) * h
    return SimpleNamespace(cell=(h, h), window=(n, n), coords=GridCoords(x, x, np.zeros(1)),
                           initial_gap=lambda pos, x1, x2: (x1**2 + x2**2) / (2 * R))


def approach_error(cells_per_radius: float, subcells: int) -> float:
    """Relative error of the approach of the Hertz contact on ``subcells`` sub-cells."""
    geo = sphere_geometry(cells_per_radius)
    (h, _), (n, _) = geo.cell, geo.window
    if subcells == 1:
        compliance = Convolution(
            lambda d1, d2: (rectangle_displacement(d1 * h, d2 * h, h / 2, h / 2)
                            / (np.pi * E_STAR))[None, None], (n, n), (n, n))
        x = geo.coords.x1
        result = solve_contact(geo.initial_gap(0, x[:, None], x[None, :]), compliance, h * h,
                               load=W)
    else:
        contact = SubcellContact(geo, E_STAR, subcells)
        window = (slice(0, n), slice(0, n))
        result = contact.solve(contact.window_gap((0.0, 0.0), window), W, None, tol=1e-10,
                               max_iter=2000, step=0)
    return float(result.approach / HERTZ.approach - 1.0)


def test_subcells_take_the_edge_sawtooth_off_the_hertz_approach():
    """Over cells that move the edge through more than a cell (6 to 7 per contact radius) the
    approach's error against Hertz jumps as the edge changes cells: its range over the windows
    shrinks more than fourfold with 2 sub-cells and again with 4, and the largest error with
    it."""
    errors = {s: np.array([approach_error(c, s) for c in CELLS_PER_RADIUS]) for s in (1, 2, 4)}
    spread = {s: float(np.ptp(e)) for s, e in errors.items()}
    worst = {s: float(np.abs(e).max()) for s, e in errors.items()}
    assert spread[2] < spread[1] / 4, spread
    assert spread[4] < spread[2] / 4, spread
    assert worst[1] > worst[2] > worst[4], worst


def test_cell_means_carry_the_load_and_the_area_is_the_sub_cells():
    geo = sphere_geometry(6.3)
    (h, _), (n, _) = geo.cell, geo.window
    contact = SubcellContact(geo, E_STAR, 2)
    window = (slice(0, n), slice(0, n))
    result = contact.solve(contact.window_gap((0.0, 0.0), window), W, None, tol=1e-10,
                           max_iter=2000, step=0)
    assert result.pressure.shape == (n, n)
    assert result.pressure.sum() * h * h == pytest.approx(W, rel=1e-12)
    loaded_cells = np.count_nonzero(result.pressure > 0) * h * h
    assert result.area is not None and result.area < loaded_cells  # edge cells partly loaded
    assert result.area == pytest.approx(np.pi * HERTZ.a**2, rel=0.05)
    # the warm start: its own solution's sub-cells, a copy's spread over each cell
    fine = contact.warm_start(result.pressure)
    assert fine is not None and fine.shape == (2 * n, 2 * n)
    assert_allclose(contact.cell_mean(fine), result.pressure, rtol=1e-14)
    spread = contact.warm_start(result.pressure.copy())
    assert spread is not None and not np.array_equal(spread, fine)
    assert_allclose(contact.cell_mean(spread), result.pressure, rtol=1e-14)
    assert contact.warm_start(None) is None


def test_the_residual_displacement_reaches_the_sub_cells_exactly_for_a_cubic():
    geo = sphere_geometry(6.0)
    n = geo.window[0]
    x = geo.coords.x1

    def field(x1, x2):
        return 1e-6 * (0.3 + x1 / 1e-3 - (x2 / 1e-3) ** 2 + (x1 / 1e-3) ** 2 * (x2 / 1e-3)
                       + (x1 / 1e-3) ** 3)

    contact = SubcellContact(geo, E_STAR, 3)
    window = (slice(2, n - 1), slice(0, n))  # a window at the body's border as well
    x1, x2 = contact.points(window)
    assert x1.size == 3 * (n - 3) and x2.size == 3 * n
    assert_allclose(contact.displacement(field(x[:, None], x[None, :]), window),
                    field(x1[:, None], x2[None, :]), rtol=0, atol=1e-12 * 1e-6)
    assert not contact.displacement(np.zeros((n, n)), window).any()


def test_the_option_reaches_the_solver_and_keeps_the_id_of_runs_without_it():
    config = CONFIGS / "nanoindentation-650mN.toml"
    shipped = load_case(config)
    assert load_case(config, ["solver.contact_subcells=1"]).case_id == shipped.case_id
    refined = load_case(config, ["solver.contact_subcells=2"])
    assert refined.case_id != shipped.case_id
    assert solver_inputs(refined).settings.contact_subcells == 2
    assert solver_inputs(shipped).settings.contact_subcells == 1
    contact_item = {item.name: item.nbytes for item in estimate_case_memory(shipped).items}
    refined_item = {item.name: item.nbytes for item in estimate_case_memory(refined).items}
    assert refined_item["contact operator"] > 3 * contact_item["contact operator"]
    for wrong in ("0", "5", "1.5"):
        with pytest.raises(ConfigError) as info:
            load_case(config, [f"solver.contact_subcells={wrong}"])
        assert "solver.contact_subcells" in str(info.value)


def test_a_plastic_run_on_sub_cells_balances_the_load():
    """The 650 mN case on 24² × 10 cells: every loaded increment's cell pressures carry its
    load, the contact area is the sub-cells', and the approach at the peak load is the one on
    the surface cells to within their discretisation (the contact's edge moves it by less than
    a per cent at these cells)."""
    config = CONFIGS / "nanoindentation-650mN.toml"
    small = ["grid.nx=24", "grid.ny=24", "grid.nz=10", "load_path.0.increments=4",
             "load_path.1.increments=2"]
    runs = {}
    for s in (1, 2):
        case = load_case(config, [*small, f"solver.contact_subcells={s}"])
        sim = simulation_for(case)
        runs[s] = (sim, list(sim.run()))
    sim, states = runs[2]
    dx1, dx2 = sim.geometry.cell
    for state in states:
        assert state.converged
        if state.load > 0:
            assert state.surface["pressure"].sum() * dx1 * dx2 == pytest.approx(state.load,
                                                                               rel=1e-9)
    top = max(states, key=lambda st: st.load)
    loaded = np.count_nonzero(top.surface["pressure"] > 0) * dx1 * dx2
    assert top.contact_area < loaded
    peak = {s: max(run[1], key=lambda st: st.load).approach for s, run in runs.items()}
    assert peak[2] == pytest.approx(peak[1], rel=0.01)


def test_the_splines_pass_through_the_window_and_its_margin_only():
    """On a body four times as long as its window (a rolled track), the splines through the
    window and 8 cells beyond it give what splines through the whole surface give, to the
    decay of a cubic spline's nodes (2 − √3 per cell), for a field that is not a polynomial."""
    from scipy.interpolate import RectBivariateSpline

    from sacflow.solver.subcell_contact import SPLINE_MARGIN

    h = 1e-5
    x1 = (np.arange(64) - 31.5) * h
    x2 = (np.arange(16) - 7.5) * h
    geo = SimpleNamespace(cell=(h, h), window=(16, 16), coords=GridCoords(x1, x2, np.zeros(1)))
    surface = 1e-6 * np.sin(x1[:, None] / (3 * h)) * np.cos(x2[None, :] / (4 * h))
    contact = SubcellContact(geo, E_STAR, 2)
    window = (slice(24, 40), slice(0, 16))
    p1, p2 = contact.points(window)
    whole = RectBivariateSpline(x1, x2, surface, bbox=[x1[0] - h / 2, x1[-1] + h / 2,
                                                       x2[0] - h / 2, x2[-1] + h / 2])(p1, p2)
    near = contact.displacement(surface, window)
    assert SPLINE_MARGIN < 24  # the margin ends inside the body: the test compares something
    assert_allclose(near, whole, rtol=0, atol=3e-5 * 1e-6)  # (2 − √3)^8 of the amplitude
    assert not np.array_equal(near, whole)


@pytest.mark.parametrize(("subcells", "sampling"), [(2, 1), (3, 1), (2, 2)])
def test_the_body_is_loaded_by_the_sub_cells_pressure_not_its_cell_means(subcells, sampling):
    """The stress of a sub-cell pressure (its cell means' stress plus that of its variation
    within each cell) is the sum of Love's rectangles of the sub-cells, evaluated directly at
    the body cells (and averaged over their ``sampling³`` points), on a window inside the
    body; a pressure uniform over each cell adds nothing to its cell means' stress."""
    from sacflow.kernels.cell_average import sub_points
    from sacflow.kernels.surface import rectangle_stress
    from sacflow.solver.operators import Operators

    h1, h2, nz, dz, nu = 1e-5, 1.3e-5, 4, 0.6e-5, 0.3
    body, window = (7, 6), (slice(2, 5), slice(1, 4))
    ops = Operators((3, 3), body, (h1, h2), nz, dz, 2e11, nu, 1e11, None, False, 1,
                    stress_sampling=sampling, contact_subcells=subcells)
    rng = np.random.default_rng(5)
    fine = rng.uniform(0.0, 2e9, (3 * subcells, 3 * subcells))
    means = fine.reshape(3, subcells, 3, subcells).mean(axis=(1, 3))
    total = ops.pressure_stress(means, window) + ops.subcell_pressure_stress(fine, window)

    x1, x2 = (np.arange(body[0]) - 3) * h1, (np.arange(body[1]) - 2.5) * h2
    z = (np.arange(nz) + 0.5) * dz
    centres = (np.arange(subcells) + 0.5) / subcells - 0.5
    s1 = (x1[window[0]][:, None] + centres[None, :] * h1).ravel()
    s2 = (x2[window[1]][:, None] + centres[None, :] * h2).ravel()
    direct = np.zeros((*body, nz, 6))
    points = list(sub_points(sampling, (h1, h2, dz)))
    for q1, q2, q3 in points:
        for k in range(nz):
            d1 = x1[:, None, None, None] + q1 - s1[None, None, :, None]
            d2 = x2[None, :, None, None] + q2 - s2[None, None, None, :]
            unit = rectangle_stress(d1, d2, z[k] + q3, h1 / (2 * subcells),
                                    h2 / (2 * subcells), nu)
            direct[:, :, k] += np.einsum("ijabc,ab->ijc", unit, fine) / len(points)
    assert_allclose(total, direct, rtol=0, atol=1e-10 * np.abs(direct).max())

    uniform = np.repeat(np.repeat(means, subcells, axis=0), subcells, axis=1)
    assert np.abs(ops.subcell_pressure_stress(uniform, window)).max() < 1e-12 * 2e9


def test_the_sub_cells_pressure_gives_the_hertz_stress_below_the_first_layers():
    """Hertz's contact on 2 × 2 sub-cells, its edge at five places within a cell: from a cell
    deep down, the stress of the sub-cells' pressure (the pressure as the contact solved it)
    is more than three times nearer Huber's closed form than that of its cell means (the
    pressure smeared over each cell, which moves the load at the contact's edge by up to half
    a cell). Above a cell's depth both carry the sub-cells' own steps of the pressure."""
    from sacflow.mechanics.hertz import hertz_subsurface_stress
    from sacflow.solver.operators import Operators

    nu, nz = 0.3, 12
    for cells_per_radius in np.linspace(6.0, 7.0, 5):
        geo = sphere_geometry(cells_per_radius)
        (h, _), (n, _) = geo.cell, geo.window
        contact = SubcellContact(geo, E_STAR, 2)
        window = (slice(0, n), slice(0, n))
        result = contact.solve(contact.window_gap((0.0, 0.0), window), W, None, tol=1e-12,
                               max_iter=4000, step=0)
        assert result.subcell_pressure is not None
        ops = Operators((n, n), (n, n), (h, h), nz, h / 4, 2e11, nu, E_STAR, None, False, 1,
                        contact_subcells=2)
        smeared = ops.pressure_stress(result.pressure, window)
        solved = smeared + ops.subcell_pressure_stress(result.subcell_pressure, window)
        x, z = geo.coords.x1, (np.arange(nz) + 0.5) * h / 4
        hertz = hertz_subsurface_stress(x[:, None, None], x[None, :, None], z[None, None, :],
                                        HERTZ.a, HERTZ.p0, nu)
        deep = z >= h
        errors = [float(np.abs(s - hertz)[:, :, deep].max()) / HERTZ.p0
                  for s in (smeared, solved)]
        assert errors[1] < errors[0] / 3, (cells_per_radius, errors)


def test_a_run_on_sub_cells_resumes_where_it_stopped():
    """Stored steps keep the cells' pressure only: resumed after a loaded step, the run solves
    that step's contact on the sub-cells again, so that the next increment starts from the
    stress of the sub-cells' pressure, and goes on as the uninterrupted run did (to the
    solver's tolerances)."""
    config = CONFIGS / "nanoindentation-650mN.toml"
    case = load_case(config, ["grid.nx=24", "grid.ny=24", "grid.nz=10",
                              "load_path.0.increments=4", "load_path.1.increments=2",
                              "solver.contact_subcells=2"])
    states = list(simulation_for(case).run())
    resumed = simulation_for(case)
    resumed.restore(1, states[1].restart, states[1].first_contact_offset)
    assert resumed.history.converged_subcells is not None
    again = list(resumed.run(start=2))
    for s, r in zip(states[2:], again, strict=True):
        for name, field in (("pressure", "surface"), ("equivalent_plastic_strain", "volume")):
            ours, theirs = getattr(r, field).get(name), getattr(s, field).get(name)
            if ours is None or theirs is None:
                continue
            assert_allclose(ours, theirs, rtol=0, atol=1e-6 * np.abs(theirs).max())
