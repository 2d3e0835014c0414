"""Repeated rolling: what each pass adds, and whether the body shakes down or ratchets.

``sacflow compare passes RUN.nc`` on a run whose roll segment has ``passes > 1`` (the volume
fields are stored at the end of every pass). Per pass k, from the end of pass k − 1 (the virgin
or initial state for the first pass, which includes the first loading) to the end of pass k:

* ``pass_plastic_increment_max``: the largest increment Δp of the equivalent plastic strain;
* ``pass_plastic_increment_integral``: ∫ Δp dV over the body grid [m³]: how much plastic flow
  the pass caused;
* ``pass_net_plastic_strain_integral``: ∫ sqrt(2/3 Δεp:Δεp) dV [m³], Δεp the change of the
  plastic strain *tensor* over the pass: the flow that did not reverse within it;
* ``pass_residual_displacement``: the largest residual surface displacement on the track centre
  at the end of the pass [m].

The verdict (attribute ``verdict``, with the rule in ``verdict_rule``) compares the last pass
with the first and the one before it (Johnson, *Contact Mechanics*, 1985, §9.3; Ponter, Hearle &
Johnson, J. Mech. Phys. Solids 33 (1985) 339):

* ``elastic``: no plastic flow in any pass;
* ``ratcheting``: the flow no longer decays (last ≥ :data:`STEADY_RATIO` × the pass before),
  and neither does its net part (net ≥ :data:`STEADY_RATIO` × the pass before's net, and at least
  :data:`RATCHET_FRACTION` of the pass's ∫Δp): strain accumulates by a steady amount every
  pass, however much of the flow reverses within it;
* ``plastic shakedown``: the flow no longer decays but its net part does (alternating
  plasticity: the cycle closes);
* ``elastic shakedown``: the flow stopped, or still decays (last < :data:`STEADY_RATIO` × the
  pass before) at a rate that does not slow down (the last ratio of successive passes at most
  :data:`SLOWING_FACTOR` × the one before it) and is down to :data:`SHAKEDOWN_FRACTION` of the
  first pass's or less;
* ``undecided``: still decaying, but not yet that far, or ever more slowly (near the shakedown
  limit the ratio of successive passes creeps towards 1): run more passes.

The decay is tested first: a flow that has levelled off at a small fraction of the first pass's
(whose flow includes the first loading) is a steady cycle, not shakedown. A pass's flow at or
below the solver's resolution counts as none: each step's plastic increment is converged to
``solver.plasticity_tolerance`` of the plastic strain present, so a pass of n steps leaves about
n × tolerance × (the first pass's flow) unresolved (attribute ``no_flow_below_m3``); below that,
ratios of successive passes are noise.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from sacflow.compare.core import CompareError, case_of, load_run, require

__all__ = ["SHAKEDOWN_FRACTION", "passes", "plot_passes"]

#: Last pass's plastic flow over the first's at or below which the body has shaken down.
SHAKEDOWN_FRACTION = 1e-2
#: Ratio of the last two passes' plastic flow above which the flow no longer decays.
STEADY_RATIO = 0.5
#: Growth of the ratio of successive passes' flow, from one pass to the next, above which the
#: decay counts as slowing down (3 or more passes): a geometric decay converges, a slowing one
#: may not.
SLOWING_FACTOR = 1.1
#: Share of a pass's plastic flow below which its net part counts as a closed cycle (a floor
#: well above the fixed-point tolerance, 1e-6 of the strain, at which a closed cycle closes).
RATCHET_FRACTION = 1e-2


def passes(run: str | Path | xr.Dataset) -> xr.Dataset:
    """Per-pass plastic flow and the shakedown verdict of a repeated rolling run (module doc).

    Raises
    ------
    CompareError
        When the run has fewer than two passes, lacks the fields, or misses a pass's end.
    """
    from sacflow.config.solver_inputs import case_steps

    stage = "passes"
    ds = load_run(run)
    require(ds, "equivalent_plastic_strain", "plastic_strain", "residual_displacement",
            "load_x2", stage=stage)
    case = case_of(ds)
    plan = case_steps(case)
    ends = [i for i, s in enumerate(plan) if s.pass_end]
    if len(ends) < 2:
        raise CompareError(f"{stage}: the run has {len(ends)} rolling pass(es); give its roll "
                           "segment passes >= 2")
    steps = ds["step"].values
    missing = [e for e in ends if e not in steps or bool(
        ds["equivalent_plastic_strain"].sel(step=e).isnull().all())]
    if missing:
        raise CompareError(f"{stage}: no volume fields at the end of pass(es) ending at steps "
                           f"{missing[:5]}; the run is unfinished or older than pass storage")
    cell = _cell_volume(ds)
    p_prev = np.zeros(ds["equivalent_plastic_strain"].shape[1:])
    e_prev = np.zeros(ds["plastic_strain"].shape[1:])
    rows: dict[str, list[float]] = {k: [] for k in (
        "max", "integral", "net", "residual")}
    for end in ends:
        at = ds.sel(step=end)
        p = np.nan_to_num(at["equivalent_plastic_strain"].values)
        e = np.nan_to_num(at["plastic_strain"].values)
        dp, de = p - p_prev, e - e_prev
        net = np.sqrt(2.0 / 3.0 * (np.sum(de[..., :3] ** 2, axis=-1)
                                   + 2.0 * np.sum(de[..., 3:] ** 2, axis=-1)))
        rows["max"].append(float(dp.max()))
        rows["integral"].append(float(dp.sum() * cell))
        rows["net"].append(float(net.sum() * cell))
        track = at["residual_displacement"].sel(x2=float(at["load_x2"]), method="nearest")
        rows["residual"].append(float(track.max()))
        p_prev, e_prev = p, e
    # what the fixed point leaves unresolved in a pass: each step's increment is converged to
    # plasticity_tolerance of the plastic strain present (about the first pass's flow)
    floor = (ends[-1] - ends[-2]) * case.solver.plasticity_tolerance * rows["integral"][0]
    verdict = classify(rows["integral"], rows["net"], floor)
    n = len(ends)
    result = xr.Dataset(
        {
            "pass_plastic_increment_max": ("pass", rows["max"], {
                "units": "1", "long_name": "largest increment of p over the pass"}),
            "pass_plastic_increment_integral": ("pass", rows["integral"], {
                "units": "m3", "long_name": "volume integral of the increment of p"}),
            "pass_net_plastic_strain_integral": ("pass", rows["net"], {
                "units": "m3", "long_name": "volume integral of the equivalent net change "
                "of the plastic strain tensor"}),
            "pass_residual_displacement": ("pass", rows["residual"], {
                "units": "m", "long_name": "largest residual displacement on the track "
                "centre at the end of the pass"}),
            "pass_end_step": ("pass", np.array(ends, dtype=np.int32), {
                "units": "1", "long_name": "last rolling step of the pass"}),
            "last_over_first": ((), rows["integral"][-1] / rows["integral"][0]
                                if rows["integral"][0] > 0 else 0.0, {
                "units": "1", "long_name": "plastic flow of the last pass over the first's"}),
        },
        coords={"pass": ("pass", np.arange(n, dtype=np.int32),
                         {"units": "1", "long_name": "rolling pass, from 0"})},
    )
    result.attrs.update(stage=stage, case=case.name, Conventions="CF-1.10", verdict=verdict,
                        verdict_rule=VERDICT_RULE, no_flow_below_m3=floor)
    return result


VERDICT_RULE = (
    f"a pass's flow counts as none at or below (steps of the last pass) x "
    f"plasticity_tolerance x the first pass's flow (attribute no_flow_below_m3); "
    f"elastic: no plastic flow; ratcheting: last pass's integral of dp >= {STEADY_RATIO:g} x "
    f"the pass before, its net plastic strain >= {STEADY_RATIO:g} x the pass before's and >= "
    f"{RATCHET_FRACTION:g} x its integral of dp; plastic shakedown: last >= {STEADY_RATIO:g} x "
    f"the pass before, net not so; elastic shakedown: no flow in the last pass, or last < "
    f"{STEADY_RATIO:g} x the pass before, that ratio at most {SLOWING_FACTOR:g} x the previous "
    f"one, and last <= {SHAKEDOWN_FRACTION:g} x the first's; else undecided"
)


def classify(flow: list[float], net: list[float], floor: float = 0.0) -> str:
    """Return the verdict (module docstring) from the per-pass flow ∫Δp and net ∫|Δεp|.

    ``floor`` [m³]: a pass's flow at or below it counts as none (the solver's resolution).
    """
    if max(flow) <= floor:
        return "elastic"
    if flow[-1] <= floor:
        return "elastic shakedown"
    if flow[-1] >= STEADY_RATIO * flow[-2]:
        steady_net = net[-1] >= STEADY_RATIO * net[-2] and net[-1] >= RATCHET_FRACTION * flow[-1]
        return "ratcheting" if steady_net else "plastic shakedown"
    slowing = len(flow) >= 3 and flow[-2] > 0.0 and (
        flow[-1] * flow[-3] > SLOWING_FACTOR * flow[-2] ** 2)  # r_last > SLOWING_FACTOR r_prev
    if flow[-1] <= SHAKEDOWN_FRACTION * flow[0] and not slowing:
        return "elastic shakedown"
    return "undecided"


def _cell_volume(ds: xr.Dataset) -> float:
    spacing = [float(np.diff(ds[d].values).mean()) if ds.sizes[d] > 1 else 0.0
               for d in ("x1", "x2", "x3")]
    return float(np.prod(spacing))


def plot_passes(result: xr.Dataset) -> Figure:
    """Plastic flow per pass (log scale) and the residual displacement at each pass's end."""
    fig = Figure(figsize=(10.0, 4.2), layout="constrained")
    left, right = fig.subplots(1, 2)
    k = result["pass"].values + 1
    left.semilogy(k, result["pass_plastic_increment_integral"] * 1e9, "o-", label="∫Δp dV")
    left.semilogy(k, result["pass_net_plastic_strain_integral"] * 1e9, "s--",
                  label="net ∫|Δεp| dV")
    left.set(xlabel="pass", ylabel="plastic flow of the pass [mm³]",
             title=f"verdict: {result.attrs['verdict']}")
    left.legend()
    right.plot(k, result["pass_residual_displacement"] * 1e9, "o-")
    right.set(xlabel="pass", ylabel="residual displacement on the track [nm]")
    for ax in (left, right):
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"{result.attrs.get('case', '')}: repeated rolling")
    return fig
