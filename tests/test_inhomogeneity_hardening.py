"""Inhomogeneities with their own hardening (issue #33): the per-phase return next to ε*.

Checks: an inhomogeneity with the matrix's E, ν and hardening law is the homogeneous run bit
for bit, plasticity active inside it; one with the matrix's E, ν and another law L2 over the
whole box is the homogeneous L2 run; a lower own yield stress yields inside where the elastic
inhomogeneity cannot, a higher one is the elastic inhomogeneity's run; the converged fields
satisfy Eshelby's equivalence and the own yield condition cell by cell; a deep stiff sphere
yielding under a uniform stress against the material-point return of Eshelby's uniform
interior field; the nested scheme and a resume reach the same state; the case translates.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import fsolve
from test_inhomogeneity_case import SPHERE, hertz_data, problem
from test_inhomogeneity_solver import (
    NU,
    S0,
    E,
    eshelby_inputs,
    eshelby_tensor,
    hertz_inputs,
    run,
    sphere,
    stiffness,
)

from sacflow.config.solver_inputs import solver_inputs
from sacflow.mechanics.hardening import LinearHardening, PerfectPlasticity, SwiftHardening
from sacflow.mechanics.stress_measures import von_mises
from sacflow.solver.inputs import Inhomogeneity, SolverInputs
from sacflow.solver.simulation import Simulation
from sacflow.storage.case_file import case_from_dict

LOADING = [{"kind": "load", "to": 0.3, "increments": 2}, {"kind": "unload", "increments": 1}]
#: The matrix's law L1 (yields under the 0.3 N contact, at the depth of the largest shear).
L1 = {"law": "linear", "yield_stress": 4.0e9, "modulus": 1e10}
#: The law L2 of the box-wide inhomogeneity: σ_Y(0) = 3.38 GPa < L1's 4 GPa.
L2 = SwiftHardening(5e9, 0.02, 0.1, "strain")
#: Own laws of the sphere: a yield stress it reaches under the contact (half L1's), and one it
#: never sees (five times L1's).
LOW, HIGH = LinearHardening(2e9, 1e10), LinearHardening(2e10, 1e10)
#: The deep sphere's own law under σ11 = σ22 = S0 (the matrix never yields: 5 GPa).
DEEP_LAW, DEEP_MATRIX = LinearHardening(0.4e9, 2e10), PerfectPlasticity(5e9)


def base_inputs(hardening: dict = L1) -> SolverInputs:
    """The 0.3 N contact on 16 × 16 × 8 cells, the matrix's law ``hardening`` (L1)."""
    return hertz_inputs(16, hardening, LOADING, fft_threads=1)


@pytest.fixture
def base(monkeypatch) -> SolverInputs:
    monkeypatch.setenv("SACFLOW_FFTW_PLANNER", "estimate")  # the same plans in every run
    return base_inputs()


def own(inputs: SolverInputs, law, ratio: float = 1.0, depth: float = 0.5,
        radius: float = 0.3) -> SolverInputs:
    """``inputs`` with a sphere (in Hertz radii) of modulus ``ratio`` E and the law ``law``."""
    with_sphere = sphere(inputs, depth, radius, ratio)
    return replace(with_sphere, inhomogeneities=(
        replace(with_sphere.inhomogeneities[0], law=law),))


def largest_p_inside(state) -> float:
    """Largest equivalent plastic strain of a state's inhomogeneity cells."""
    return float(state.volume["equivalent_plastic_strain"][state.volume["phase"] > 0].max())


def box_inputs(inputs: SolverInputs, law) -> SolverInputs:
    """``inputs`` with a cuboid over the whole box of the matrix's E, ν and the law ``law``."""
    depth = inputs.grid.depth
    box = Inhomogeneity("cuboid", (0.0, 0.0, depth / 2), (1.0, 1.0, depth / 2), E, NU, law=law)
    return replace(inputs, inhomogeneities=(box,))


def assert_same_runs(first, second, skip=()):
    for a, b in zip(first, second, strict=True):
        assert a.scalars() == b.scalars()
        for group in ("surface", "volume", "restart"):
            ours, theirs = getattr(a, group), getattr(b, group)
            for name in set(ours) - set(skip):
                if name in theirs:
                    assert np.array_equal(ours[name], theirs[name], equal_nan=True), (group, name)


