"""Slow groups of ``pipelines/record_doc_numbers.py`` for docs/initial-states.md,
docs/friction.md and docs/repeated-rolling.md (issue #30): shipped cases and pipelines at their
shipped grids (minutes each; finished runs in the output folder are reused).

Each group is a function of the output folder returning ``{key: value in SI units}``; the rows
of ``data/doc_numbers.csv`` name the group. The fast groups are in ``doc_number_groups_b.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from doc_number_groups_b import K_CYCLES, campaign_cases, import_script, shipped_case


# --------------------------------------------------------------------- docs/initial-states.md
def _surface_numbers(path: Path) -> dict[str, float]:
    """The dent of a text surface (height positive outward): depth, hollow along x1 on the
    track centre (cell centres below the plane), rim height."""
    x1, x2, height = np.loadtxt(path, comments="#", unpack=True)
    centre = np.isclose(x2, x2[np.argmin(np.abs(x2))])
    hollow = x1[centre & (height < 0.0)]
    return {"depth": float(-height.min()), "hollow_from": float(hollow.min()),
            "hollow_to": float(hollow.max()), "rim": float(height.max())}


def dent_from_indentation(out: Path) -> dict[str, float]:
    """``python pipelines/dent_from_indentation.py`` at its shipped grids (docs/initial-states.md):
    the press, the chained and the shape-only rolling runs, their comparison and fatigue."""
    import xarray as xr

    from sacflow.compare.fatigue_index import fatigue
    from sacflow.runner import run_case
    from sacflow.storage.case_file import load_case

    pipeline = import_script("pipelines", "dent_from_indentation")
    folder = out / "dent-from-indentation"
    compared = pipeline.compare_histories(folder, [], [], progress=False)
    numbers = {f"dent_indentation_{k}": v for k, v in compared.items()}
    press = run_case(load_case(pipeline.PRESS), folder, progress=False).path
    with xr.open_dataset(press) as ds:
        last = ds.isel(step=-1)
        numbers["dent_indentation_press_depth"] = float(last["residual_displacement"].max())
        numbers["dent_indentation_press_max_eqps"] = float(
            last["equivalent_plastic_strain"].max())
    surface = _surface_numbers(folder / pipeline.SURFACE)
    numbers |= {f"dent_indentation_surface_{k}": v for k, v in surface.items()}
    chained = load_case(pipeline.CHAINED, [f"initial_state.run={press}"])
    numbers["dent_indentation_smooth_p0"] = chained.hertz().p0
    for label in ("rolling", "geometric"):
        run = folder / f"dent-from-indentation-{label}.nc"
        with xr.open_dataset(run) as ds:
            numbers[f"dent_indentation_peak_pressure_{label}"] = float(ds["max_pressure"].max())
        index = fatigue(run)
        for name in ("dang_van", "crossland"):
            for what in ("", "_x1", "_x2", "_depth"):
                numbers[f"dent_indentation_{name}_track_max{what}_{label}"] = float(
                    index[f"{name}_track_max{what}"])
            # the track is symmetric about x2 = 0: the lateral distance, whichever side
            # holds the maximum of two equal rims
            numbers[f"dent_indentation_{name}_track_max_x2_{label}"] = abs(
                numbers[f"dent_indentation_{name}_track_max_x2_{label}"])
    peak = [numbers[f"dent_indentation_peak_pressure_{k}"] for k in ("rolling", "geometric")]
    numbers["dent_indentation_peak_over_p0"] = peak[1] / numbers["dent_indentation_smooth_p0"]
    numbers["dent_indentation_peak_spread"] = (max(peak) - min(peak)) / max(peak)
    numbers["dent_indentation_dang_van_drop"] = 1.0 - numbers["dent_indentation_dang_van_ratio"]
    numbers["dent_indentation_crossland_ratio"] = (
        numbers["dent_indentation_crossland_track_max_rolling"]
        / numbers["dent_indentation_crossland_track_max_geometric"] - 1.0)
    return numbers


#: docs/initial-states.md's depth on the axis where the 72² × 64 press oscillates [m].
OSCILLATION_DEPTH = 100e-6


def dent_hydrostatic_runs(out: Path) -> dict[str, float]:
    """``python pipelines/dent_hydrostatic.py``'s press runs (its JSON cache in ``out``; about
    20 min on 2 cores): σ33 on the axis at 100 µm, the largest εp, the imprint's edge and rim."""
    pipeline = import_script("pipelines", "dent_hydrostatic")
    from sacflow.studies.convergence import base_case, shipped_discretisation

    depth = shipped_discretisation(base_case(pipeline.STUDY_CASE)).depth
    folder = out / "dent-hydrostatic"
    folder.mkdir(parents=True, exist_ok=True)
    numbers: dict[str, float] = {}
    for nx, nz in pipeline.parse_grids(pipeline.DEFAULT_GRIDS):
        data = pipeline.cached_run(folder, nx, nz, depth)
        grid = f"{nx}x{nz}"
        x3 = np.asarray(data["x3"])
        numbers[f"press_{grid}_max_eqps"] = float(data["max_plastic_strain"])
        numbers[f"press_{grid}_s33_axis_100um"] = float(
            np.interp(OSCILLATION_DEPTH, x3, data["s33_axis"]))
        x1, surface = np.asarray(data["x1"]), np.asarray(data["surface"])
        outside = x1[(x1 > 0) & (surface < 0)]  # displaced outward: above the original plane
        numbers[f"press_{grid}_imprint_edge"] = float(outside.min())
        numbers[f"press_{grid}_rim_peak"] = float(x1[x1 > 0][np.argmin(surface[x1 > 0])])
    return numbers



