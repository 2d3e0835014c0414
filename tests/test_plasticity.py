"""Tests of the hardening laws (sacflow.mechanics.hardening), the stress measures
(sacflow.mechanics.stress_measures) and the isotropic return (sacflow.mechanics.return_mapping)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

from sacflow.config.hardening_laws import hardening_from_schema
from sacflow.mechanics.hardening import (
    DepthScaledHardening,
    LinearHardening,
    NoPlasticity,
    PerfectPlasticity,
    SwiftHardening,
    TabularHardening,
)
from sacflow.mechanics.return_mapping import return_map
from sacflow.mechanics.stress_measures import (
    deviator,
    double_contraction,
    equivalent_strain,
    equivalent_stress,
    von_mises,
)

E, NU = 210e9, 0.3
MU = E / (2.0 * (1.0 + NU))
K = E / (3.0 * (1.0 - 2.0 * NU))
SEED_SWIFT = dict(B=1240e6, C=30.0, n=0.085)  # seed §3.2, micro-strain


def random_stress(rng, n, scale=3e9):
    return rng.normal(size=(n, 6)) * scale


# ----------------------------------------------------------------------------- hardening laws


def test_swift_seed_initial_yield():
    law = SwiftHardening(**SEED_SWIFT)
    assert_allclose(law.yield_stress(0.0), 1655.7e6, rtol=1e-4,
                    err_msg="seed Swift law: sigma_Y0 = 1240 * 30^0.085 MPa = 1655.7 MPa")
    # same law written in plain strain: B (C + 1e6 p)^n = B 1e6^n (C 1e-6 + p)^n
    plain = SwiftHardening(1240e6 * 1e6**0.085, 30e-6, 0.085, strain_unit="strain")
    p = np.array([0.0, 1e-5, 1e-3, 0.02])
    assert_allclose(plain.yield_stress(p), law.yield_stress(p), rtol=1e-13,
                    err_msg="micro-strain and strain units disagree")


LAWS = {
    "swift": SwiftHardening(**SEED_SWIFT),
    "swift_strain": SwiftHardening(900e6, 2e-3, 0.2, strain_unit="strain"),
    "linear": LinearHardening(1.2e9, 20e9),
    "perfect": PerfectPlasticity(1.5e9),
    "tabular": TabularHardening([0.0, 1e-3, 4e-3, 1e-2], [1.0e9, 1.3e9, 1.45e9, 1.5e9],
                       beyond_last="extrapolate"),
    # beyond_last "constant": the default
    "tabular_flat": TabularHardening([0.0, 1e-3, 4e-3], [1.0e9, 1.3e9, 1.45e9]),
    "depth_swift": DepthScaledHardening(SwiftHardening(**SEED_SWIFT), [0.0, 50e-6, 200e-6],
                                        [1.4, 1.2, 1.0]),
}


@pytest.mark.parametrize("name", sorted(LAWS))
def test_slope_matches_finite_difference(name):
    law = LAWS[name]
    # points away from the tabular kinks and the depth-profile nodes
    p = np.array([3e-4, 2.2e-3, 7e-3, 2.5e-2])
    depth = np.array([20e-6, 80e-6, 130e-6, 400e-6])
    h = 1e-7 * np.maximum(p, 1e-4)
    fd = (law.yield_stress(p + h, depth) - law.yield_stress(p - h, depth)) / (2.0 * h)
    assert_allclose(law.slope(p, depth), fd, rtol=1e-6, atol=1e-6 * np.max(np.abs(fd)),
                    err_msg=f"{name}: slope is not d sigma_Y / d p")
    y2, h2 = law.yield_and_slope(p, depth)
    assert_allclose(y2, law.yield_stress(p, depth), rtol=1e-15, err_msg=f"{name}: yield_and_slope")
    assert_allclose(h2, law.slope(p, depth), rtol=1e-15, err_msg=f"{name}: yield_and_slope")


def test_tabular_interpolation_and_extrapolation():
    e, s = [0.0, 1e-3, 4e-3], [1.0e9, 1.3e9, 1.45e9]
    lin, flat = TabularHardening(e, s, beyond_last="extrapolate"), TabularHardening(e, s)
    p = np.array([0.0, 5e-4, 1e-3, 2.5e-3, 4e-3, 6e-3])
    expected = np.array([1.0e9, 1.15e9, 1.3e9, 1.375e9, 1.45e9, 1.45e9 + 50e9 * 2e-3])
    assert_allclose(lin.yield_stress(p), expected, rtol=1e-14,
                    err_msg="tabular: piecewise-linear values / last-slope continuation")
    assert_allclose(flat.yield_stress(p), np.minimum(expected, 1.45e9), rtol=1e-14,
                    err_msg="tabular flat: constant beyond the last point")
    assert_allclose(lin.slope(p), [300e9, 300e9, 50e9, 50e9, 50e9, 50e9], rtol=1e-12,
                    err_msg="tabular slope: right derivative at kinks")
    assert_allclose(flat.slope(p), [300e9, 300e9, 50e9, 50e9, 0.0, 0.0], rtol=1e-12,
                    err_msg="tabular flat slope")


def test_depth_scaling():
    base = LinearHardening(1e9, 10e9)
    law = DepthScaledHardening(base, [10e-6, 110e-6], [1.5, 1.0])
    depth = np.array([0.0, 10e-6, 60e-6, 110e-6, 1e-3])
    factor = np.array([1.5, 1.5, 1.25, 1.0, 1.0])
    p = 2e-3
    assert_allclose(law.yield_stress(p, depth), factor * base.yield_stress(p), rtol=1e-14,
                    err_msg="depth factor: piecewise linear, constant beyond the ends")
    assert_allclose(law.slope(p, depth), factor * 10e9, rtol=1e-14, err_msg="depth-scaled slope")
    grid_p = np.zeros((3, 4, 5))  # (nx1, nx2, nx3) against depth of shape (nx3,)
    assert law.yield_stress(grid_p, depth).shape == (3, 4, 5)
    with pytest.raises(ValueError, match="depth"):
        law.yield_stress(p)


@pytest.mark.parametrize(("bad", "message"), [
    (lambda: SwiftHardening(1240e6, 0.0, 0.085), "'swift': field 'C': must be a finite"),
    (lambda: SwiftHardening(1240e6, 30.0, 0.085, strain_unit="percent"), "'strain_unit'"),
    (lambda: SwiftHardening(1240e6, 30.0, np.nan), "field 'n'"),
    (lambda: LinearHardening(1e9, -1e9), "'linear': field 'modulus': must be a finite number >="),
    (lambda: LinearHardening(np.inf, 1e9), "field 'yield_stress'"),
    (lambda: PerfectPlasticity(0.0), "'perfectly_plastic': field 'yield_stress'"),
    (lambda: TabularHardening([1e-3, 2e-3], [1e9, 1.1e9]), "'plastic_strain': must start at 0"),
    (lambda: TabularHardening([0.0, 1e-3], [1e9, 0.9e9]), "'stress': must be non-decreasing"),
    (lambda: TabularHardening([0.0, 1e-3, 1e-3], [1e9, 1e9, 1e9]), "strictly increasing"),
    (lambda: TabularHardening([0.0, 1e-3], [1e9]), "field 'stress': must be a list of at least"),
    (lambda: TabularHardening([0.0, 1e-3], [1e9, 1.1e9, 1.2e9]), "one value per plastic_strain"),
    (lambda: TabularHardening([0.0, 5e-324], [1e9, 1.1e9]), "slope is not a finite number"),
    (lambda: TabularHardening([0.0, 1e-3], [1e9, 1.1e9], "linear"), "field 'beyond_last'"),
    (lambda: DepthScaledHardening(LinearHardening(1e9, 0.0), [0.0, 1e-4], [1.0, 0.0]),
     r"depth profile: field 'factor\[1\]': must be a finite number > 0"),
    (lambda: DepthScaledHardening(LinearHardening(1e9, 0.0), [1e-4, 0.0], [1.0, 1.0]),
     "field 'depth': must be strictly increasing"),
])
def test_invalid_laws_rejected(bad, message):
    """The runtime laws check the schema's rules themselves and name the field that breaks one."""
    with pytest.raises(ValueError, match=message):
        bad()


