"""Repeated rolling (issue #19, part): passes in the load path, pass labels, shakedown verdict.

* the load path expands into passes with their labels (lifted between passes, or rolled back);
  cases without ``passes`` keep their steps and case id;
* the per-pass report's rule on synthetic flows;
* an elastic–perfectly plastic half-space under repeated free rolling at p0 = 3.5 k (between
  first yield, 2.79 k, and the shakedown limit, about 4.7 k): the plastic flow per pass falls by
  more than 100× within five passes (elastic shakedown); at 6 k (slow test) it tends to a
  non-zero constant.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from sacflow.compare.pass_history import classify, passes
from sacflow.config.solver_inputs import case_steps
from sacflow.runner import run_case
from sacflow.storage.case_file import load_case

ROOT = Path(__file__).resolve().parents[1]
SMOOTH = ROOT / "configs" / "rolling-smooth.toml"


def test_lifted_passes_unload_return_and_reload():
    case = load_case(SMOOTH, ["load_path.0.increments=1", "load_path.1.steps=2",
                              "load_path.1.passes=3", "load_path.1.lift_increments=1"])
    steps = case_steps(case)
    loads = [s.load for s in steps]
    x1 = [round(s.position[0] * 1e3, 6) for s in steps]
    labels = [s.pass_index for s in steps]
    ends = [i for i, s in enumerate(steps) if s.pass_end]
    assert loads == [4200, 4200, 4200, 0, 4200, 4200, 4200, 0, 4200, 4200, 4200, 2100, 0]
    assert x1 == [0, 2.1, 4.2, 4.2, 0, 2.1, 4.2, 4.2, 0, 2.1, 4.2, 4.2, 4.2]
    assert labels == [0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 2]
    assert ends == [2, 6, 10]


def test_reversed_passes_roll_back_over_the_track():
    case = load_case(SMOOTH, ["load_path.0.increments=1", "load_path.1.steps=2",
                              "load_path.1.passes=3", "load_path.1.between=reverse"])
    x1 = [round(s.position[0] * 1e3, 6) for s in case_steps(case)]
    assert x1 == [0, 2.1, 4.2, 2.1, 0, 2.1, 4.2, 4.2, 4.2]


def test_cases_without_passes_are_unchanged():
    case = load_case(SMOOTH)
    steps = case_steps(case)
    assert {s.pass_index for s in steps} == {0}
    assert "passes" not in case.identity()["load_path"][1]
    # as before passes existed (issue #15's identity), with the one-step return of those runs
    solver = case.solver.model_copy(update={"return_integration": "backward_euler"})
    assert case.model_copy(update={"solver": solver}).case_id == "8ce69a0f0c18"


@pytest.mark.parametrize(
    ("flow", "net", "verdict"),
    [
        ([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], "elastic"),
        ([1.0, 0.1, 0.005], [1.0, 0.1, 0.005], "elastic shakedown"),
        ([1.0, 0.5, 0.45], [0.9, 0.4, 0.4], "ratcheting"),
        ([1.0, 0.5, 0.45], [0.9, 0.1, 0.02], "plastic shakedown"),
        ([1.0, 0.3, 0.1], [1.0, 0.3, 0.1], "undecided"),
        ([1.0, 0.1, 0.0], [1.0, 0.1, 0.0], "elastic shakedown"),
        # decaying by 5x, then by 2.5x: slowing down, and may yet level off
        ([1.0, 0.02, 0.004, 0.0016], [1.0, 0.02, 0.004, 0.0016], "undecided"),
        ([1.0, 0.02, 0.004, 0.0008], [1.0, 0.02, 0.004, 0.0008], "elastic shakedown"),
        # levelled off below 1 % of the first pass: a steady cycle, not shakedown
        ([1.0, 0.004, 0.003], [1.0, 0.001, 0.0002], "plastic shakedown"),
        ([1.0, 0.004, 0.003], [1.0, 0.001, 0.0008], "ratcheting"),
        # a steady net part that is mostly reversed flow still ratchets; below 1 % it is noise
        ([1.0, 0.5, 0.45], [0.9, 0.05, 0.045], "ratcheting"),
        ([1.0, 0.5, 0.45], [0.9, 1e-4, 1e-4], "plastic shakedown"),
    ],
)
def test_verdict_rule(flow, net, verdict):
    assert classify(flow, net) == verdict


def test_flow_at_the_solver_resolution_counts_as_none():
    # a tail of noise-level passes (ratio 0.7) is shakedown once below the floor, not ratcheting
    flow = [1.0, 1e-3, 1e-5, 7e-6]
    assert classify(flow, flow) == "ratcheting"
    assert classify(flow, flow, floor=2.4e-5) == "elastic shakedown"
    assert classify([1e-6, 1e-7], [1e-6, 1e-7], floor=1e-5) == "elastic"


TINY = ["grid.nx=12", "grid.ny=12", "grid.nz=6", "load_path.1.steps=12",
        "load_path.1.passes=5"]


def test_below_the_shakedown_limit_the_flow_dies_out(tmp_path):
    """p0 = 3.5 k, five passes, 12 × 12 × 6 cells.

    Measured when written: ∫Δp per pass 8.5e-13, 2.6e-14, 2.9e-15, 3.5e-16, 4.4e-17 m³ (the
    fifth 5e-5 of the first), residual displacement on the track 426 → 438 nm.
    """
    case = load_case(ROOT / "configs" / "rolling-cycles-shakedown.toml", TINY)
    path = run_case(case, tmp_path, progress=False).path
    with xr.open_dataset(path) as ds:
        assert list(np.unique(ds["pass"].values)) == [0, 1, 2, 3, 4]
    report = passes(path)
    flow = report["pass_plastic_increment_integral"].values
    assert flow[0] > 0 and flow[4] < 1e-2 * flow[0]
    assert np.all(np.diff(flow) < 0)
    assert report.attrs["verdict"] == "elastic shakedown"


@pytest.mark.slow
def test_above_the_shakedown_limit_the_flow_does_not(tmp_path):
    """p0 = 6 k, six passes: the flow per pass tends to a non-zero constant.

    Measured when written (16 × 16 × 8 cells, 16 steps per pass): ∫Δp per pass 1.28e-10,
    1.41e-11, 5.2e-12, 3.8e-12, 3.3e-12, 3.1e-12 m³ (last over the one before 0.94).
    """
    case = load_case(ROOT / "configs" / "rolling-cycles-ratcheting.toml",
                     ["grid.nx=16", "grid.ny=16", "grid.nz=8", "load_path.1.steps=16"])
    report = passes(run_case(case, tmp_path, progress=False).path)
    flow = report["pass_plastic_increment_integral"].values
    assert flow[-1] > 0.8 * flow[-2] and flow[-1] > 1e-2 * flow[0]
    assert report.attrs["verdict"] in ("ratcheting", "plastic shakedown")


def test_the_shakedown_campaign_sweeps_p0_over_k_at_a_roll_distance_of_4a():
    """configs/campaign-rolling-cycles.toml: its loads give the p0/k it states (closed-form
    Hertz) and each roll distance is 4 a at its load, so only p0/k changes between cases."""
    from sacflow.campaign.expansion import expand_campaign, load_campaign
    from sacflow.mechanics.hertz import composite_modulus, hertz_contact

    cases = expand_campaign(load_campaign(ROOT / "configs" / "campaign-rolling-cycles.toml"))
    ratios = []
    for entry in cases:
        case = entry.case
        e_star = composite_modulus(case.body.E, case.body.nu, case.counterbody.E,
                                   case.counterbody.nu)
        hertz = hertz_contact(case.load_path[0].to, case.counterbody.radius, e_star)
        k = case.body.hardening.yield_stress / np.sqrt(3.0)
        ratios.append(hertz.p0 / k)
        assert case.load_path[1].distance == pytest.approx(4.0 * hertz.a, rel=1e-4)
        assert case.load_path[1].passes == 6
    np.testing.assert_allclose(ratios, [3.5, 4.0, 4.5, 4.75, 5.0, 5.25, 5.5, 6.0], rtol=1e-4)


def test_the_gap_can_leave_the_residual_displacement_out(tmp_path):
    """``solver.residual_displacement_in_gap = false``: the contact sees the undeformed surface,
    so the pressure is that of the elastic body at every step, while the plastic strain and
    the residual displacement it leaves are still computed and stored. With the default, the
    plastic groove spreads the pressure: its peak falls below the elastic one. The default
    keeps the case id."""
    short = ["grid.nx=12", "grid.ny=12", "grid.nz=6", "load_path.1.steps=6",
             "load_path.1.passes=2"]
    config = ROOT / "configs" / "rolling-cycles-shakedown.toml"
    fixed = load_case(config, [*short, "solver.residual_displacement_in_gap=false"])
    coupled = load_case(config, short)
    elastic = load_case(config, [*short, "body.hardening.yield_stress=1e12"])
    assert coupled.case_id == load_case(config, [
        *short, "solver.residual_displacement_in_gap=true"]).case_id
    assert fixed.case_id != coupled.case_id
    runs = {}
    for name, case in (("fixed", fixed), ("coupled", coupled), ("elastic", elastic)):
        path = run_case(case, tmp_path / name, progress=False).path
        with xr.open_dataset(path) as ds:
            runs[name] = {v: ds[v].values for v in ("pressure", "max_pressure",
                                                     "residual_displacement", "load")}
    loaded = runs["fixed"]["load"] > 0
    assert_pressure = runs["elastic"]["pressure"][loaded]
    np.testing.assert_allclose(runs["fixed"]["pressure"][loaded], assert_pressure,
                               rtol=0, atol=1e-8 * assert_pressure.max(),
                               err_msg="the fixed gap's pressure is the elastic one")
    assert np.abs(runs["fixed"]["residual_displacement"][-1]).max() > 0
    peak = runs["elastic"]["max_pressure"][loaded]
    assert np.all(runs["coupled"]["max_pressure"][loaded][4:] < 0.99 * peak[4:]), \
        "the groove spreads the pressure"