def _after_rolling(path: Path, a: float) -> dict[str, float]:
    """A rolling run after the pass (its last step, unloaded): the largest εp, its depth, the
    εp-weighted mean depth and the shallowest plastic layer (in a), the most compressive
    residual σ11 and the largest residual surface displacement on the track centre (x2 = 0),
    and the largest von Mises stress over the yield stress of the stored steps."""
    import xarray as xr

    with xr.open_dataset(path) as ds:
        last = ds.isel(step=-1)
        eqps = last["equivalent_plastic_strain"].transpose("x1", "x2", "x3").values
        x3 = ds["x3"].values
        plastic = eqps.max(axis=(0, 1)) > 0.0
        k = np.unravel_index(int(np.argmax(eqps)), eqps.shape)[2]
        centre = last.sel(x2=0.0, method="nearest")
        ratio = (ds["von_mises"] / ds["yield_stress"]).max()
        weights = eqps.sum(axis=(0, 1))
        return {
            "max_eqps": float(eqps.max()), "max_eqps_depth": float(x3[k] / a),
            "mean_depth": float((weights * x3).sum() / weights.sum() / a) if plastic.any()
            else np.nan,
            "shallowest_plastic": float(x3[plastic].min() / a) if plastic.any() else np.nan,
            "first_layer": float(x3[0] / a),
            "min_residual_s11": float(centre["residual_stress"].sel(component="11").min()),
            "residual_displacement": float(centre["residual_displacement"].max()),
            "von_mises_over_yield": float(ratio),
        }


def case_hardened_rolling(out: Path) -> dict[str, float]:
    """docs/initial-states.md: configs/rolling-smooth.toml and configs/case-hardened-rolling.toml
    at their shipped grid (24 × 24 × 11, 177 steps; a minute or two)."""
    from sacflow.runner import run_case

    numbers: dict[str, float] = {}
    for name in ("rolling-smooth", "case-hardened-rolling"):
        case = shipped_case(f"configs/{name}.toml")
        path = run_case(case, out, progress=False).path
        after = _after_rolling(path, case.hertz().a)
        numbers |= {f"{name}_{k}": v for k, v in after.items()}
        numbers[f"{name}_max_eqps_depth_m"] = after["max_eqps_depth"] * case.hertz().a
    numbers["case-hardened-rolling_margin"] = 1.0 - numbers[
        "case-hardened-rolling_von_mises_over_yield"]
    return numbers