# ----------------------------------------------------------------------------- helpers


def test_von_mises_helpers():
    t = np.zeros((3, 6))
    t[0, 0] = -2e9  # uniaxial
    t[1, 3] = 1e9  # pure shear sigma12
    t[2, :3] = 5e9  # hydrostatic
    assert_allclose(von_mises(t), [2e9, np.sqrt(3.0) * 1e9, 0.0], rtol=1e-15, atol=1e-6,
                    err_msg="von Mises of uniaxial / shear / hydrostatic stress")
    rng = np.random.default_rng(0)
    a = random_stress(rng, 50)
    s = deviator(a)
    assert_allclose(s[:, :3].sum(axis=1), 0.0, atol=1e-6, err_msg="deviator is traceless")
    assert_allclose(von_mises(a), np.sqrt(1.5 * double_contraction(s, s)), rtol=1e-13,
                    err_msg="von_mises = sqrt(3/2 s:s) with shear counted twice")
    full = np.zeros((50, 3, 3))
    for k, (i, j) in enumerate([(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)]):
        full[:, i, j] = full[:, j, i] = a[:, k]
    assert_allclose(double_contraction(a, a), np.einsum("nij,nij->n", full, full), rtol=1e-13,
                    err_msg="double_contraction != full 3x3 contraction")
    # equivalent strain of uniaxial isochoric plastic strain (1, -1/2, -1/2) e is e
    assert_allclose(equivalent_strain([1e-3, -5e-4, -5e-4, 0, 0, 0]), 1e-3, rtol=1e-14,
                    err_msg="equivalent strain of a uniaxial plastic strain")


