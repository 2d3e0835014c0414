"""Groups of ``pipelines/record_doc_numbers.py`` for README.md, docs/compare.md,
docs/dent-study.md and docs/inclusions.md (#30).

Each group is a function of the output folder (runs are kept there, finished ones reused)
returning ``{key: value in SI units}``; ``record_doc_numbers.GROUPS`` registers it as fast (closed
forms, case geometry, runs of seconds: recomputed in the default suite) or slow (shipped runs and
campaigns at their shipped grids, minutes: ``pytest -m slow``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: The stress stored per cuboid and step (six float64 components) [bytes].
STRESS_BYTES = 48


def _case(path: str, overrides: tuple[str, ...] = ()):
    from sacflow.storage.case_file import load_case

    return load_case(ROOT / path, list(overrides))


def _run(path: str, out: Path, overrides: tuple[str, ...] = ()) -> Path:
    from sacflow.runner import run_case

    return run_case(_case(path, overrides), out, progress=False).path


def _lowest_point_height(case, position: tuple[float, float]) -> float:
    """Height r²/2R of the counter-body over the cell centre nearest to its lowest point.

    Cell centres lie at (k + ½) d from the window's centre cell boundary (an even window), as
    the simulation places them (``sacflow.solver.simulation``); R is the geometric mean of the
    case's effective radii.
    """
    cell = np.array(case.cell_size())
    offset = np.asarray(position) / cell - 0.5
    r2 = float(np.sum(((offset - np.rint(offset)) * cell) ** 2))
    radius = float(np.sqrt(np.prod(case.effective_radii())))
    return r2 / (2.0 * radius)


def _campaign_cases(path: str) -> list:
    """The validated cases of a shipped campaign file."""
    from sacflow.campaign import expand_campaign, load_campaign

    return [c.case for c in expand_campaign(load_campaign(ROOT / path))]


def _p0_over_k(case) -> float:
    return float(case.hertz().p0 / (case.body.hardening.yield_stress / np.sqrt(3.0)))


def readme_cases(out: Path) -> dict[str, float]:
    """README.md's numbers of shipped cases: Hertz pressures, cells, the approach offsets."""
    from sacflow.config.solver_inputs import case_steps

    rolling = _case("configs/rolling-smooth.toml")
    end = [s for s in case_steps(rolling) if s.load > 0][-1].position
    campaign = _campaign_cases("configs/campaign-rolling-cycles.toml")
    return {
        "rolling_smooth_p0": rolling.hertz().p0,
        "rolling_smooth_cell": rolling.cell_size()[0],
        "approach_offset_hertz": _lowest_point_height(_case("configs/hertz-elastic.toml"),
                                                      (0.0, 0.0)),
        "approach_offset_650mN": _lowest_point_height(
            _case("configs/nanoindentation-650mN.toml"), (0.0, 0.0)),
        "approach_offset_rolling_smooth": _lowest_point_height(rolling, end),
        "rolling_cycles_shakedown_p0_k": _p0_over_k(_case("configs/rolling-cycles-shakedown.toml")),
        "rolling_cycles_ratcheting_p0_k": _p0_over_k(
            _case("configs/rolling-cycles-ratcheting.toml")),
        "campaign_rolling_cycles_p0_k_0": min(_p0_over_k(c) for c in campaign),
        "campaign_rolling_cycles_p0_k_1": max(_p0_over_k(c) for c in campaign),
    }


def hertz_check_grids(out: Path) -> dict[str, float]:
    """docs/compare.md: the stored peak against Hertz p0 of hertz-elastic at 24² and 64² cells."""
    from sacflow.compare import hertz_check

    numbers = {}
    for n in (24, 64):
        path = _run("configs/hertz-elastic.toml", out,
                    (f"grid.nx={n}", f"grid.ny={n}", f"name=hertz-elastic-{n}"))
        numbers[f"hertz_check_p0_error_{n}"] = float(hertz_check(path)["p0_error"])
    return numbers