@pytest.mark.parametrize("kinematic", [None, {"modulus": 2e10, "recall": 10.0}])
def test_matrix_moduli_and_law_give_the_homogeneous_run_bit_for_bit(base, kinematic):
    if kinematic is not None:
        base = base_inputs({**L1, "kinematic": kinematic})
    _, homogeneous = run(base)
    with_sphere = own(base, base.material.law)
    inh = replace(with_sphere.inhomogeneities[0], kinematic=base.material.kinematic)
    _, same = run(replace(with_sphere, inhomogeneities=(inh,)))
    assert_same_runs(homogeneous, same)
    inside = same[1].volume["phase"] > 0
    # measured: 1.70e-4 in the 12 cells of the sphere, returned by its own (equal) law
    assert largest_p_inside(same[1]) > 1e-4
    if kinematic is not None:
        assert np.abs(same[1].volume["backstress"][inside]).max() > 0


def test_a_box_wide_inhomogeneity_with_law_l2_is_the_homogeneous_l2_run(base, monkeypatch):
    l2 = replace(base, material=replace(base.material, law=L2))
    _, homogeneous = run(l2)
    _, covered = run(box_inputs(base, L2))
    assert (covered[1].volume["phase"] == 1).all()
    assert covered[1].volume["equivalent_plastic_strain"].max() > 4e-3  # measured 4.5e-3
    for h, c in zip(homogeneous, covered, strict=True):
        assert h.scalars() == c.scalars()
        for name in ("plastic_strain", "stress", "yield_stress", "residual_displacement"):
            ours = h.volume.get(name, h.surface.get(name))
            theirs = c.volume.get(name, c.surface.get(name))
            if ours is not None:  # measured: bit for bit
                scale = np.abs(ours).max()
                np.testing.assert_allclose(theirs, ours, rtol=0, atol=1e-12 * scale)


def fields_inside(state):
    inside = state.volume["phase"] == 1
    return inside, {name: state.volume[name][inside] for name in (
        "equivalent_plastic_strain", "plastic_strain", "stress", "equivalent_eigenstrain",
        "yield_stress")}


@pytest.mark.parametrize("ratio", [1.0, 2.0])
def test_a_lower_own_yield_stress_yields_inside_a_higher_one_does_not(base, ratio):
    _, elastic = run(sphere(base, 0.5, 0.3, ratio))
    _, low = run(own(base, LOW, ratio))
    _, high = run(own(base, HIGH, ratio))
    assert all(s.converged for s in low + high)
    _, soft = fields_inside(low[1])
    _, stiff = fields_inside(elastic[1])
    assert not stiff["equivalent_plastic_strain"].any()
    # measured largest p inside: 1.29e-2 (E*/E = 1), 1.94e-2 (2)
    assert soft["equivalent_plastic_strain"].max() > 1e-2
    # a higher yield stress than the sphere ever sees: the elastic sphere's run, bit for bit
    assert_same_runs(elastic, high, skip=("yield_stress",))
    assert high[1].volume["yield_stress"][high[1].volume["phase"] == 1].min() == 2e10


def test_the_converged_cells_satisfy_eshelby_and_their_own_yield_condition(base):
    ratio, law = 2.0, LOW
    _, states = run(own(base, law, ratio))
    _, inside = fields_inside(states[1])
    p, stress = inside["equivalent_plastic_strain"], inside["stress"]
    plastic = p > 0
    assert plastic.sum() >= 4
    # the real stress is on the sphere's own yield surface, not the matrix's (4 GPa)
    np.testing.assert_allclose(von_mises(stress[plastic]), law.yield_stress(p[plastic]),
                               rtol=1e-6)
    np.testing.assert_array_equal(inside["yield_stress"], law.yield_stress(p))
    # ε* = (S* − S) σ: the eigenstrain field holds εp apart from ε*
    difference = np.linalg.inv(stiffness(ratio * E, NU)) - np.linalg.inv(stiffness(E, NU))
    expected = stress @ difference.T
    np.testing.assert_allclose(inside["equivalent_eigenstrain"], expected, rtol=0,
                               atol=1e-5 * np.abs(expected).max())
    strain = inside["plastic_strain"]
    assert np.abs(strain[:, :3].sum(axis=1)).max() < 1e-12 * np.abs(strain).max()


def material_point(ratio, law):
    """Mean interior stress, plastic strain and p of a sphere yielding under σ11 = σ22 = S0.

    Eshelby's uniform interior field with a uniform plastic strain (infinite body): the
    total eigenstrain ``e = ε* + εp`` gives the strain ``ε = ε0 + S^E e``; the sphere's return
    (one backward-Euler step from rest, radial) of its trial stress ``C_k ε`` gives εp, and
    ``C_k (ε − εp) = C (ε − e)`` closes the six equations, solved by ``fsolve``.
    """
    c, ck = stiffness(E, NU), stiffness(ratio * E, NU)
    eshelby = eshelby_tensor()
    remote = np.linalg.solve(c, [S0, S0, 0, 0, 0, 0])
    three_mu = 1.5 * ratio * E / (1 + NU)

    def returned(e):
        trial = ck @ (remote + eshelby @ e)
        s = trial.copy()
        s[:3] -= trial[:3].mean()
        q = von_mises(trial)
        dp = (q - law.yield_stress(0.0)) / (three_mu + law.modulus)
        return 1.5 * dp * s / q, dp

    def equivalence(e):
        strain = remote + eshelby @ e
        return (ck @ (strain - returned(e)[0]) - c @ (strain - e)) / S0

    e = fsolve(equivalence, np.zeros(6), xtol=1e-13)
    plastic, dp = returned(e)
    return ck @ (remote + eshelby @ e - plastic), plastic, dp