# ----------------------------------------------------------------------------- return mapping


def check_return(res, trial, eqps, law, mu, depth=None, rtol=1e-10):
    """Assert the invariants every radial return must satisfy; return the new yield stress."""
    y_new = law.yield_stress(eqps + res.equivalent_plastic_strain_increment, depth)
    pl = res.plastic
    assert not np.isnan(res.stress).any(), "NaN in returned stress"
    assert np.all(res.equivalent_plastic_strain_increment >= 0.0), "negative eqps increment"
    assert_allclose(von_mises(res.stress)[pl], y_new[pl], rtol=rtol,
                    err_msg="consistency: von Mises(sigma) != sigma_Y(p + dp)")
    assert np.all(von_mises(res.stress) <= y_new * (1.0 + 1e-12)), "stress outside yield surface"
    dep = res.plastic_strain_increment
    scale = np.max(np.abs(dep)) + 1e-300
    assert_allclose(dep[:, :3].sum(axis=1) / scale, 0.0, atol=1e-12,
                    err_msg="plastic strain increment not deviatoric")
    assert_allclose(equivalent_strain(dep), res.equivalent_plastic_strain_increment, rtol=1e-10,
                    atol=1e-18,
                    err_msg="dp != sqrt(2/3 deps:deps)")
    assert_allclose(res.stress, trial - 2.0 * mu * dep, rtol=0.0,
                    atol=1e-11 * np.abs(trial).max(), err_msg="sigma != sigma_tr - 2 mu deps")
    dissipation = double_contraction(dep, res.stress)
    assert np.all(dissipation >= -1e-12 * np.abs(res.stress).max() * scale), "negative dissipation"
    return y_new


@pytest.mark.parametrize("name", sorted(LAWS))
def test_radial_return_invariants(name):
    law, rng = LAWS[name], np.random.default_rng(1)
    y0 = float(law.yield_stress(0.0, 300e-6))  # q of a unit normal 6-vector is ~3.5
    trial = random_stress(rng, 2000, scale=0.35 * y0) * rng.lognormal(0.0, 0.5, (2000, 1))
    eqps = rng.uniform(0.0, 0.01, 2000)
    depth = rng.uniform(0.0, 300e-6, 2000)
    res = return_map(trial, eqps, law, MU, depth=depth)
    assert 0.1 < res.plastic.mean() < 0.95, "test should mix elastic and plastic points"
    check_return(res, trial, eqps, law, MU, depth)
    assert res.iterations <= 12, f"{name}: {res.iterations} Newton/bisection updates"
    el = ~res.plastic
    assert_array_equal(res.stress[el], trial[el], err_msg="elastic points must be untouched")
    assert_array_equal(res.plastic_strain_increment[el], 0.0, err_msg="elastic points: deps = 0")
    # normality: deps is parallel to the trial deviator, with factor 3/2 dp / q_tr
    s = deviator(trial)
    lam = 1.5 * res.equivalent_plastic_strain_increment / von_mises(trial)
    assert_allclose(res.plastic_strain_increment, lam[:, None] * s, rtol=1e-12, atol=1e-18,
                    err_msg="normality: deps not along s_tr")
    # hydrostatic stress unchanged
    assert_allclose(res.stress[:, :3].sum(1), trial[:, :3].sum(1), rtol=1e-12, atol=1e-3,
                    err_msg="radial return changed the mean stress")


