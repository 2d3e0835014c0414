"""Groups of ``pipelines/record_doc_numbers.py`` for docs/initial-states.md, docs/friction.md,
docs/repeated-rolling.md, docs/convergence.md, docs/fatigue.md and docs/case-format.md (issue
#30): the fast ones.

Each group is a function of the output folder returning ``{key: value in SI units}``; the rows
of ``data/doc_numbers.csv`` name the group. Fast groups read the shipped tables under ``data/``
back or compute closed forms and runs of seconds; the slow groups, which run shipped cases at
their shipped grids, are in ``doc_number_groups_b_runs.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def import_script(folder: str, name: str):
    """A script of ``pipelines/`` or ``tests/`` as a module (they are not a package)."""
    path = str(ROOT / folder)
    if path not in sys.path:
        sys.path.insert(0, path)
    return __import__(name)


def shipped_case(path: str, overrides: tuple[str, ...] = (), check: bool = True):
    """A shipped case file (path relative to the repository), with overrides."""
    from sacflow.storage.case_file import load_case

    return load_case(ROOT / path, list(overrides), check_files=check)


#: σR / p0 of docs/initial-states.md's table (the cases of ``tests/test_initial_state.py``: a
#: rigid sphere R = 10 mm on an elastic steel body at p0 = 2 GPa, 32 × 32 × 16 cells over ±1.5 a,
#: 1.2 a deep), and the scan (steps of 0.01) that finds where the largest von Mises stress
#: leaves the axis.
INITIAL_STRESS_RATIOS = (0.1, 0.0, -0.1, -0.2, -0.3)
AXIS_SCAN = tuple(round(-0.20 - 0.01 * i, 2) for i in range(11))


def hertz_with_initial_stress(ratio: float) -> tuple[float, float, float]:
    """Largest von Mises / p0 of Huber's Hertz field plus σ11 = σ22 = ratio p0, searched over
    x = 0–2 a (401 points) and z = 0.001–1.5 a (300 points); and where (x/a, z/a)."""
    from sacflow.mechanics.hertz import hertz_subsurface_stress
    from sacflow.mechanics.stress_measures import von_mises

    x, z = np.linspace(0.0, 2.0, 401), np.linspace(1e-3, 1.5, 300)
    stress = hertz_subsurface_stress(x[:, None], 0.0, z[None, :], 1.0, 1.0, 0.3)
    stress[..., :2] += ratio
    q = von_mises(stress)
    i, j = np.unravel_index(int(np.argmax(q)), q.shape)
    return float(q[i, j]), float(x[i]), float(z[j])


def _initial_stress_run(ratio: float, p0: float) -> float:
    import math

    from sacflow.config.solver_inputs import simulation_for
    from sacflow.mechanics.hertz import composite_modulus
    from sacflow.mechanics.stress_measures import von_mises
    from sacflow.storage.case_file import case_from_dict

    e, nu, radius = 210e9, 0.3, 10e-3
    a = math.pi * p0 * radius / (2.0 * composite_modulus(e, nu))
    case = {"name": "initial-stress",
            "body": {"E": e, "nu": nu, "hardening": {"law": "elastic"},
                     "initial_residual_stress": {"depth": [0.0], "s11": [ratio * p0],
                                                 "s22": [ratio * p0]}},
            "counterbody": {"kind": "rigid", "radius": radius},
            "grid": {"nx": 32, "ny": 32, "nz": 16, "half_width": 1.5, "depth": 1.2 * a},
            "load_path": [{"kind": "load", "to": 2.0 * math.pi * a * a * p0 / 3.0,
                           "increments": 1}],
            "output": {"fields": ["load", "pressure", "stress", "residual_stress"]}}
    state = list(simulation_for(case_from_dict(case)).run())[-1]
    return float(von_mises(state.volume["stress"]).max() / p0)


def initial_stress_von_mises(out: Path) -> dict[str, float]:
    """docs/initial-states.md: largest von Mises / p0 of Hertz + σR, closed form and run."""
    numbers: dict[str, float] = {}
    for ratio in INITIAL_STRESS_RATIOS:
        key = f"initial_stress_{ratio:+.1f}"
        numbers[f"{key}_closed"], numbers[f"{key}_x"], numbers[f"{key}_z"] = (
            hertz_with_initial_stress(ratio))
        numbers[f"{key}_sacflow"] = _initial_stress_run(ratio, 2.0e9)
    on_axis = [r for r in AXIS_SCAN if hertz_with_initial_stress(r)[1] == 0.0]
    numbers["initial_stress_axis_last"] = min(on_axis)
    numbers["initial_stress_axis_first_off"] = max(r for r in AXIS_SCAN if r < min(on_axis))
    numbers["initial_stress_axis_leaves"] = (numbers["initial_stress_axis_last"]
                                             + numbers["initial_stress_axis_first_off"]) / 2.0
    return numbers



def _hydrostatic_rows(quantity: str) -> list[dict[str, str]]:
    import csv

    with open(ROOT / "data" / "dent-hydrostatic.csv", newline="", encoding="utf-8") as f:
        return [r for r in csv.DictReader(f) if r["quantity"] == quantity]


def _on_axis(rows: list[dict[str, str]], grid: str, where: str) -> float:
    """The value in the cell column nearest the axis on x1 > 0 (x2 = 0 row of the table)."""
    line = [r for r in rows if r["grid"] == grid and r["where"] == where and float(r["x1_m"]) > 0]
    return float(min(line, key=lambda r: float(r["x1_m"]))["value_Pa"])


def dent_hydrostatic_prose(out: Path) -> dict[str, float]:
    """What docs/initial-states.md and docs/convergence.md say of ``data/dent-hydrostatic.csv``
    (regenerated by ``python pipelines/dent_hydrostatic.py``): ranges and ratios of the table's
    cells, the grids' cell centres and layers, the residual σ33 on the axis."""
    record = import_script("pipelines", "record_doc_numbers")
    cells = record.dent_hydrostatic(out)
    numbers: dict[str, float] = {}
    for where in ("16_um", "8_um", "first_layer"):
        rim = [v for k, v in cells.items() if k.endswith(where) and "_148_" not in k]
        numbers[f"rim_hydrostatic_{where}_min"], numbers[f"rim_hydrostatic_{where}_max"] = (
            min(rim), max(rim))
    fine = [(k, k.replace("48x64", "72x64")) for k in cells if k.startswith("hydrostatic_48x64")
            and "_148_" not in k]
    numbers["rim_48_vs_72_near_surface"] = max(abs(cells[a] - cells[b]) for a, b in fine
                                               if not a.endswith("16_um"))
    numbers["rim_48_vs_72"] = max(abs(cells[a] - cells[b]) for a, b in fine)
    edge_coarse, edge_fine = cells["hydrostatic_48x16_148_16_um"], cells[
        "hydrostatic_48x64_148_16_um"]
    numbers |= {"edge_hydrostatic_shipped": edge_coarse, "edge_hydrostatic_fine": edge_fine,
                "edge_hydrostatic_ratio": edge_coarse / edge_fine}
    rows = _hydrostatic_rows("hydrostatic")
    for grid in ("48x64", "72x64"):
        x1 = sorted({float(r["x1_m"]) for r in rows if r["grid"] == grid and float(r["x1_m"]) > 0})
        for radius in (148, 177, 205):
            numbers[f"cell_x1_{grid}_{radius}"] = min(x1, key=lambda x: abs(x - radius * 1e-6))
        numbers[f"cell_size_{grid}"] = x1[1] - x1[0]
        numbers[f"first_layer_{grid}"] = float(next(
            r["depth_m"] for r in rows if r["grid"] == grid and r["where"] == "first layer"))
    s33 = _hydrostatic_rows("s33")
    numbers["s33_axis_shipped_first_layer"] = _on_axis(s33, "48x16", "first layer")
    numbers["s33_axis_48x16_first_layer_depth"] = float(next(
        r["depth_m"] for r in s33 if r["grid"] == "48x16" and r["where"] == "first layer"))
    numbers["s33_axis_48x64_first_layer"] = _on_axis(s33, "48x64", "first layer")
    numbers["s33_axis_48x64_16_um"] = _on_axis(s33, "48x64", "16 um")
    return numbers