#: docs/dent-study.md's campaign: dent depth A and width w [m], loads W [N].
DENT_DEPTHS, DENT_WIDTHS, DENT_LOADS = (10e-6, 20e-6, 35e-6), (450e-6, 600e-6, 900e-6), (1318.0,
                                                                                        675.0)
#: docs/dent-study.md's finer grid on a cluster.
FINE_GRID = ("grid.nx=64", "grid.ny=64", "grid.nz=24", "load_path.1.steps=240")


def dent_study_setup(out: Path) -> dict[str, float]:
    """docs/dent-study.md's numbers of the base case: Hertz p0 per load, the narrowest hollow
    in cells, each dent's slope A/w, and the stress a finer grid stores at every step."""
    from sacflow.config.solver_inputs import case_body_grid, case_steps

    base = "pipelines/dent-study-case.toml"
    numbers = {f"dent_study_p0_{w:.0f}": _case(base, (f"load_path.0.to={w}",)).hertz().p0
               for w in DENT_LOADS}
    numbers["dent_rolling_p0"] = _case("configs/dent-rolling.toml").hertz().p0
    numbers["dent_study_hollow_cells"] = min(DENT_WIDTHS) / 2 / _case(base).cell_size()[0]
    for depth in DENT_DEPTHS:
        for width in DENT_WIDTHS:
            numbers[f"dent_study_slope_{depth * 1e6:.0f}_{width * 1e6:.0f}"] = depth / width
    fine = _case(base, FINE_GRID)
    grid = case_body_grid(fine)
    steps = len(case_steps(fine))
    numbers["dent_study_fine_stress_bytes"] = float(
        STRESS_BYTES * grid.body[0] * grid.body[1] * grid.nz * steps)
    return numbers


def inclusion_setup(out: Path) -> dict[str, float]:
    """docs/inclusions.md's numbers of the shipped inclusion cases that follow from their
    inputs: Hertz contact, the largest von Mises stress (Johnson eq. 3.45 on the axis), the
    initial yield stress of the Swift law, the sphere's depth in a and its cells per radius."""
    from sacflow.config.hardening_laws import hardening_from_schema
    from sacflow.mechanics.hertz import first_yield

    case = _case("configs/inclusion-hertz.toml")
    hertz = case.hertz()
    sphere = case.body.inhomogeneity[0]
    _, _, von_mises = first_yield(case.body.nu)
    dent = _case("configs/dent-rolling-inclusion.toml")
    return {
        "inclusion_hertz_a": hertz.a, "inclusion_hertz_p0": hertz.p0,
        "inclusion_hertz_von_mises_over_p0": von_mises,
        "inclusion_hertz_von_mises": von_mises * hertz.p0,
        "inclusion_hertz_yield": float(hardening_from_schema(case.body.hardening).yield_stress(
            np.zeros(1), np.zeros(1))[0]),
        "inclusion_hertz_depth_over_a": sphere.centre[2] / hertz.a,
        "inclusion_hertz_cells_lateral": sphere.radius / case.cell_size()[0],
        "inclusion_hertz_cells_depth": sphere.radius / (case.grid.depth / case.grid.nz),
        "dent_inclusion_depth_over_a": dent.body.inhomogeneity[0].centre[2] / dent.hertz().a,
        "dent_inclusion_p0": dent.hertz().p0,
        "inclusion_alumina_ratio": sphere.E / case.body.E,
        **_campaign_depths(hertz.a),
    }


def _campaign_depths(a: float) -> dict[str, float]:
    """configs/campaign-inclusion.toml's inclusion depths over the Hertz radius."""
    depths = sorted({c.body.inhomogeneity[0].centre[2]
                     for c in _campaign_cases("configs/campaign-inclusion.toml")})
    return {f"inclusion_campaign_depth_{i}": depth / a for i, depth in enumerate(depths)}