def test_linear_closed_form_and_perfect_plasticity():
    rng = np.random.default_rng(2)
    trial = random_stress(rng, 500)
    eqps = rng.uniform(0.0, 0.02, 500)
    q = von_mises(trial)
    for law, H in [(LinearHardening(1.1e9, 30e9), 30e9), (PerfectPlasticity(1.1e9), 0.0)]:
        res = return_map(trial, eqps, law, MU)
        y0 = law.yield_stress(eqps)
        expected = np.where(q > y0, (q - y0) / (3.0 * MU + H), 0.0)
        assert_allclose(res.equivalent_plastic_strain_increment, expected, rtol=1e-13, atol=1e-20,
                        err_msg=f"{type(law).__name__}: dp != (q_tr - sigma_Y)/(3 mu + H)")
        assert res.iterations <= 1, "linear hardening needs at most one Newton step"
    pl = q > 1.1e9
    assert_allclose(von_mises(res.stress)[pl], 1.1e9, rtol=1e-13,
                    err_msg="perfect plasticity: returned stress not on the yield surface")


def test_elastic_law_never_yields_and_shapes():
    rng = np.random.default_rng(3)
    trial = random_stress(rng, 24, scale=1e11).reshape(2, 3, 4, 6)
    res = return_map(trial, 0.0, NoPlasticity(), MU)
    assert not res.plastic.any()
    assert_array_equal(res.stress, trial, err_msg="NoPlasticity law changed the stress")
    assert res.equivalent_plastic_strain_increment.shape == (2, 3, 4)
    assert res.plastic_strain_increment.shape == trial.shape
    law = LAWS["depth_swift"]
    depth = np.array([0.0, 50e-6, 100e-6, 300e-6])  # one depth per layer (last leading axis)
    res = return_map(trial * 0.01, np.zeros((2, 3, 4)), law, MU, depth=depth)
    flat = return_map((trial * 0.01).reshape(-1, 6), 0.0, law, MU,
                         depth=np.broadcast_to(depth, (2, 3, 4)).ravel())
    assert_allclose(res.stress.reshape(-1, 6), flat.stress, rtol=1e-15,
                    err_msg="leading shape / depth broadcasting changes the result")


def test_unit_and_pressure_invariance():
    rng = np.random.default_rng(4)
    trial, eqps = random_stress(rng, 300), rng.uniform(0.0, 0.01, 300)
    law = LAWS["swift"]
    ref = return_map(trial, eqps, law, MU)
    shifted = trial.copy()
    shifted[:, :3] -= 3e9  # superposed hydrostatic pressure
    res = return_map(shifted, eqps, law, MU)
    assert_allclose(res.equivalent_plastic_strain_increment,
                    ref.equivalent_plastic_strain_increment, rtol=1e-10, atol=1e-18,
                    err_msg="hydrostatic pressure changed the plastic flow")
    f = 7.3  # scale stresses, B and mu together: strains unchanged
    scaled = SwiftHardening(SEED_SWIFT["B"] * f, SEED_SWIFT["C"], SEED_SWIFT["n"])
    res = return_map(trial * f, eqps, scaled, MU * f)
    assert_allclose(res.plastic_strain_increment, ref.plastic_strain_increment, rtol=1e-10,
                    atol=1e-18, err_msg="scaling stresses and moduli changed the strains")