# --------------------------------------------------------------------------- docs/friction.md
#: Friction coefficients of docs/friction.md's sliding table; 0.32 for the crossing it names.
SLIDING_MU = (0.0, 0.25, 0.3, 0.35, 0.5)
#: Cells across the contact diameter of the trailing-edge convergence table.
EDGE_CELLS = (64, 128, 256, 512, 1024)
#: The rate the traction's square-root edge predicts for piecewise-constant cells (h^½).
EDGE_RATE = 0.5


def _von_mises_row(stress: np.ndarray) -> float:
    from sacflow.mechanics.stress_measures import von_mises

    return float(von_mises(np.asarray(stress)[None, :])[0])


def _edge_limit(values: list[float]) -> float:
    """Extrapolate the last two of a sequence of cell-halving levels at the rate ½."""
    return values[-1] + (values[-1] - values[-2]) / (2.0**EDGE_RATE - 1.0)


def _trailing_edge(test, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Surface stress / p0 at (−a, 0) on n cells of the Hertz pressure and of its traction per
    unit μ (the stress is linear in μ: σ(μ) = σ_p + μ σ_q)."""
    pressure = np.asarray(test.surface_stress(-1.0, 0.0, n, 0.0))
    return pressure, np.asarray(test.surface_stress(-1.0, 0.0, n, 1.0)) - pressure


def sliding_hertz(out: Path) -> dict[str, float]:
    """docs/friction.md's checks of configs/sliding-hertz.toml (seconds).

    The trailing edge: σ11 and σvM of the Hertz pressure and traction summed with the
    closed-form rectangle kernels (``tests/test_friction.py``'s ``surface_stress``), the
    convergence table at μ = 0.25 and the surface column per μ (extrapolated at the rate ½ from
    512 and 1024 cells). Below the surface: ``pipelines/friction_report.py`` per μ (128 × 128
    cells over ±1.25 a, 64 layers down to a). The first-yield load is the lower of the two.
    """
    test = import_script("tests", "test_friction")
    report = import_script("pipelines", "friction_report")
    levels = {n: _trailing_edge(test, n) for n in EDGE_CELLS}
    exact = float(test.trailing_edge_closed_form(0.25))
    s11 = [float(p[0] + 0.25 * q[0]) for p, q in levels.values()]
    numbers = {"edge_closed_form": exact}
    for n, value in zip(EDGE_CELLS, s11, strict=True):
        numbers[f"edge_s11_{n}"] = value
        numbers[f"edge_error_{n}"] = value / exact - 1.0
    numbers["edge_fitted_rate"] = float(
        -np.polyfit(np.log(EDGE_CELLS), np.log(exact - np.asarray(s11)), 1)[0])
    numbers["edge_extrapolated"] = _edge_limit(s11)
    numbers["edge_extrapolated_error"] = numbers["edge_extrapolated"] / exact - 1.0
    numbers["edge_normal_error_256"] = (
        float(levels[256][0][0]) / float(test.trailing_edge_closed_form(0.0)) - 1.0)
    for mu in (*SLIDING_MU, 0.32):
        edge = _edge_limit([_von_mises_row(p + mu * q) for p, q in list(levels.values())[2:]])
        numbers[f"edge_von_mises_{mu:g}"] = edge
        if mu not in SLIDING_MU:
            continue
        row = report.report(mu, 128, 64)
        for key in ("von_mises_max_over_p0", "x1_over_a", "depth_over_a"):
            numbers[f"sliding_{key}_{mu:g}"] = float(row[key])
        below = float(row["von_mises_max_over_p0"])
        numbers[f"sliding_first_yield_{mu:g}"] = float(np.sqrt(3.0)) / max(below, edge)
        numbers[f"sliding_edge_below_subsurface_{mu:g}"] = 1.0 - edge / below
    return numbers



def traction_kernels(out: Path) -> dict[str, float]:
    """docs/friction.md's kernel checks, as ``tests/test_traction_kernels.py`` makes them
    (seconds): Cerruti's point force against Johnson's form at its 500 random points (ν = 0,
    0.3, 0.45, 0.5), the rectangle against quadrature of the point force at its field points
    (four rectangles, ν = 0, 0.3, 0.45): largest error over the largest component."""
    from sacflow.kernels.shear import cerruti_stress, rectangle_shear_stress

    test = import_script("tests", "test_traction_kernels")
    points = test.random_points(500, 1)
    point_errors = []
    for nu in (0.0, 0.3, 0.45, 0.5):
        ref = test.johnson_cerruti(*points.T, nu)
        point_errors.append(float((np.abs(cerruti_stress(*points.T, nu) - ref).max(-1)
                                   / np.abs(ref).max(-1)).max()))
    worst, component = 0.0, -1
    for h1, h2 in test.RECTANGLES:
        for nu in (0.0, 0.3, 0.45):
            pts = np.array(test.field_points(h1, h2))
            got = rectangle_shear_stress(pts[:, 0], pts[:, 1], pts[:, 2], h1, h2, nu)
            ref = np.array([test.quadrature(*q, h1, h2, nu) for q in pts])
            err = np.abs(got - ref) / np.abs(ref).max(-1)[:, None]
            if err.max() > worst:
                worst, component = float(err.max()), int(np.argmax(err.max(axis=0)))
    return {"cerruti_point_error": max(point_errors), "rectangle_error": worst,
            "rectangle_error_component": float(component)}



# ------------------------------------------------------------------------ docs/convergence.md
def _summary(name: str, sequence: str | None = None) -> dict[tuple[str, str, str], dict[str, str]]:
    import csv

    with open(ROOT / "data" / name, newline="", encoding="utf-8") as f:
        return {(r["case"], r["sequence"], r["quantity"]): r for r in csv.DictReader(f)
                if sequence in (None, r["sequence"])}


#: The rows of convergence.md's grid table, by the label its table uses.
GRID_ROWS = {
    "650 mN, print depth": ("nanoindentation-650mN", "print_depth"),
    "650 mN, max εp (cell)": ("nanoindentation-650mN", "max_plastic_strain"),
    "650 mN, peak pressure": ("nanoindentation-650mN", "peak_pressure"),
    "650 mN, approach": ("nanoindentation-650mN", "approach_at_peak_load"),
    "190 mN, print depth": ("nanoindentation-190mN", "print_depth"),
    "190 mN, max εp (refined)": ("nanoindentation-190mN", "max_plastic_strain_refined"),
    "linear 650 mN, print depth": ("nanoindentation-linear-650mN", "print_depth"),
}
PRESS = "dent-from-indentation-press"


def convergence_grid(out: Path) -> dict[str, float]:
    """docs/convergence.md's spatial results, read back from ``data/convergence.csv`` and
    ``data/convergence-summary.csv`` (regenerated by ``python pipelines/convergence.py``, the
    command of data/README.md), and the increment orders' ranges over its first table."""
    import csv

    record = import_script("pipelines", "record_doc_numbers")
    after, before = _summary("convergence-summary.csv"), _summary(
        "convergence-backward-euler-summary.csv")
    numbers: dict[str, float] = {}
    for index, (case, quantity) in enumerate(GRID_ROWS.values()):
        for sequence in ("lateral", "layers"):
            row = after[(case, sequence, quantity)]
            numbers[f"grid_{index}_{sequence}_order"] = float(row["order"])
            numbers[f"grid_{index}_{sequence}_error"] = float(row["shipped_error"])
    first = list(record.CONVERGENCE_ROWS.values())
    orders = [float(before[(c, "increments", q)]["order"]) for c, q in first]
    numbers["increments_be_order_min"] = min(orders)
    numbers["increments_be_order_max"] = max(orders)
    second = [float(after[(c, "increments", q)]["order"]) for c, q in first
              if c != "nanoindentation-linear-650mN"]
    numbers["increments_order_min"], numbers["increments_order_max"] = min(second), max(second)
    for name, table in (("be", before), ("after", after)):
        for case in ("nanoindentation-650mN", PRESS):
            row = table[(case, "increments", "print_depth")]
            numbers[f"increments_{name}_{case}_print_depth_limit"] = float(row["limit"])
            numbers[f"increments_{name}_{case}_print_depth_uncertainty"] = float(
                row["relative_uncertainty"])
    for quantity in ("print_depth", "peak_pressure"):  # the three errors, if they add
        numbers[f"summed_error_650mN_{quantity}"] = sum(float(after[(
            "nanoindentation-650mN", sequence, quantity)]["shipped_error"])
            for sequence in ("lateral", "layers", "increments"))
        row = after[(PRESS, "lateral", quantity)]
        numbers[f"press_lateral_{quantity}_order"] = float(row["order"])
        numbers[f"press_lateral_{quantity}_error"] = float(row["shipped_error"])
    with open(ROOT / "data" / "convergence.csv", newline="", encoding="utf-8") as f:
        levels = [r for r in csv.DictReader(f) if r["sequence"] in ("layers", "depth")]
    for r in levels:
        if r["sequence"] == "layers" and (r["case"], r["quantity"]) in (
                (PRESS, "print_depth"), (PRESS, "max_plastic_strain"),
                (PRESS, "residual_s33_layer1_axis"),
                ("nanoindentation-650mN", "max_plastic_strain_depth")):
            numbers[f"layers_{r['case']}_{r['quantity']}_{r['nz']}"] = float(r["value"])
    spread: dict[tuple[str, str], list[float]] = {}
    for r in levels:
        if r["sequence"] == "depth" and r["value"]:
            spread.setdefault((r["case"], r["quantity"]), []).append(float(r["value"]))
    numbers["depth_sequence_largest_change"] = max(
        (max(v) - min(v)) / max(abs(x) for x in v) for v in spread.values() if any(v))
    return numbers



# ------------------------------------------------------------ case numbers (sacflow validate)
#: The shear yield stress k of the rolling-cycles cases: σY / √3 with σY = 1000 MPa [Pa].
K_CYCLES = 1000e6 / np.sqrt(3.0)


def campaign_cases(path: str) -> list[tuple[float, float]]:
    """(load, roll distance) of each case of a zipped campaign sweep."""
    import tomllib

    sweep = tomllib.loads((ROOT / path).read_text(encoding="utf-8"))["sweep"][0]["parameters"]
    return list(zip(sweep["load_path.0.to"], sweep["load_path.1.distance"], strict=True))


def case_numbers(out: Path) -> dict[str, float]:
    """Numbers the docs derive from shipped case files: Hertz a and p0 (``sacflow validate``),
    layer thicknesses and first layer centres, yield stresses of their hardening laws, the
    Dundurs constant of a rigid counter-body, the initial residual stress at a depth."""
    from sacflow.config.hardening_laws import hardening_from_schema, kinematic_from_schema
    from sacflow.config.solver_inputs import solver_inputs
    from sacflow.mechanics.hertz import first_yield

    numbers: dict[str, float] = {}
    for name in ("sliding-hertz", "rolling-smooth", "dent-rolling", "rolling-cycles-shakedown",
                 "rolling-cycles-ratcheting", "dent-rolling-cycles"):
        hertz = shipped_case(f"configs/{name}.toml").hertz()
        numbers[f"{name}_a"], numbers[f"{name}_p0"] = hertz.a, hertz.p0
        numbers[f"{name}_p0_over_k"] = hertz.p0 / K_CYCLES
    smooth = shipped_case("configs/rolling-smooth.toml")
    grid = solver_inputs(smooth).grid
    numbers["rolling-smooth_layer_over_a"] = grid.depth / grid.nz / smooth.hertz().a
    numbers["rolling-smooth_yield"] = float(hardening_from_schema(
        smooth.body.hardening).yield_stress(0.0))
    numbers["rolling-smooth_first_yield_depth"] = first_yield(0.3)[1] * smooth.hertz().a
    hardened = shipped_case("configs/case-hardened-rolling.toml").body.initial_residual_stress
    numbers["case_hardened_stress_at_peak_depth"] = float(np.interp(
        numbers["rolling-smooth_first_yield_depth"], hardened.depth, hardened.s11))
    rolling = shipped_case("pipelines/dent-from-indentation-geometric.toml", (), check=False)
    numbers["dent_indentation_rolling_first_layer"] = rolling.grid.depth / rolling.grid.nz / 2.0
    numbers["dent_indentation_rolling_p0"] = rolling.hertz().p0
    dent = shipped_case("configs/dent-rolling.toml").body.hardening
    numbers["dent_swift_at_7_percent"] = float(hardening_from_schema(dent).yield_stress(0.07))
    cycles = shipped_case("configs/dent-rolling-cycles.toml")
    kinematic = kinematic_from_schema(cycles.body.hardening)
    numbers["dent_cycles_backstress_saturation"] = kinematic.modulus / kinematic.recall
    numbers["rigid_dundurs_beta"] = (1.0 - 2.0 * 0.3) / (2.0 * (1.0 - 0.3))
    for load, distance in campaign_cases("configs/campaign-rolling-cycles.toml"):
        case = shipped_case("configs/rolling-cycles-shakedown.toml", (f"load_path.0.to={load}",))
        label = f"{case.hertz().p0 / K_CYCLES:.2f}"
        numbers[f"cycles_campaign_p0_over_k_{label}"] = case.hertz().p0 / K_CYCLES
        numbers[f"cycles_campaign_track_over_a_{label}"] = distance / case.hertz().a
    return numbers



# ---------------------------------------------------------------------------- docs/fatigue.md
def _rolled_elastic(out: Path) -> Path:
    """tests/test_fatigue_stage.py's run: an elastic sphere (R = 20 mm, 4200 N) rolled 4.6 mm
    over an elastic flat, 24 × 24 cells over ±1.5 a, 16 layers over 1 mm, 90 roll steps."""
    from sacflow.runner import run_case
    from sacflow.storage.case_file import case_from_dict

    steel = {"E": 210e9, "nu": 0.3}
    case = {"name": "fatigue-stage-check",
            "body": {**steel, "hardening": {"law": "elastic"}},
            "counterbody": {"kind": "elastic", **steel, "radius": 20e-3},
            "grid": {"nx": 24, "ny": 24, "nz": 16, "half_width": 1.5, "depth": 1.0e-3},
            "load_path": [{"kind": "load", "to": 4200.0, "increments": 2},
                          {"kind": "roll", "distance": 4.6e-3, "steps": 90},
                          {"kind": "unload", "to": 0.0, "increments": 1}]}
    return run_case(case_from_dict(case), out, progress=False).path


def fatigue_stage_check(out: Path) -> dict[str, float]:
    """docs/fatigue.md's check of the stage on an elastic rolling run against Huber's Hertz
    field at the run's load positions (seconds): spread along the track, agreement below
    0.3 a, in the first layer and at the maximum, and the finely sampled depths of the maxima."""
    import xarray as xr

    from sacflow.compare.fatigue_index import DEFAULT_LIMITS, fatigue
    from sacflow.mechanics.fatigue_criteria import fatigue_indices
    from sacflow.mechanics.hertz import composite_modulus, hertz_contact, hertz_subsurface_stress

    path = _rolled_elastic(out)
    result = fatigue(path)
    e_star = composite_modulus(210e9, 0.3, 210e9, 0.3)
    a = hertz_contact(4200.0, 20e-3, e_star).a
    with xr.open_dataset(path) as ds:
        x1, x3 = ds["x1"].values, ds["x3"].values
        start, end = ds["load_x1"].values.min(), ds["load_x1"].values.max()
        middle = (x1 > start + 2.0 * a) & (x1 < end - 2.0 * a)
        history = np.zeros((ds.sizes["step"], int(middle.sum()), x3.size, 6))
        for t, (w, l1, l2) in enumerate(zip(ds["load"].values, ds["load_x1"].values,
                                            ds["load_x2"].values, strict=True)):
            if w > 0.0:
                h = hertz_contact(float(w), 20e-3, e_star)
                history[t] = hertz_subsurface_stress((x1[middle] - l1)[:, None], -l2,
                                                     x3[None, :], h.a, h.p0, 0.3)
    dang_van, crossland = fatigue_indices(history, DEFAULT_LIMITS, time_axis=0)
    centre = {name: result[name].sel(x2=0.0, method="nearest").values[middle]
              for name in ("dang_van", "sqrt_j2_amplitude")}
    index = centre["dang_van"]
    spread = (index.max(axis=0) - index.min(axis=0)) / index.mean(axis=0)
    numbers = {"fatigue_check_rolled_over_a": (end - start) / a,
               "fatigue_check_layer_over_a": x3[1] - x3[0],
               "fatigue_check_spread": float(spread.max()),
               "fatigue_check_spread_at_max": float(spread[int(np.argmax(index.mean(axis=0)))])}
    numbers["fatigue_check_layer_over_a"] /= a
    deep = x3 >= 0.3 * a
    for name, hertz in (("dang_van", dang_van.index), ("sqrt_j2_amplitude", crossland.sqrt_j2a)):
        run, closed = centre[name].mean(axis=0), hertz.mean(axis=0)
        numbers[f"fatigue_check_{name}_deep"] = float(np.max(np.abs(run[deep] / closed[deep] - 1)))
        numbers[f"fatigue_check_{name}_first_layer"] = float(abs(run[0] / closed[0] - 1.0))
        numbers[f"fatigue_check_{name}_at_max"] = float(abs(run.max() / closed.max() - 1.0))
    h = hertz_contact(4200.0, 20e-3, e_star)
    fine = hertz_subsurface_stress((np.linspace(-6.0, 6.0, 961) * a)[:, None], 0.0,
                                   (np.linspace(0.05, 1.2, 231) * a)[None, :], h.a, h.p0, 0.3)
    fine_dv, fine_cr = fatigue_indices(fine, DEFAULT_LIMITS, time_axis=0)
    depths = np.linspace(0.05, 1.2, 231)
    numbers["fatigue_check_dang_van_depth"] = float(depths[np.argmax(fine_dv.index)])
    numbers["fatigue_check_sqrt_j2a_depth"] = float(depths[np.argmax(fine_cr.sqrt_j2a)])
    return numbers



def iso_fatigue_finer(out: Path) -> dict[str, float]:
    """docs/fatigue.md's indices at ISO's limit (p0 = 1.5 GPa, default limits) sampled as the
    doc says (961 positions over ±6 a, depths every 0.005 a) and twice as finely in both, over
    0.30–0.50 a where both maxima lie: the largest change of either index (seconds)."""
    from sacflow.compare.fatigue_index import DEFAULT_LIMITS
    from sacflow.mechanics.fatigue_criteria import fatigue_indices
    from sacflow.mechanics.hertz import hertz_subsurface_stress

    maxima = []
    for positions, step in ((961, 0.005), (1921, 0.0025)):
        x1 = np.linspace(-6.0, 6.0, positions)
        x3 = np.arange(round(0.30 / step), round(0.50 / step) + 1) * step
        stress = hertz_subsurface_stress(x1[:, None], 0.0, x3[None, :], 1.0, 1.5e9, 0.3)
        dang_van, crossland = fatigue_indices(stress, DEFAULT_LIMITS, time_axis=0)
        maxima.append(np.array([dang_van.index.max(), crossland.index.max()]))
    return {"iso_finer_sampling_change": float(np.abs(maxima[1] - maxima[0]).max())}


#: Numbers the docs derive from other rows' recorded values (the rows' own groups recompute
#: those): key -> (function of the recorded values by key, the keys it reads).
DERIVED = {
    "dent_fatigue_spread": (lambda v: abs(v[0] - v[1]) / v[1],
                            ("dent_fatigue_dang_van_32", "dent_fatigue_dang_van_40")),
    "shakedown_ceiling_under_literature": (lambda v: PONTER_LIMIT / v[0] - 1.0,
                                           ("shakedown_point_ceiling",)),
    "melan_crossing": (lambda v: 5.0 + 0.5 * (v[0] - 1.0) / (v[0] - v[1]),
                       ("melan_5.0k_load_factor", "melan_5.5k_load_factor")),
    "cycles_3.5_decay_factor": (lambda v: 1.0 / v[0], ("cycles_3.5_ratio_6",)),
}
#: The free-rolling shakedown limit of a sphere under the Hertz pressure, in k (Ponter, Hearle
#: & Johnson, J. Mech. Phys. Solids 33 (1985) 339).
PONTER_LIMIT = 4.7


def recorded_arithmetic(out: Path) -> dict[str, float]:
    """Ratios and differences the docs state of numbers recorded in data/doc_numbers.csv."""
    import csv

    with open(ROOT / "data" / "doc_numbers.csv", newline="", encoding="utf-8") as f:
        recorded = {r["key"]: float(r["value"]) for r in csv.DictReader(
            line for line in f if not line.startswith("#"))}
    return {key: float(rule([recorded[k] for k in keys]))
            for key, (rule, keys) in DERIVED.items()}


GROUPS = {
    "traction_kernels": ("fast", traction_kernels),
    "iso_fatigue_finer": ("fast", iso_fatigue_finer),
    "recorded_arithmetic": ("fast", recorded_arithmetic),
    "fatigue_stage_check": ("slow", fatigue_stage_check),
    "case_numbers": ("fast", case_numbers),
    "dent_hydrostatic_prose": ("fast", dent_hydrostatic_prose),
    "convergence_grid": ("fast", convergence_grid),
    "sliding_hertz": ("slow", sliding_hertz),
    "initial_stress_von_mises": ("fast", initial_stress_von_mises),
}
