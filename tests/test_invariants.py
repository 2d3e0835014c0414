"""Solver invariants (issue #15): discrete adjointness of the operators, independence of the
number of elastic load increments, unit neutrality of a whole elastic-plastic run.

Conventions (README): x3 is depth, pressure and the residual surface displacement u3r are
positive into the body, stress is positive in tension, the 6-component storage holds tensor
shears (ε12, not γ12 = 2ε12), so that σ:ε = Σ_d w_d σ_d ε_d with w = (1, 1, 1, 2, 2, 2).
"""

from __future__ import annotations

import numpy as np
import pytest

import sacflow
from sacflow.config.solver_inputs import simulation_for
from sacflow.kernels.convolution import Convolution
from sacflow.kernels.surface import rectangle_stress
from sacflow.storage.case_file import case_from_dict

E, NU, R = 210e9, 0.3, 105e-6
#: σ:ε with tensor shears stored once.
W = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])


# ---------------------------------------------------------------- adjointness
def pressure_stress(p: np.ndarray, depths, dx1: float, dx2: float) -> np.ndarray:
    """Stress (n1, n2, len(depths), 6) at the cell centres' lateral positions and ``depths`` of
    the uniform pressure ``p`` on each surface cell: the solver's operator (DC-FFT convolution
    of Love's rectangle stress), at the depths asked for."""
    n1, n2 = p.shape

    def stresses(d1, d2):
        out = np.empty((len(depths), 6, *np.broadcast_shapes(d1.shape, d2.shape)))
        for k, depth in enumerate(depths):
            out[k] = np.moveaxis(
                rectangle_stress(d1 * dx1, d2 * dx2, depth, dx1 / 2, dx2 / 2, NU), -1, 0)
        return out.reshape(6 * len(depths), 1, *out.shape[2:])

    out = Convolution(stresses, (n1, n2), (n1, n2))(p[None])
    return np.moveaxis(out.reshape(len(depths), 6, n1, n2), (0, 1), (2, 3))


@pytest.fixture(scope="module")
def random_fields():
    """Random pressure (0-1 GPa) and random plastic strain (all six components, ~1e-3) on a
    12 × 10 × 6 grid of non-cubic cells, and the work Σ p·u3r ΔA of the pressure on u3r(εp)."""
    shape, spacing = (12, 10, 6), (1.0e-6, 1.25e-6, 0.8e-6)
    rng = np.random.default_rng(1)
    p = rng.random(shape[:2]) * 1e9
    eps = rng.standard_normal((*shape, 6)) * 1e-3
    u3r = sacflow.residual_displacement(eps, spacing, E, NU)
    work = float(np.sum(p * u3r)) * spacing[0] * spacing[1]
    return p, eps, spacing, work


def test_adjointness_exact_against_layer_averaged_stress(random_fields):
    """Σ p·u3r ΔA = Σ εp:σ̄(p) ΔV with σ̄ the layer average of the pressure stress.

    Betti with an eigenstrain: ∫ t·u^r dS = ∫ σ(p):εp dV. u3r is the exact volume integral over
    each cuboid of Boussinesq's stress of a point force at the surface cell centre; σ(p) is the
    exact surface integral over each cell of the same kernel. Laterally the two discrete forms
    integrate the kernel over the same box (cells and cuboids share dx1, dx2), so they differ
    only along depth: u3r integrates exactly across each layer, σ(p) is sampled at its centre.
    Averaging σ(p) over each layer by 12-point Gauss-Legendre (the integrand is analytic in x3
    on every layer, the top one included: the lateral cell centres never sit on a rectangle
    edge) must therefore reproduce Σ p·u3r ΔA to round-off. Measured: 1.6e-13 relative
    (8 points: 1.4e-9, 4 points: 1.4e-5); asserted 1e-10.
    """
    p, eps, (dx1, dx2, dz), work = random_fields
    n3 = eps.shape[2]
    g, w = np.polynomial.legendre.leggauss(12)
    depths = ((np.arange(n3)[:, None] + 0.5 + g[None, :] / 2) * dz).ravel()
    s = pressure_stress(p, depths, dx1, dx2).reshape(*p.shape, n3, len(g), 6)
    mean = np.einsum("ijkgc,g->ijkc", s, w / 2)
    volume_work = float(np.sum(eps * mean * W)) * dx1 * dx2 * dz
    assert volume_work == pytest.approx(work, rel=1e-10, abs=0)
    # the shear weight matters: without it the identity fails by far more than the tolerance
    assert float(np.sum(eps * mean)) * dx1 * dx2 * dz != pytest.approx(work, rel=1e-3, abs=0)