def _run_extremes(path: Path) -> dict[str, float]:
    """Largest von Mises stress and εp, peak pressure, Krylov iterations per step of a run."""
    from sacflow.storage.run_reader import open_run

    ds = open_run(path)
    numbers = {"von_mises": float(ds["von_mises"].max()),
               "max_pressure": float(ds["max_pressure"].max())}
    if "equivalent_plastic_strain" in ds:
        numbers["eqps"] = float(ds["equivalent_plastic_strain"].max())
    if "inclusion_iterations" in ds:
        iterations = ds["inclusion_iterations"].values
        numbers["iterations_min"] = float(iterations[iterations > 0].min())
        numbers["iterations_max"] = float(iterations.max())
        numbers["iterations_total"] = float(iterations.sum())
    return numbers


def inclusion_hertz_runs(out: Path) -> dict[str, float]:
    """configs/inclusion-hertz.toml with and without its sphere (seconds each)."""
    path = "configs/inclusion-hertz.toml"
    with_sphere = _run_extremes(_run(path, out))
    without = _run_extremes(_run(path, out, ("body.inhomogeneity=[]",
                                             "name=inclusion-hertz-homogeneous")))
    return {"inclusion_hertz_von_mises_without": without["von_mises"],
            "inclusion_hertz_von_mises_with": with_sphere["von_mises"],
            "inclusion_hertz_eqps_with": with_sphere["eqps"],
            "inclusion_hertz_eqps_without": without.get("eqps", 0.0),
            "inclusion_hertz_peak_without": without["max_pressure"],
            "inclusion_hertz_peak_with": with_sphere["max_pressure"],
            "inclusion_hertz_peak_rise": with_sphere["max_pressure"] / without["max_pressure"] - 1,
            "inclusion_hertz_iterations_min": with_sphere["iterations_min"],
            "inclusion_hertz_iterations_max": with_sphere["iterations_max"]}


#: docs/inclusions.md's table: modulus ratios E*/E of Eshelby's sphere at 3 cells per radius.
ITERATION_RATIOS = (1e-3, 0.1, 0.5, 2.0, 5.0, 10.0, 100.0, 1000.0)
#: The near cavity among them, whose count depends on the FFT plans a process measures.
NEAR_CAVITY = 1e-3


