"""Property test: every hardening law the schema accepts builds and runs (one material definition).

Valid laws of every kind are drawn from the schema's own domains -- Swift (both strain units),
Linear, PerfectlyPlastic, Tabular (``beyond_last`` constant and extrapolate), each with and
without a depth profile -- validated by :data:`sacflow.config.schema.HardeningLaw`, built with
:func:`sacflow.config.hardening_laws.hardening_from_schema`, and checked: σ_Y finite, positive and
non-decreasing in εp, and the radial return of a trial stress above yield lands on the yield
surface with the consistency condition satisfied (Simo & Hughes 1998, Box 3.1).
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from pydantic import TypeAdapter

from sacflow.config import schema
from sacflow.config.hardening_laws import hardening_from_schema
from sacflow.mechanics.return_mapping import return_map
from sacflow.mechanics.stress_measures import von_mises

#: Stresses drawn between these [Pa]: from soft metals' yield to well past hard steels'.
STRESS_RANGE = (1e5, 1e11)
#: Equivalent plastic strains checked, up to this (100 %: far past contact plasticity).
MAX_EQPS = 1.0
POINTS = 64
LAW = TypeAdapter(schema.HardeningLaw)


def _open(low: float, high: float) -> st.SearchStrategy[float]:
    return st.floats(low, high, exclude_min=True, exclude_max=True, allow_nan=False)


@st.composite
def swift(draw) -> dict:
    unit = draw(st.sampled_from(["strain", "microstrain"]))
    offsets = (1e-9, 1.0) if unit == "strain" else (1e-3, 1e6)
    return {"law": "swift", "B": draw(st.floats(*STRESS_RANGE)), "C": draw(st.floats(*offsets)),
            "n": draw(_open(0.0, 1.0)), "strain_unit": unit}


@st.composite
def tabular(draw) -> dict:
    m = draw(st.integers(2, 6))
    de = draw(st.lists(st.floats(1e-6, 0.1), min_size=m - 1, max_size=m - 1))
    ds = draw(st.lists(st.floats(0.0, 1e9), min_size=m - 1, max_size=m - 1))
    strain = np.concatenate([[0.0], np.cumsum(de)])
    stress = draw(st.floats(*STRESS_RANGE)) + np.concatenate([[0.0], np.cumsum(ds)])
    return {"law": "tabular", "plastic_strain": strain.tolist(), "stress": stress.tolist(),
            "beyond_last": draw(st.sampled_from(["constant", "extrapolate"]))}


@st.composite
def depth_profile(draw) -> dict | None:
    if not draw(st.booleans()):
        return None
    m = draw(st.integers(1, 4))
    steps = draw(st.lists(st.floats(1e-7, 1e-3), min_size=m, max_size=m))
    depth = (np.cumsum(steps) - steps[0]).tolist()  # from 0, strictly increasing
    factor = draw(st.lists(st.floats(0.1, 10.0), min_size=m, max_size=m))
    return {"depth": depth, "factor": factor}


@st.composite
def hardening_laws(draw) -> dict:
    law = draw(st.one_of(
        swift(),
        st.fixed_dictionaries({"law": st.just("linear"), "yield_stress": st.floats(*STRESS_RANGE),
                               "modulus": st.floats(0.0, 1e12)}),
        st.fixed_dictionaries({"law": st.just("perfectly_plastic"),
                               "yield_stress": st.floats(*STRESS_RANGE)}),
        tabular(),
    ))
    if (profile := draw(depth_profile())) is not None:
        law["depth_profile"] = profile
    return law


@settings(max_examples=150, deadline=None, derandomize=True)
@given(data=hardening_laws(), seed=st.integers(0, 2**32 - 1),
       overshoot=st.floats(1e-6, 50.0), mu=st.floats(1e9, 200e9))
def test_every_valid_law_builds_and_returns_onto_its_yield_surface(data, seed, overshoot, mu):
    model = LAW.validate_python(data)  # drawn from the valid domain: the schema accepts it
    law = hardening_from_schema(model)
    rng = np.random.default_rng(seed)
    depth = rng.uniform(0.0, 2e-3, POINTS)
    eqps = np.sort(rng.uniform(0.0, MAX_EQPS, POINTS))
    eqps[0] = 0.0
    y, h = law.yield_and_slope(eqps, np.full(POINTS, depth[0]))
    assert np.all(np.isfinite(y)) and np.all(y > 0), f"sigma_Y not finite and positive: {data}"
    assert np.all(np.diff(y) >= -1e-12 * y[1:]), f"sigma_Y decreases with eps_p: {data}"
    assert np.all(np.isfinite(h)) and np.all(h >= 0), f"negative or non-finite slope: {data}"

    # a deviatoric trial stress above yield, on a random hydrostatic stress
    p_old = rng.uniform(0.0, 0.1, POINTS)
    y0 = law.yield_stress(p_old, depth)
    direction = rng.normal(size=(POINTS, 6))
    direction /= von_mises(direction)[:, None]
    trial = direction * (y0 * (1.0 + overshoot))[:, None]
    trial[:, :3] += rng.normal(size=(POINTS, 1)) * y0[:, None]
    res = return_map(trial, p_old, law, mu, depth=depth)
    assert res.plastic.all()
    assert np.all(res.equivalent_plastic_strain_increment > 0) and np.all(np.isfinite(res.stress))
    y_new = law.yield_stress(p_old + res.equivalent_plastic_strain_increment, depth)
    assert_allclose(von_mises(res.stress), y_new, rtol=1e-9, err_msg=f"off the surface: {data}")
    q_tr = von_mises(trial)
    assert_allclose(q_tr - 3.0 * mu * res.equivalent_plastic_strain_increment, y_new, rtol=1e-8,
                    atol=1e-9 * float(np.max(q_tr)), err_msg=f"consistency: {data}")