def test_adjointness_of_solver_operators_converges_as_midpoint_rule(random_fields):
    """The solver's σ(p) at cuboid centres: Σ εp:σ(p) ΔV - Σ p·u3r ΔA is the depth midpoint
    error, O(dz²). The same εp field on m sublayers per layer (u3r unchanged, checked) gives
    relative discrepancies 3.4 %, 0.90 %, 0.22 % for m = 1, 2, 4 (ratios 3.79 and 4.03);
    asserted: each halving of dz divides the discrepancy by 4 ± 0.5 (the h² law), and the
    coarse one is below 10 % (the midpoint error of the top layer, where σ(p) varies over dz)."""
    p, eps, (dx1, dx2, dz), work = random_fields
    u3r = sacflow.residual_displacement(eps, (dx1, dx2, dz), E, NU)
    errors = []
    for m in (1, 2, 4):
        fine = np.repeat(eps, m, axis=2)
        u_fine = sacflow.residual_displacement(fine, (dx1, dx2, dz / m), E, NU)
        np.testing.assert_allclose(u_fine, u3r, rtol=0, atol=1e-11 * np.abs(u3r).max(),
                                   err_msg=f"u3r of the same field on {m} sublayers")
        depths = (np.arange(eps.shape[2] * m) + 0.5) * dz / m
        volume_work = float(np.sum(fine * pressure_stress(p, depths, dx1, dx2) * W))
        errors.append(abs(volume_work * dx1 * dx2 * dz / m - work) / abs(work))
    assert errors[0] < 0.10, errors
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(3.5 < r < 4.5 for r in ratios), f"discrepancies {errors}, ratios {ratios}"


# ---------------------------------------------------------------- small runs
def sphere(hardening, load_path, nx, nz, depth, E=E, radius=R, **solver):
    return case_from_dict({
        "name": "invariant",
        "body": {"E": E, "nu": NU, "hardening": hardening},
        "counterbody": {"kind": "rigid", "radius": radius},
        "grid": {"nx": nx, "ny": nx, "nz": nz, "half_width": 1.6, "depth": depth},
        "load_path": load_path,
        "solver": solver,
    })


@pytest.mark.parametrize("tol", [1e-6, 1e-10])
def test_elastic_result_independent_of_increments(tol):
    """Elastic contact has no memory: 1 or 5 increments to 0.3 N give the same pressure and
    approach to the contact tolerance (relative gap error ``tol``; the pressure, a solution of
    a system with condition number ~ nx, may be off by more). Measured at tol = 1e-10: pressure
    1.5e-9 of its peak, approach 7e-12. Asserted: pressure 100 tol, approach 10 tol."""
    final = []
    for n in (1, 5):
        case = sphere({"law": "elastic"}, [{"kind": "load", "to": 0.3, "increments": n}],
                      nx=32, nz=4, depth=5e-6, contact_tolerance=tol)
        *_, last = simulation_for(case).run()
        final.append(last)
    one, five = final
    p = one.surface["pressure"]
    assert np.abs(five.surface["pressure"] - p).max() <= 100 * tol * p.max()
    assert five.approach == pytest.approx(one.approach, rel=10 * tol, abs=0)


def test_elastic_plastic_run_is_unit_neutral():
    """Lengths × a, moduli and stresses × s, loads × s·a²: dimensionless fields unchanged.

    190 mN Swift indentation (B = 1240 MPa, C = 30 µε, n = 0.085) on 24 × 24 × 10 cells, load
    in 2 increments and unload; scaled by a = 1000, s = 0.01 (every tolerance of the solver is
    relative, so even the iteration counts agree). Measured: p/s 2.1e-10, εp 8e-10, u3r/a
    6.8e-10 (of their peaks), approach/a 1.4e-12. Asserted 1e-8 (the plasticity and coupling
    tolerances are 1e-6: any absolute threshold or unit-dependent step would show at that level).
    """
    runs = []
    for a, s in ((1.0, 1.0), (1e3, 1e-2)):
        law = {"law": "swift", "B": 1240e6 * s, "C": 30.0, "n": 0.085,
               "strain_unit": "microstrain"}
        path = [{"kind": "load", "to": 0.19 * s * a * a, "increments": 2},
                {"kind": "unload", "increments": 1}]
        sim = simulation_for(sphere(law, path, nx=24, nz=10, depth=7e-6 * a, E=E * s, radius=R * a))
        runs.append((a, s, sim, list(sim.run())))
    (_, _, ref, ref_states), (a, s, sim, states) = runs
    p_peak = max(st.surface["pressure"].max() for st in ref_states)
    for x, y in zip(ref_states, states, strict=True):
        np.testing.assert_allclose(y.surface["pressure"] / s, x.surface["pressure"], rtol=0,
                                   atol=1e-8 * p_peak, err_msg=f"p/s, step {x.step}")
        assert y.approach / a == pytest.approx(x.approach, rel=1e-8, abs=0), f"step {x.step}"
        assert y.plasticity_iterations == x.plasticity_iterations
    assert ref.equivalent_plastic_strain.max() > 1e-3, "the run is plastic"
    p_ref = ref.equivalent_plastic_strain
    np.testing.assert_allclose(sim.equivalent_plastic_strain, p_ref, rtol=0,
                               atol=1e-8 * p_ref.max())
    np.testing.assert_allclose(sim.plastic_strain, ref.plastic_strain, rtol=0,
                               atol=1e-8 * np.abs(ref.plastic_strain).max())
    u = ref.residual_displacement
    np.testing.assert_allclose(sim.residual_displacement / a, u, rtol=0,
                               atol=1e-8 * np.abs(u).max())