def eshelby_iterations(out: Path) -> dict[str, float]:
    """Eshelby's sphere of ``tests/test_inhomogeneity_solver.py``: its cells at 2, 3 and 5 per
    radius, the GMRES iterations of its step against E*/E (3 per radius, 136 cells); the near
    cavity's with estimated FFT plans (``pipelines/eshelby_spread.py``), the same in every
    process."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_inhomogeneity_solver as eshelby

    numbers = {}
    for cells in (2, 3, 5):
        sim, states = eshelby.run(eshelby.eshelby_inputs(2.0, cells))
        numbers[f"eshelby_cells_{cells}"] = float((states[-1].volume["phase"] == 1).sum())
    for ratio in ITERATION_RATIOS:
        if ratio == NEAR_CAVITY:
            # in a fresh process with estimated FFT plans: with measured ones the near cavity's
            # count varies from process to process (docs/inclusions.md)
            count = _pipeline("eshelby_spread").counts(1, ratio, planner="estimate")[0]
        else:
            _, states = eshelby.run(eshelby.eshelby_inputs(ratio, 3))
            count = states[-1].inclusion_iterations
        numbers[f"eshelby_iterations_{ratio:g}"] = float(count)
    return numbers


def _pipeline(name: str):
    sys.path.insert(0, str(ROOT / "pipelines"))
    return __import__(name)


def _label(value: float) -> str:
    return f"{value * 1e6:.0f}"


#: docs/dent-study.md's table columns: summary variable -> key suffix.
DENT_COLUMNS = {"dang_van_max": "dv", "dang_van_ratio": "dv_ratio",
                "dang_van_max_offset": "offset", "dang_van_max_lateral": "lateral",
                "dang_van_max_depth": "depth", "pressure_peak_ratio": "p_ratio",
                "residual_stress_11_min": "s11_min", "max_plastic_strain": "eqps"}


def dent_study(out: Path) -> dict[str, float]:
    """``python pipelines/dent_study.py`` at its default size (minutes): docs/dent-study.md's
    table, smooth references and the ranges its text quotes."""
    import json

    import xarray as xr

    from sacflow.studies.dent_study import case_metrics

    folder = out / "dent-study"
    assert _pipeline("dent_study").main(["--out", str(folder), "--no-progress"]) == 0
    ds = xr.load_dataset(folder / "dent-study-summary.nc")
    numbers: dict[str, float] = {}
    for i in range(ds.sizes["case"]):
        stem = "dent_study_{}_{}_{:.0f}".format(_label(float(ds["dent_depth"][i])),
                                                _label(float(ds["dent_width"][i])),
                                                float(ds["load"][i]))
        for name, suffix in DENT_COLUMNS.items():
            numbers[f"{stem}_{suffix}"] = float(ds[name][i])
        # Symmetric about the track's centre line: the side of the maximum is round-off.
        numbers[f"{stem}_lateral"] = abs(numbers[f"{stem}_lateral"])
    manifest = json.loads((folder / "dent-study-smooth.manifest.json").read_text())
    names = {r["parameters"]["load_path.0.to"]: r["name"] for r in manifest["cases"]}
    for load in DENT_LOADS:
        name = names[load]
        smooth = case_metrics(folder / f"{name}.nc", folder / "fatigue" / f"{name}-fatigue.nc")
        a = _case("pipelines/dent-study-case.toml", (f"load_path.0.to={load}",)).hertz().a
        numbers[f"dent_study_smooth_dv_{load:.0f}"] = smooth["dang_van_max"]
        numbers[f"dent_study_smooth_depth_{load:.0f}"] = smooth["dang_van_max_depth"]
        numbers[f"dent_study_smooth_depth_over_a_{load:.0f}"] = smooth["dang_van_max_depth"] / a
    return numbers | _dent_study_ranges(ds)


def _dent_study_ranges(ds) -> dict[str, float]:
    """The extremes docs/dent-study.md's bullets quote, over the summary's cases."""
    offset, width = ds["dang_van_max_offset"].values, ds["dent_width"].values
    down = offset > 0
    grid = _case("pipelines/dent-study-case.toml").grid
    thickness = grid.depth / grid.nz  # the layers of the base case
    wide = ds["dang_van_max_depth"].values[width == max(DENT_WIDTHS)]
    seed = (ds["dent_width"] == min(DENT_WIDTHS)) & (ds["load"] == max(DENT_LOADS))
    s11 = ds["residual_stress_11_min"].values[seed.values]
    return {
        "dent_study_dv_ratio_min": float(ds["dang_van_ratio"].min()),
        "dent_study_dv_ratio_max": float(ds["dang_van_ratio"].max()),
        "dent_study_crossland_ratio_min": float(ds["crossland_ratio"].min()),
        "dent_study_crossland_ratio_max": float(ds["crossland_ratio"].max()),
        "dent_study_wide_layers_top": float(wide.min() - thickness / 2),
        "dent_study_wide_layers_bottom": float(wide.max() + thickness / 2),
        "dent_study_lateral_max": float(np.abs(ds["dang_van_max_lateral"]).max()),
        "dent_study_downstream_min": float(offset[down].min()),
        "dent_study_downstream_max": float(offset[down].max()),
        "dent_study_upstream_nearest": float(offset[~down].max()),
        "dent_study_upstream_farthest": float(offset[~down].min()),
        "dent_study_downstream_cases": float(down.sum()),
        "dent_study_p_ratio_min": float(ds["pressure_peak_ratio"].min()),
        "dent_study_p_ratio_max": float(ds["pressure_peak_ratio"].max()),
        "dent_study_s11_seed_width_first": float(s11[np.argmax(s11)]),
        "dent_study_s11_seed_width_last": float(s11[np.argmin(s11)]),
    }


#: docs/dent-study.md's vertical loading: the load put on at the dent centre in 8 increments,
#: taken off in 4, on the study's base case and grid.
VERTICAL = ('load_path=[{kind = "load", to = 1318.0, increments = 8}, '
            '{kind = "unload", to = 0.0, increments = 4}]',)


def dent_vertical(out: Path) -> dict[str, float]:
    """The seed's dent of the study (35 µm, 450 µm, 1318 N) loaded vertically, and the smooth
    surface alike: the fatigue stage's largest Dang Van index and where it lies."""
    from sacflow.compare import fatigue

    numbers = {}
    for label, surface in (("dented", "surface.dents.0.depth=35e-6"),
                           ("smooth", 'surface={kind = "smooth"}')):
        path = _run("pipelines/dent-study-case.toml", out,
                    (*VERTICAL, surface, f"name=dent-study-vertical-{label}"))
        result = fatigue(path)
        numbers[f"dent_vertical_{label}_dv"] = float(result["dang_van_max"])
        numbers[f"dent_vertical_{label}_depth"] = float(result["dang_van_max_depth"])
        numbers[f"dent_vertical_{label}_radius"] = float(np.hypot(
            float(result["dang_van_max_x1"]), float(result["dang_van_max_x2"])))
    numbers["dent_vertical_ratio"] = (numbers["dent_vertical_dented_dv"]
                                      / numbers["dent_vertical_smooth_dv"])
    return numbers