#: Traction coefficients of configs/campaign-rolling-traction.toml.
TRACTION_MU = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5)


def rolling_traction_campaign(out: Path) -> dict[str, float]:
    """docs/friction.md: configs/campaign-rolling-traction.toml's six cases (its base,
    rolling-smooth-traction, at each μ; a few minutes), after the pass."""
    from sacflow.runner import run_case

    numbers: dict[str, float] = {}
    for mu in TRACTION_MU:
        case = shipped_case("configs/rolling-smooth-traction.toml",
                     (f"friction.coefficient={mu}", f"name=rolling-traction-mu{mu:g}"))
        after = _after_rolling(run_case(case, out, progress=False).path, case.hertz().a)
        numbers |= {f"traction_mu{mu:g}_{k}": v for k, v in after.items()}
    return numbers



# ------------------------------------------------------------------- docs/repeated-rolling.md
#: Nominal p0/k of configs/campaign-rolling-cycles.toml's cases, in its order.
CYCLES_LABELS = ("3.5", "4.0", "4.5", "4.75", "5.0", "5.25", "5.5", "6.0")
#: The loads docs/repeated-rolling.md also runs for 14 passes.
LONG_LABELS = ("4.5", "4.75", "5.0", "5.25")
VERDICTS = ("elastic", "elastic shakedown", "plastic shakedown", "ratcheting", "undecided")


def _cycles_run(out: Path, label: str, load: float, distance: float, passes: int = 6) -> Path:
    from sacflow.runner import run_case

    more = () if passes == 6 else (f"load_path.1.passes={passes}",)
    case = shipped_case("configs/rolling-cycles-shakedown.toml", (
        f"load_path.0.to={load}", f"load_path.1.distance={distance}", *more,
        f"name=rolling-cycles-{label}k" + ("" if passes == 6 else f"-{passes}")))
    return run_case(case, out, progress=False).path


def _pass_numbers(path: Path, stem: str) -> dict[str, float]:
    """``sacflow compare passes``: the flow of each pass over the first's, successive ratios,
    the verdict (its index in VERDICTS), the last pass's largest Δp and net share, the residual
    displacement at the end of each pass, the no-flow floor over the first pass's flow."""
    from sacflow.compare import passes

    result = passes(path)
    flow = result["pass_plastic_increment_integral"].values
    numbers = {f"{stem}_verdict": float(VERDICTS.index(result.attrs["verdict"])),
               f"{stem}_floor": float(result.attrs["no_flow_below_m3"]) / flow[0],
               f"{stem}_last_max": float(result["pass_plastic_increment_max"].values[-1]),
               f"{stem}_last_net_share": float(
                   result["pass_net_plastic_strain_integral"].values[-1] / flow[-1])}
    for k in range(1, flow.size):
        numbers[f"{stem}_flow_{k + 1}"] = float(flow[k] / flow[0])
        numbers[f"{stem}_ratio_{k + 1}"] = float(flow[k] / flow[k - 1])
    for k, value in enumerate(result["pass_residual_displacement"].values):
        numbers[f"{stem}_residual_{k + 1}"] = float(value)
    return numbers


def _last_pass_pressure(path: Path) -> tuple[float, float, float]:
    """The range of the peak pressure over the full-load rolling steps of the last pass, and
    the peak pressure at the end of the first loading [Pa]."""
    import xarray as xr

    with xr.open_dataset(path) as ds:
        last = ds["pass"].values.max()
        full = ds["load"].values >= ds["load"].values.max() * (1.0 - 1e-12)
        rolled = ds["max_pressure"].values[(ds["pass"].values == last) & full]
        return float(rolled.min()), float(rolled.max()), float(
            ds["max_pressure"].values[int(np.argmax(full))])