def test_uniaxial_path_reproduces_hardening_curve():
    """Uniaxial stress by small increments: (eps11 - sigma/E, sigma) lies on sigma_Y(p).

    Uniaxial stress is a deviatoric drive along diag(1, -1/2, -1/2) plus the hydrostatic part
    that makes sigma22 = sigma33 = 0; the return ignores the latter, so sigma = s11 - s22 and
    eps11 = d + sigma/(9K) for the accumulated deviatoric axial strain d.
    """
    law = SwiftHardening(**SEED_SWIFT)
    direction = np.array([1.0, -0.5, -0.5, 0.0, 0.0, 0.0])
    n, d_total = 400, 0.02
    stress, p, ep11 = np.zeros(6), 0.0, 0.0
    sig, pp, eps, epl = [], [], [], []
    for k in range(1, n + 1):
        res = return_map(stress + 2.0 * MU * (d_total / n) * direction, p, law, MU)
        stress, p = res.stress, p + float(res.equivalent_plastic_strain_increment)
        ep11 += res.plastic_strain_increment[0]
        sigma = stress[0] - stress[1]
        sig.append(sigma), pp.append(p), eps.append(k * d_total / n + sigma / (9.0 * K))
        epl.append(ep11)
    sig, pp, eps, epl = map(np.array, (sig, pp, eps, epl))
    yielded = pp > 0
    assert yielded.sum() > 200 and (~yielded).sum() > 10
    assert_allclose(sig[~yielded], E * eps[~yielded], rtol=1e-12, err_msg="elastic branch: E eps")
    assert_allclose(sig[yielded], law.yield_stress(pp[yielded]), rtol=1e-11,
                    err_msg="uniaxial stress off the hardening curve")
    assert_allclose(epl, pp, rtol=1e-11, atol=1e-18, err_msg="uniaxial: eps_p11 != p")
    assert_allclose(eps[yielded] - sig[yielded] / E, pp[yielded], rtol=1e-9,
                    err_msg="eps11 != sigma/E + k^-1(sigma)")
    # seed eq. (3.2): dp/dsigma = g'(sigma) = (B/sigma)^(1-1/n) / (n B), p in micro-strain
    B, nn = SEED_SWIFT["B"], SEED_SWIFT["n"]
    i = np.flatnonzero(yielded)[5:-1]
    dpds = (pp[i + 1] - pp[i]) / (sig[i + 1] - sig[i])
    smid = 0.5 * (sig[i + 1] + sig[i])
    assert_allclose(dpds * 1e6, (B / smid) ** (1.0 - 1.0 / nn) / (nn * B), rtol=2e-3,
                    err_msg="Prandtl-Reuss rate of seed eq. (3.2)")
    # radial loading: backward Euler is exact, one big step lands on the same state
    one = return_map(2.0 * MU * d_total * direction, 0.0, law, MU)
    assert_allclose(one.equivalent_plastic_strain_increment, p, rtol=1e-11,
                    err_msg="one step != many steps")
    assert_allclose(one.stress, stress, rtol=1e-11, err_msg="one step != many steps (stress)")


@st.composite
def laws(draw):
    kind = draw(st.sampled_from(["swift", "swift_strain", "linear", "perfect", "tabular"]))
    if kind == "swift":
        law = SwiftHardening(draw(st.floats(300e6, 2e9)), draw(st.floats(0.5, 1000.0)),
                    draw(st.floats(0.01, 0.5)))
    elif kind == "swift_strain":
        law = SwiftHardening(draw(st.floats(300e6, 2e9)), draw(st.floats(1e-6, 1e-2)),
                    draw(st.floats(0.01, 0.99)), strain_unit="strain")
    elif kind == "linear":
        law = LinearHardening(draw(st.floats(100e6, 2e9)), draw(st.floats(0.0, 1e12)))
    elif kind == "perfect":
        law = PerfectPlasticity(draw(st.floats(100e6, 2e9)))
    else:
        m = draw(st.integers(2, 6))
        de = draw(st.lists(st.floats(1e-5, 1e-2), min_size=m - 1, max_size=m - 1))
        ds = draw(st.lists(st.floats(0.0, 5e8), min_size=m - 1, max_size=m - 1))
        law = TabularHardening(np.concatenate([[0.0], np.cumsum(de)]),
                      draw(st.floats(100e6, 2e9)) + np.concatenate([[0.0], np.cumsum(ds)]),
                      beyond_last=draw(st.sampled_from(["extrapolate", "constant"])))
    if draw(st.booleans()):
        law = DepthScaledHardening(law, [0.0, 1e-4], [draw(st.floats(0.5, 2.0)), 1.0])
    return law


@settings(max_examples=60, deadline=None)
@given(law=laws(), seed=st.integers(0, 2**32 - 1), scale=st.floats(0.02, 5.0),
       pressure=st.floats(-10.0, 10.0), mu=st.floats(20e9, 120e9),
       pmax=st.sampled_from([0.0, 1e-4, 0.05]))
def test_radial_return_property(law, seed, scale, pressure, mu, pmax):
    """Random trial stresses up to q_tr ~ 50 sigma_Y0 on a hydrostatic stress up to 10 sigma_Y0."""
    rng = np.random.default_rng(seed)
    eqps, depth = rng.uniform(0.0, pmax, 64), rng.uniform(0.0, 2e-4, 64)
    y0 = law.yield_stress(np.zeros(64), depth)[:, None]
    trial = random_stress(rng, 64, scale) * rng.lognormal(0.0, 0.5, size=(64, 1)) * y0
    trial[:, :3] += pressure * y0
    res = return_map(trial, eqps, law, mu, depth=depth)
    check_return(res, trial, eqps, law, mu, depth)