def inclusion_campaign(out: Path) -> dict[str, float]:
    """``python pipelines/inclusion_campaign.py`` (15 runs and their fatigue stage, a minute or
    two): docs/inclusions.md's Dang Van indices against depth and modulus ratio."""
    import csv

    folder = out / "inclusion"
    assert _pipeline("inclusion_campaign").main(["--out", str(folder), "--no-progress"]) == 0
    with open(folder / "campaign-inclusion-summary.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    line: dict[str, dict[str, dict[str, float]]] = {}
    for row in rows:
        ratio = {"0.5": "soft", "1": "homogeneous"}.get(f"{float(row['modulus_ratio']):.2g}",
                                                         "alumina")
        line.setdefault(ratio, {})[f"{float(row['depth_over_a']):.2f}"] = {
            k: float(v) for k, v in row.items() if k != "case"}
    hom = [line["homogeneous"][d]["dang_van_max"] for d in sorted(line["homogeneous"])]
    lift = {d: line["alumina"][d]["dang_van_max"] / line["homogeneous"][d]["dang_van_max"] - 1
            for d in line["alumina"]}
    numbers = {"inclusion_campaign_homogeneous_min": min(hom),
               "inclusion_campaign_homogeneous_max": max(hom),
               "inclusion_campaign_homogeneous_depth": line["homogeneous"]["0.48"][
                   "dang_van_max_depth_over_a"],
               "inclusion_campaign_lift_min": min(lift.values()),
               "inclusion_campaign_lift_max": max(lift.values()),
               "inclusion_campaign_lift_argmax": float(max(lift, key=lift.__getitem__)),
               "inclusion_campaign_alumina_eqps_min": min(
                   r["max_plastic_strain"] for r in line["alumina"].values()),
               "inclusion_campaign_alumina_eqps_max": max(
                   r["max_plastic_strain"] for r in line["alumina"].values())}
    for ratio in ("alumina", "soft"):
        for depth, row in line[ratio].items():
            numbers[f"inclusion_campaign_{ratio}_{depth}"] = row["dang_van_max"]
    return numbers


#: docs/inclusions.md's region around the sphere of dent-rolling-inclusion: x1 and depth [m].
SPHERE_REGION = ((100e-6, 210e-6), (150e-6, 330e-6))


def dent_rolling_inclusion(out: Path) -> dict[str, float]:
    """configs/dent-rolling-inclusion.toml with and without its sphere (minutes each): the
    dent's plastic strain and peak pressure, the plastic strain around the sphere, GMRES."""
    from sacflow.storage.run_reader import open_run

    path = "configs/dent-rolling-inclusion.toml"
    runs = {"with": open_run(_run(path, out)),
            "without": open_run(_run(path, out, ("body.inhomogeneity=[]",
                                                 "name=dent-rolling-inclusion-homogeneous")))}
    numbers: dict[str, float] = {}
    for label, ds in runs.items():
        eqps = ds["equivalent_plastic_strain"].isel(step=-1)
        (x1_low, x1_high), (z_low, z_high) = SPHERE_REGION
        near = eqps.sel(x1=slice(x1_low, x1_high), x3=slice(z_low, z_high))
        numbers[f"dent_inclusion_eqps_max_{label}"] = float(eqps.max())
        numbers[f"dent_inclusion_peak_{label}"] = float(ds["max_pressure"].max())
        numbers[f"dent_inclusion_sphere_eqps_{label}"] = float(near.max())
    numbers["dent_inclusion_unchanged"] = max(
        abs(numbers[f"dent_inclusion_{k}_with"] / numbers[f"dent_inclusion_{k}_without"] - 1)
        for k in ("eqps_max", "peak"))
    numbers["dent_inclusion_sphere_ratio"] = (numbers["dent_inclusion_sphere_eqps_with"]
                                              / numbers["dent_inclusion_sphere_eqps_without"])
    numbers["dent_inclusion_iterations"] = float(runs["with"]["inclusion_iterations"].sum())
    numbers["dent_inclusion_steps"] = float(runs["with"].sizes["step"])
    return numbers


def inclusion_benchmark(out: Path) -> dict[str, float]:
    """``benchmarks/inclusion.py 64``'s results other than its times: one mild-hardening load
    step at 64 × 64 × 32 with and without its alumina sphere (each step run three times)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import inclusion as benchmark

    without, with_sphere = benchmark.one_step(64, False), benchmark.one_step(64, True)
    return {
        "inclusion_benchmark_cells": float(with_sphere["inhomogeneity"].split(", ")[1].split()[0]),
        "inclusion_benchmark_applications_with": float(
            with_sphere["residual_stress_applications"]),
        "inclusion_benchmark_applications_without": float(
            without["residual_stress_applications"]),
        "inclusion_benchmark_gmres": float(with_sphere["inclusion_iterations"]),
        "inclusion_benchmark_pressure_rise": (with_sphere["max_pressure_pa"]
                                              / without["max_pressure_pa"] - 1.0),
        "inclusion_benchmark_eqps_without": without["max_equivalent_plastic_strain"],
        "inclusion_benchmark_eqps_with": with_sphere["max_equivalent_plastic_strain"],
    }


def dent_grid_change(out: Path) -> dict[str, float]:
    """docs/dent-study.md: the fatigue stage's largest Dang Van index of configs/dent-rolling.toml
    (the study's seed dent at 2.5 GPa) at 32 × 32 × 12 and 40 × 40 × 14 cells, the runs of
    ``record_doc_numbers.dent_fatigue`` (same names: reused from ``out``). The whole body's
    maximum: that case's track is too short for a middle (``dang_van_track_max`` is NaN)."""
    from sacflow.compare import fatigue

    numbers = {}
    for n, nz in ((32, 12), (40, 14)):
        path = _run("configs/dent-rolling.toml", out, (
            f"grid.nx={n}", f"grid.ny={n}", f"grid.nz={nz}", "output.volume_every=1",
            f"name=dent-rolling-{n}"))
        result = fatigue(path)
        numbers[f"dent_grid_max_{n}"] = float(result["dang_van_max"])
        numbers[f"dent_grid_max_x1_{n}"] = float(result["dang_van_max_x1"])
    numbers["dent_grid_change"] = abs(numbers["dent_grid_max_40"] / numbers["dent_grid_max_32"]
                                      - 1.0)
    return numbers


#: The groups of this module: name -> (speed, function of the output folder).
GROUPS = {
    "readme_cases": ("fast", readme_cases),
    "hertz_check_grids": ("fast", hertz_check_grids),
    "dent_study_setup": ("fast", dent_study_setup),
    "inclusion_setup": ("fast", inclusion_setup),
    "inclusion_hertz_runs": ("slow", inclusion_hertz_runs),
    "eshelby_iterations": ("slow", eshelby_iterations),
    "dent_study": ("slow", dent_study),
    "dent_vertical": ("fast", dent_vertical),
    "inclusion_campaign": ("slow", inclusion_campaign),
    "dent_rolling_inclusion": ("slow", dent_rolling_inclusion),
    "inclusion_benchmark": ("slow", inclusion_benchmark),
    "dent_grid_change": ("slow", dent_grid_change),
}