def rolling_cycles(out: Path) -> dict[str, float]:
    """docs/repeated-rolling.md: configs/campaign-rolling-cycles.toml's eight cases (six passes;
    about 6 min on 2 cores) with ``sacflow compare passes`` and, at 5.5 and 6.0 k, ``sacflow
    compare melan``; the pressure of the last pass; then four of them for 14 passes."""
    from sacflow.compare import melan

    numbers: dict[str, float] = {}
    cases = dict(zip(CYCLES_LABELS, campaign_cases("configs/campaign-rolling-cycles.toml"),
                     strict=True))
    for label, (load, distance) in cases.items():
        path = _cycles_run(out, label, load, distance)
        numbers |= _pass_numbers(path, f"cycles_{label}")
        low, high, first = _last_pass_pressure(path)
        numbers |= {f"cycles_{label}_last_pass_peak_min": low / K_CYCLES,
                    f"cycles_{label}_last_pass_peak_max": high / K_CYCLES,
                    f"cycles_{label}_first_loading_peak": first / K_CYCLES}
        if label in ("5.5", "6.0"):
            result = melan(path)
            numbers[f"melan_{label}k_load_factor"] = float(result["load_factor"])
            numbers[f"melan_{label}k_peak"] = float(result["peak_pressure"])
    for label in LONG_LABELS:
        numbers |= _pass_numbers(_cycles_run(out, label, *cases[label], passes=14),
                                 f"cycles14_{label}")
    return numbers



#: The seed's Fig. 22 depth docs/repeated-rolling.md reads the residual σ11 at [m].
SEED_PROFILE_DEPTH = 75e-6


def dent_rolling_cycles(out: Path) -> dict[str, float]:
    """configs/dent-rolling-cycles.toml at its shipped grid (four lifted passes, 338 steps;
    about 10 min on 2 cores): per pass ``sacflow compare passes``'s flow and largest Δp, and at
    the pass's end the largest εp, the largest equivalent backstress, the most compressive
    residual σ11 at 75 µm on the track centre and where; the peak pressure of the run."""
    import xarray as xr

    from sacflow.compare import passes
    from sacflow.runner import run_case

    case = shipped_case("configs/dent-rolling-cycles.toml")
    path = run_case(case, out, progress=False).path
    result = passes(path)
    flow = result["pass_plastic_increment_integral"].values
    numbers = {"dent_cycles_verdict": float(VERDICTS.index(result.attrs["verdict"])),
               "dent_cycles_first_over_second": float(flow[0] / flow[1])}
    with xr.open_dataset(path) as ds:
        numbers["dent_cycles_peak_pressure"] = float(ds["max_pressure"].max())
        for k, end in enumerate(result["pass_end_step"].values):
            at = ds.sel(step=int(end))
            x = at["backstress"].transpose(..., "component").values
            backstress = np.sqrt(1.5 * (np.sum(x[..., :3] ** 2, axis=-1)
                                        + 2.0 * np.sum(x[..., 3:] ** 2, axis=-1)))
            s11 = at["residual_stress"].sel(component="11").sel(
                x2=0.0, x3=SEED_PROFILE_DEPTH, method="nearest")
            stem = f"dent_cycles_pass{k + 1}"
            numbers |= {
                f"{stem}_flow": float(flow[k]),
                f"{stem}_max_increment": float(result["pass_plastic_increment_max"].values[k]),
                f"{stem}_max_eqps": float(at["equivalent_plastic_strain"].max()),
                f"{stem}_max_backstress": float(np.nanmax(backstress)),
                f"{stem}_min_s11": float(s11.min()),
                f"{stem}_min_s11_x1": float(s11["x1"].values[int(np.argmin(s11.values))]),
                f"{stem}_s11_depth": float(s11["x3"]),
            }
    return numbers