def deep_yielding_sphere(ratio: float, cells: int) -> dict:
    """A sphere yielding under σ11 = σ22 = S0 against :func:`material_point`.

    Eshelby's sphere of ``tests/test_inhomogeneity_solver.py`` (``cells`` cells per radius,
    4 radii deep) with modulus ``ratio`` E and the own law :data:`DEEP_LAW`, the matrix
    :data:`DEEP_MATRIX` (never reached). Returns the state, the sphere's cells, the relative
    error of the mean interior stress, the mean interior plastic strain and the material
    point's, and the mean p's offset over the material point's (``mean p / Δp − 1``).
    """
    stress, plastic, dp = material_point(ratio, DEEP_LAW)
    inputs = eshelby_inputs(2.0, cells)
    inh = replace(inputs.inhomogeneities[0], E=ratio * E, law=DEEP_LAW)
    inputs = replace(inputs, inhomogeneities=(inh,),
                     material=replace(inputs.material, law=DEEP_MATRIX))
    _, (state,) = run(inputs)
    inside, fields = fields_inside(state)
    mean_stress = fields["stress"].mean(axis=0)
    return {"state": state, "inside": inside,
            "stress_error": float(np.linalg.norm(mean_stress - stress) / np.linalg.norm(stress)),
            "mean_plastic_strain": fields["plastic_strain"].mean(axis=0),
            "plastic_strain": plastic,
            "p_offset": float(fields["equivalent_plastic_strain"].mean() / dp - 1.0)}


@pytest.mark.parametrize("ratio", [1.0, 2.0])
def test_a_deep_yielding_sphere_against_the_material_point_of_eshelby_s_field(ratio):
    """Mean interior fields of a staircase sphere 4 radii deep against the uniform solution.

    Measured (2, 3, 5 cells per radius): mean stress off by 0.38, 0.59, 0.56 % (E*/E = 1: no
    ε*, the matrix's moduli and the sphere's own law) and 0.84, 1.01, 1.02 % (E*/E = 2); mean p
    above the material point's by 6.0, 5.0, 4.6 % and 5.1, 4.3, 4.3 %. The discrete interior
    is not uniform: a uniform deviatoric eigenstrain in the staircase sphere gives per cell a
    constraint 1 + σ11/(2μ εp11) between 0.28 and 0.82 (Eshelby's 0.476; standard deviation
    0.10 at 5 cells, 0.08 at 7, its mean 0.479), and p, convex in it, averages above the
    uniform value. The two ratios share that offset: the coupling with ε* adds none of its own.
    """
    errors = []
    for cells in (2, 3):
        deep = deep_yielding_sphere(ratio, cells)
        state, inside = deep["state"], deep["inside"]
        assert state.converged
        assert not state.volume["equivalent_plastic_strain"][~inside].any()  # the sphere only
        assert deep["stress_error"] < 0.015
        np.testing.assert_allclose(deep["mean_plastic_strain"], deep["plastic_strain"], rtol=0,
                                   atol=0.07 * np.abs(deep["plastic_strain"]).max())
        errors.append(deep["p_offset"])
    assert 0.0 < errors[1] < errors[0] < 0.065, errors


def test_nested_scheme_and_resume_reach_the_same_state(base):
    inputs = own(base, LOW, 2.0)
    _, states = run(inputs)
    loaded = states[1]
    _, nested = run(replace(inputs, settings=replace(inputs.settings, scheme="nested")))
    np.testing.assert_allclose(nested[1].volume["equivalent_plastic_strain"],
                               loaded.volume["equivalent_plastic_strain"], rtol=0, atol=1e-7)
    resumed = Simulation(inputs)
    resumed.restore(0, states[0].restart, states[0].first_contact_offset)
    again = list(resumed.run(start=1))
    for s, r in zip(states[1:], again, strict=True):
        scale = np.abs(s.volume["equivalent_plastic_strain"]).max()
        np.testing.assert_allclose(r.volume["equivalent_plastic_strain"],
                                   s.volume["equivalent_plastic_strain"], rtol=0,
                                   atol=1e-4 * scale)
        np.testing.assert_array_equal(r.volume["phase"], s.volume["phase"])