def test_invalid_return_inputs():
    with pytest.raises(ValueError, match="mu"):
        return_map(np.zeros(6), 0.0, LAWS["linear"], -1.0)
    with pytest.raises(ValueError, match="size 6"):
        return_map(np.zeros((4, 3)), 0.0, LAWS["linear"], MU)
    with pytest.raises(ValueError, match="equivalent_plastic_strain"):
        return_map(np.zeros(6), -1e-3, LAWS["linear"], MU)


# ----------------------------------------------------------------------------- schema


def test_hardening_from_schema():
    ns = SimpleNamespace
    cases = [
        (ns(law="swift", B=1240e6, C=30.0, n=0.085, strain_unit="microstrain", depth_profile=None),
         SwiftHardening(**SEED_SWIFT)),
        (ns(law="linear", yield_stress=1e9, modulus=5e9), LinearHardening(1e9, 5e9)),
        (ns(law="perfectly_plastic", yield_stress=1e9, depth_profile=None), PerfectPlasticity(1e9)),
        (ns(law="tabular", plastic_strain=[0.0, 1e-3], stress=[1e9, 1.2e9]),
         TabularHardening([0.0, 1e-3], [1e9, 1.2e9])),
    ]
    p, depth = np.array([0.0, 5e-4, 3e-3]), np.array([0.0, 1e-4, 1e-3])
    for obj, ref in cases:
        law = hardening_from_schema(obj)
        assert type(law) is type(ref), obj.law
        assert_allclose(law.yield_stress(p), ref.yield_stress(p), rtol=1e-15, err_msg=obj.law)
        assert_allclose(law.slope(p), ref.slope(p), rtol=1e-15, err_msg=obj.law)
    assert isinstance(hardening_from_schema(ns(law="elastic")), NoPlasticity)
    obj = ns(law="linear", yield_stress=1e9, modulus=0.0,
             depth_profile=ns(depth=[0.0, 2e-4], factor=[2.0, 1.0]))
    law = hardening_from_schema(obj)
    assert isinstance(law, DepthScaledHardening)
    assert_allclose(law.yield_stress(0.0, depth), [2e9, 1.5e9, 1e9], rtol=1e-14,
                    err_msg="depth_profile not applied")
    as_dict = hardening_from_schema({"law": "swift", "B": 1240e6, "C": 30.0, "n": 0.085,
                                     "strain_unit": "microstrain"})
    assert_allclose(as_dict.yield_stress(0.0), 1655.7e6, rtol=1e-4, err_msg="dict input")
    with pytest.raises(ValueError, match="hardening law"):
        hardening_from_schema(ns(law="voce"))
    with pytest.raises(ValueError, match="'C'"):
        hardening_from_schema(ns(law="swift", B=1240e6, C=None, n=0.085))


def test_compiled_equivalent_stress_equals_the_deviator_form():
    """The radial return's one-pass yield check computes sqrt(3/2 s:s) as the numpy form does
    (to rounding), for tensors of every scale and pure pressures (q = 0)."""
    rng = np.random.default_rng(11)
    stress = rng.standard_normal((5000, 6)) * 10.0 ** rng.uniform(-3, 10, (5000, 1))
    stress[:10, :3] = stress[:10, :1]  # hydrostatic
    stress[:10, 3:] = 0.0
    s = deviator(stress)
    expected = np.sqrt(1.5 * double_contraction(s, s))
    got = equivalent_stress(np.ascontiguousarray(stress))
    scale = np.abs(stress).max(axis=1)
    assert np.all(np.abs(got - expected) <= 1e-14 * scale)
    assert np.all(got[:10] <= 1e-15 * scale[:10])


def test_return_without_stress_gives_the_same_increments():
    law = LinearHardening(yield_stress=1e9, modulus=20e9)
    rng = np.random.default_rng(12)
    trial = rng.standard_normal((40, 30, 6)) * 1.2e9
    eqps = rng.uniform(0, 1e-3, (40, 30))
    full = return_map(trial, eqps, law, 80e9)
    lean = return_map(trial, eqps, law, 80e9, with_stress=False)
    assert full.plastic.any() and not full.plastic.all()
    assert lean.stress is None
    assert_array_equal(lean.plastic_strain_increment, full.plastic_strain_increment)
    assert_array_equal(lean.equivalent_plastic_strain_increment,
                       full.equivalent_plastic_strain_increment)
    assert_array_equal(lean.plastic, full.plastic)
    elastic = return_map(trial * 1e-3, eqps, law, 80e9, with_stress=False)
    assert elastic.stress is None and not elastic.plastic.any()