def shakedown_table(out: Path) -> dict[str, float]:
    """docs/repeated-rolling.md's table of classical limits: ``pipelines/shakedown_bounds.py``'s
    three cases at its settings (about 5 min on 2 cores), every column but the time, in k."""
    bounds = import_script("pipelines", "shakedown_bounds")
    from sacflow.mechanics.shakedown_bracket import rolling_bracket

    root3 = float(np.sqrt(3.0))
    numbers: dict[str, float] = {}
    for contact, kind, settings in bounds.CASES:
        bracket = rolling_bracket(contact, 0.3, kind=kind, **settings)
        stem = f"shakedown_table_{contact}_{kind}"
        numbers |= {f"{stem}_first_yield": root3 * bracket.melan.elastic_limit,
                    f"{stem}_sampled": root3 * bracket.sampled,
                    f"{stem}_lower": root3 * bracket.lower,
                    f"{stem}_ceiling": root3 * bracket.ceiling,
                    f"{stem}_ceiling_low": root3 * bracket.ceiling_low,
                    f"{stem}_gap": bracket.gap,
                    f"{stem}_cell_corners": root3 / bracket.inside.sampled,
                    f"{stem}_outside": root3 / bracket.outside,
                    f"{stem}_residual_alone": root3 / bracket.residual_alone.bound}
    return numbers






#: Load increments of docs/convergence.md's backward-Euler print depths (unloading: half).
EULER_INCREMENTS = (10, 20, 40, 80)


def backward_euler_increments(out: Path) -> dict[str, float]:
    """docs/convergence.md: the 650 mN print depth with one backward-Euler step per increment
    at 32² × 12 cells (the study's box depth) for 10, 20, 40 and 80 load increments (minutes)."""
    from sacflow.config.solver_inputs import simulation_for
    from sacflow.studies.convergence import (
        STUDY_CASES,
        WITHOUT_FAR_TRACTION,
        base_case,
        shipped_discretisation,
    )

    study = STUDY_CASES["nanoindentation-650mN"]
    depth = shipped_discretisation(base_case(study)).depth
    numbers: dict[str, float] = {}
    for n in EULER_INCREMENTS:
        case = base_case(study, [
            "grid.nx=32", "grid.ny=32", "grid.nz=12", f"grid.depth={depth!r}",
            "solver.return_integration=backward_euler", f"load_path.0.increments={n}",
            f"load_path.1.increments={n // 2}", WITHOUT_FAR_TRACTION])
        last = list(simulation_for(case).run())[-1]
        numbers[f"euler_print_depth_{n}"] = float(last.surface["residual_displacement"].max())
    return numbers



def melan_steps(out: Path) -> dict[str, float]:
    """``sacflow compare melan --step`` over every full-load rolling step of the sixth pass at
    nominal 5.0 and 5.5 k (the runs of ``rolling_cycles``, made here if absent; a few minutes):
    λ per step, keyed by step number."""
    import xarray as xr

    from sacflow.compare import melan

    cases = dict(zip(CYCLES_LABELS, campaign_cases("configs/campaign-rolling-cycles.toml"),
                     strict=True))
    numbers: dict[str, float] = {}
    for label in ("5.0", "5.5"):
        path = _cycles_run(out, label, *cases[label])
        with xr.open_dataset(path) as ds:
            full = ds["load"].values >= ds["load"].values.max() * (1.0 - 1e-12)
            last = ds["pass"].values == ds["pass"].values.max()
            steps = [int(k) for k in ds["step"].values[full & last]]
        for step in steps:
            numbers[f"melan_steps_{label}_{step}"] = float(melan(path, step=step)["load_factor"])
    return numbers


GROUPS = {
    "melan_steps": ("slow", melan_steps),
    "backward_euler_increments": ("slow", backward_euler_increments),
    "dent_rolling_cycles": ("slow", dent_rolling_cycles),
    "shakedown_table": ("slow", shakedown_table),
    "rolling_cycles": ("slow", rolling_cycles),
    "case_hardened_rolling": ("slow", case_hardened_rolling),
    "rolling_traction_campaign": ("slow", rolling_traction_campaign),
    "dent_hydrostatic_runs": ("slow", dent_hydrostatic_runs),
    "dent_from_indentation": ("slow", dent_from_indentation),
}