def test_the_case_translates_its_own_hardening():
    hardening = {"law": "linear", "yield_stress": 2e9, "modulus": 1e9}
    data = hertz_data({**SPHERE, "hardening": hardening})
    data["body"]["hardening"] = L1
    (inh,) = solver_inputs(case_from_dict(data)).inhomogeneities
    assert isinstance(inh.law, LinearHardening) and inh.law.yield_stress(0.0) == 2e9
    assert inh.kinematic is None
    data["body"]["inhomogeneity"][0]["hardening"] = {"law": "elastic"}
    assert solver_inputs(case_from_dict(data)).inhomogeneities[0].law is None


def test_a_run_file_stores_the_own_plastic_strain_and_resumes(tmp_path):
    """End to end: the plastic fields cover the sphere, the case reads back, a resume agrees."""
    from sacflow.config.solver_inputs import simulation_for
    from sacflow.runner import run as run_case
    from sacflow.storage.run_reader import run_info
    from sacflow.storage.run_writer import RunWriter

    law = {"law": "linear", "yield_stress": 1.5e9, "modulus": 1e10}
    data = hertz_data({**SPHERE, "hardening": law})
    data["body"]["hardening"] = {"law": "perfectly_plastic", "yield_stress": 2e10}
    data["load_path"] = [{"kind": "load", "to": 0.65, "increments": 2}]
    case = case_from_dict(data)
    whole = run_case(case, tmp_path / "whole", progress=False)
    last = whole.isel(step=-1)
    inside = last["phase"].values == 1
    p = last["equivalent_plastic_strain"].values
    assert p[inside].max() > 1e-3 and not p[~inside].any()  # the sphere yields, only it
    np.testing.assert_allclose(last["yield_stress"].values[inside], 1.5e9 + 1e10 * p[inside])
    assert run_info(tmp_path / "whole" / f"{case.name}.nc").case == case
    # interrupted after step 0, then resumed from the stored state
    sim = simulation_for(case)
    first = next(iter(sim.run()))
    part = tmp_path / "part"
    part.mkdir()
    writer = RunWriter(part / f"{case.name}.nc", case, sim.coords, fields=case.stored_fields())
    writer.append(first)
    writer.abort()
    assert len(run_info(part / f"{case.name}.nc").parts) == 1
    resumed = run_case(case, part, progress=False).isel(step=-1)
    np.testing.assert_allclose(resumed["equivalent_plastic_strain"].values, p, rtol=0,
                               atol=1e-4 * p.max())


def test_own_hardening_enters_the_id_and_an_elastic_one_is_none():
    data = hertz_data(SPHERE)
    data["body"]["hardening"] = L1
    without = case_from_dict(data)
    data["body"]["inhomogeneity"][0]["hardening"] = {"law": "elastic"}
    elastic = case_from_dict(data)
    data["body"]["inhomogeneity"][0]["hardening"] = {"law": "perfectly_plastic",
                                                     "yield_stress": 2e9}
    plastic = case_from_dict(data)
    assert elastic.case_id == without.case_id
    assert "hardening" not in without.identity()["body"]["inhomogeneity"][0]
    assert plastic.case_id != without.case_id


def test_the_solver_refuses_own_hardening_in_an_elastic_body():
    inputs = own(hertz_inputs(16), LinearHardening(2e9, 1e10))
    with pytest.raises(ValueError, match="needs a plastic body"):
        Simulation(inputs)


LINEAR = {"law": "linear", "yield_stress": 1e9, "modulus": 1e9}
MISTAKES = [  # (id, own hardening, body hardening, words the message must hold)
    ("in-an-elastic-body", LINEAR, {"law": "elastic"},
     ["body.inhomogeneity.0.hardening", "needs a plastic body", "body.hardening"]),
    ("bad-value", {**LINEAR, "yield_stress": -1.0}, L1,
     ["body.inhomogeneity.0.hardening.yield_stress", "must be > 0"]),
    ("unknown-law", {"law": "bogus"}, L1, ["body.inhomogeneity.0.hardening.law", "'linear'"]),
    ("unknown-key", {**LINEAR, "colour": 1}, L1,
     ["body.inhomogeneity.0.hardening.colour", "unknown key"]),
    ("backstress-alone", {**LINEAR, "kinematic": {"modulus": 1e9}}, L1,
     ["body.inhomogeneity.0.hardening.kinematic", "body.hardening.kinematic"]),
]


@pytest.mark.parametrize(("hardening", "body", "words"), [m[1:] for m in MISTAKES],
                         ids=[m[0] for m in MISTAKES])
def test_each_own_hardening_mistake_names_its_field(hardening, body, words):
    data = hertz_data({**SPHERE, "hardening": hardening})
    data["body"]["hardening"] = body
    line = problem(data)
    for word in words:
        assert word in line, line
