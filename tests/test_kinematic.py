"""Kinematic hardening (sacflow.mechanics.return_mapping) and the material-point driver (issue #19,
part).

* Armstrong–Frederick under uniaxial strain cycles against its closed form
  α = C/γ ± (α0 − C/γ) exp(∓γ Δεp) (α = 3/2 X11, the uniaxial backstress), any increment size;
* the Bauschinger effect: reverse yield at α − σ_Y;
* linear kinematic hardening (Prager–Ziegler): σ = ±σ_Y + C εp on every plastic increment, and a
  closed hysteresis loop from the first cycle;
* the isotropic-only return unchanged: no backstress gives the solver's radial return;
* consistency (the yield function zero after the return) for random multiaxial states;
* the schema: kinematic hardening validates and adds the stored backstress; case ids of laws
  without it are unchanged.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sacflow.compare.material import history_dataset
from sacflow.config.hardening_laws import hardening_from_schema, kinematic_from_schema
from sacflow.mechanics.hardening import KinematicLaw, PerfectPlasticity, SwiftHardening
from sacflow.mechanics.material_point import STRESS_TOL, cycle_path, material_cycles
from sacflow.mechanics.return_mapping import return_map
from sacflow.mechanics.stress_measures import deviator, double_contraction
from sacflow.storage.case_file import load_case

ROOT = Path(__file__).resolve().parents[1]
E, NU, SY = 200e9, 0.3, 300e6
MU = E / (2 * (1 + NU))
C, GAMMA = 50e9, 200.0


def af(recall: float = GAMMA, modulus: float = C) -> dict:
    return {"law": "perfectly_plastic", "yield_stress": SY,
            "kinematic": {"modulus": modulus, "recall": recall}}


def cycle(hardening: dict, *args, **kwargs):
    """``material_cycles`` of a schema hardening law, built as the material-point stage does."""
    history = material_cycles(hardening_from_schema(hardening), *args,
                              kinematic=kinematic_from_schema(hardening), **kwargs)
    return history_dataset(history)


def uniaxial_backstress(ds) -> np.ndarray:
    return 1.5 * ds["backstress"].sel(component="11").values


@pytest.mark.parametrize("increments", [5, 40])
def test_armstrong_frederick_follows_its_closed_form(increments):
    ds = cycle(af(), E, NU, amplitude=0.01, cycles=1, increments=increments)
    alpha = uniaxial_backstress(ds)
    ep = ds["plastic_strain"].sel(component="11").values
    n = increments
    tension = np.arange(1, n + 1)
    np.testing.assert_allclose(alpha[tension], C / GAMMA * (1 - np.exp(-GAMMA * ep[tension])),
                               rtol=0, atol=1e-12 * C / GAMMA)
    compression = np.arange(n + 1, 2 * n + 1)
    a0, e0 = alpha[n], ep[n]
    ref = -C / GAMMA + (a0 + C / GAMMA) * np.exp(GAMMA * (ep[compression] - e0))
    np.testing.assert_allclose(alpha[compression], ref, rtol=0, atol=1e-12 * C / GAMMA)
    back = np.arange(2 * n + 1, 3 * n + 1)
    a1, e1 = alpha[2 * n], ep[2 * n]
    ref = C / GAMMA + (a1 - C / GAMMA) * np.exp(-GAMMA * (ep[back] - e1))
    np.testing.assert_allclose(alpha[back], ref, rtol=0, atol=1e-12 * C / GAMMA)
    # the held lateral stresses are zero to the driver's tolerance
    assert np.abs(ds["stress"].sel(component=["22", "33"]).values).max() < 1e-9 * SY


def test_bauschinger_effect():
    """After tension to σ_max the reverse yield comes at σ = α − σ_Y, |σ| < σ_Y."""
    n = 60
    ds = cycle(af(), E, NU, amplitude=0.005, cycles=1, increments=n)
    stress = ds["driven_stress"].values
    ep = ds["plastic_strain"].sel(component="11").values
    alpha = uniaxial_backstress(ds)
    first = n + 1 + int(np.argmax(np.diff(ep[n:2 * n + 1]) < 0))  # first reverse plastic step
    assert ep[first] < ep[first - 1]
    reverse_yield = alpha[n] - SY
    # the last elastic point before it lies within one elastic increment of α − σ_Y
    step = E * 2 * 0.005 / n
    assert stress[first - 1] == pytest.approx(reverse_yield, abs=step)
    assert abs(reverse_yield) < SY < stress[n]


def test_linear_kinematic_hysteresis_loop_is_closed_form_and_stable():
    n = 50
    ds = cycle(af(recall=0.0), E, NU, amplitude=0.006, cycles=2, increments=n)
    stress = ds["driven_stress"].values
    ep = ds["plastic_strain"].sel(component="11").values
    dep = np.diff(ep)
    plastic = np.abs(dep) > 0
    sign = np.sign(dep[plastic])
    # to the driver's tolerance on the held lateral stresses (STRESS_TOL of σ_Y)
    np.testing.assert_allclose(stress[1:][plastic], sign * SY + C * ep[1:][plastic],
                               rtol=0, atol=10 * STRESS_TOL * SY)
    # linear kinematic hardening alone: the loop closes after the first loading
    np.testing.assert_allclose(stress[n:3 * n + 1], stress[3 * n:5 * n + 1], rtol=0,
                               atol=10 * STRESS_TOL * SY)


def test_without_kinematic_hardening_the_driver_uses_the_solver_return():
    law = {"law": "swift", "B": 1240e6, "C": 30.0, "n": 0.085, "strain_unit": "microstrain"}
    ds = cycle(law, 210e9, 0.3, amplitude=0.012, cycles=0, increments=20)
    assert not ds["backstress"].values.any()
    swift = SwiftHardening(1240e6, 30.0, 0.085, "microstrain")
    # uniaxial: on the plastic increments the axial stress is the yield stress at p
    p = ds["equivalent_plastic_strain"].values
    stress = ds["driven_stress"].values
    plastic = np.diff(p) > 0
    np.testing.assert_allclose(stress[1:][plastic], swift.yield_stress(p[1:][plastic]),
                               rtol=1e-9)


def test_zero_kinematic_modulus_is_the_isotropic_return():
    rng = np.random.default_rng(3)
    trial = rng.normal(scale=600e6, size=(500, 6))
    p = rng.uniform(0, 0.01, 500)
    law = SwiftHardening(1240e6, 30.0, 0.085, "microstrain")
    iso = return_map(trial, p, law, MU)
    kin = return_map(trial, p, law, MU, kinematic=KinematicLaw(0.0, 0.0), backstress=np.zeros(6))
    np.testing.assert_array_equal(kin.plastic, iso.plastic)
    np.testing.assert_allclose(kin.stress, iso.stress, rtol=1e-12, atol=1e-3)
    np.testing.assert_allclose(kin.equivalent_plastic_strain_increment,
                               iso.equivalent_plastic_strain_increment, rtol=1e-9, atol=1e-18)


@pytest.mark.parametrize(("modulus", "recall"), [(50e9, 0.0), (50e9, 200.0), (5e9, 2000.0)])
def test_return_is_consistent_for_random_multiaxial_states(modulus, recall):
    rng = np.random.default_rng(7)
    trial = rng.normal(scale=800e6, size=(1000, 6))
    x_old = deviator(rng.normal(scale=100e6, size=(1000, 6)))
    p = rng.uniform(0, 0.02, 1000)
    law = PerfectPlasticity(SY)
    kin = KinematicLaw(modulus, recall)
    ret = return_map(trial, p, law, MU, kinematic=kin, backstress=x_old)
    eta = deviator(ret.stress) - ret.backstress
    q = np.sqrt(1.5 * double_contraction(eta, eta))
    assert np.all(q[ret.plastic] == pytest.approx(SY, rel=1e-10))
    assert np.all(q[~ret.plastic] <= SY)
    # plastic flow is deviatoric and along η; the backstress stays deviatoric
    assert np.abs(ret.plastic_strain_increment[:, :3].sum(axis=1)).max() < 1e-15
    assert np.abs(ret.backstress[:, :3].sum(axis=1)).max() < 1e-6
    # the stress is the trial stress minus 2μ Δεp
    np.testing.assert_allclose(ret.stress, trial - 2 * MU * ret.plastic_strain_increment,
                               rtol=0, atol=1e-4 * SY)


def test_stress_controlled_cycles_with_a_mean_stress_ratchet():
    """Armstrong–Frederick under a mean stress: the plastic strain grows every cycle."""
    ds = cycle(af(), E, NU, amplitude=350e6, mean=100e6, cycles=4, increments=40,
                         control="stress")
    ep = ds["plastic_strain"].sel(component="11").values
    peaks = ep[40::80]  # at each maximum of the stress
    assert np.all(np.diff(peaks) > 0)


def test_shear_cycles_stay_on_the_yield_surface():
    ds = cycle(af(), E, NU, amplitude=0.004, cycles=1, increments=30, mode="shear")
    stress, x = ds["stress"].values, ds["backstress"].values
    p = ds["equivalent_plastic_strain"].values
    plastic = np.diff(p) > 0
    eta = deviator(stress) - x
    q = np.sqrt(1.5 * double_contraction(eta, eta))
    np.testing.assert_allclose(q[1:][plastic], SY, rtol=1e-10)
    assert np.abs(stress[:, :3]).max() < 1e-9 * SY


def test_cycle_path():
    path = cycle_path(1.0, 1, 2)
    np.testing.assert_allclose(path, [0.5, 1.0, 0.0, -1.0, 0.0, 1.0])


def test_kinematic_hardening_in_a_case_changes_its_id_and_fields():
    case = load_case(ROOT / "configs" / "rolling-smooth.toml",
                     ["body.hardening.kinematic.modulus=50e9"])
    assert case.body.hardening.kinematic.recall == 0.0
    assert "backstress" in case.stored_fields()
    assert case.case_id != load_case(ROOT / "configs" / "rolling-smooth.toml").case_id


def test_laws_without_kinematic_hardening_keep_their_case_id():
    case = load_case(ROOT / "configs" / "rolling-smooth.toml")
    assert "kinematic" not in case.identity()["body"]["hardening"]


MATERIAL_CASE = """
name = "af-steel"
[body]
E = 210e9
nu = 0.3
[body.hardening]
law = "perfectly_plastic"
yield_stress = 300e6
kinematic = { modulus = 50e9, recall = 200.0 }
[counterbody]
kind = "rigid"
radius = 1e-3
[grid]
nx = 16
ny = 16
nz = 4
[[load_path]]
kind = "load"
to = 1.0
"""


def test_material_point_stage_from_the_command_line(tmp_path, capsys):
    import xarray as xr

    from sacflow.cli import EXIT_CONFIG, main

    case = tmp_path / "af.toml"
    case.write_text(MATERIAL_CASE)
    out = tmp_path / "out"
    assert main(["compare", "material-point", str(case), "--amplitude", "0.01", "--cycles", "1",
                 "--increments", "10", "--out", str(out)]) == 0
    with xr.open_dataset(out / "af-material-point.nc") as ds:
        alpha = 1.5 * ds["backstress"].sel(component="11").values
        ep = ds["plastic_strain"].sel(component="11").values
        assert alpha[10] == pytest.approx(C / GAMMA * (1 - np.exp(-GAMMA * ep[10])), rel=1e-12)
        assert ds.attrs["stage"] == "material-point"
    assert (out / "af-material-point.png").stat().st_size > 10_000
    # mistakes: an elastic body, no amplitude
    elastic = tmp_path / "elastic.toml"
    elastic.write_text((ROOT / "configs" / "hertz-elastic.toml").read_text())
    assert main(["compare", "material-point", str(elastic), "--amplitude", "0.01",
                 "--out", str(out)]) == EXIT_CONFIG
    assert main(["compare", "material-point", str(case), "--out", str(out)]) == EXIT_CONFIG
    err = capsys.readouterr().err
    assert "the body is elastic" in err and "needs --amplitude" in err
