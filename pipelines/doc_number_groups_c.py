"""Groups of ``pipelines/record_doc_numbers.py`` for docs/inclusions.md's section on an
inhomogeneity's own hardening (#30, #33) and docs/convergence.md's tables read from
``data/convergence*.csv`` (#32).

Each group is a function of the output folder (unused here: the runs are in memory) returning
``{key: value in SI units}``; ``record_doc_numbers.GROUPS`` registers it as fast (runs of
seconds: recomputed in the default suite) or slow (``pytest -m slow``). The checks reuse the
helpers of ``tests/test_inhomogeneity_hardening.py``; the cost table runs the one-step case and
sphere of ``benchmarks/inclusion.py`` with the sphere elastic or with a law of its own.

    python pipelines/doc_number_groups_c.py [n]

prints the cost table's configurations (default n = 32) as JSON, with their step times (the
times docs/inclusions.md quotes are such measurements, on a shared machine).
"""

from __future__ import annotations

import csv
import json
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: The cost table's sphere: elastic, or with the matrix's law, or with half its yield stress.
COST_CONFIGURATIONS = ("none", "elastic", "matrix_law", "half_yield")
#: Cells per radius of the staircase spheres whose constraint docs/inclusions.md quotes.
CONSTRAINT_CELLS = (5, 7)
#: The uniform deviatoric eigenstrain put in the staircase sphere (11, 22, 33, 12, 13, 23),
#: the direction of the deep sphere's plastic strain under σ11 = σ22 [1].
DEVIATORIC_EIGENSTRAIN = 1e-3 * np.array([1.0, 1.0, -2.0, 0.0, 0.0, 0.0])


def _tests():
    """The test module of the own-hardening checks (and, through it, its sibling helpers)."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_inhomogeneity_hardening

    return test_inhomogeneity_hardening


def own_hardening_checks(out: Path) -> dict[str, float]:
    """The 0.3 N checks of ``tests/test_inhomogeneity_hardening.py`` (16 × 16 × 8 cells, a
    sphere of 0.3 a at 0.5 a): the largest p inside a sphere with the matrix's law (and its
    cells), over a box-wide law L2 (and L2's initial yield stress), inside a sphere with a lower
    own yield stress at E*/E = 1 and 2; then the staircase sphere's constraint."""
    checks = _tests()
    base = checks.base_inputs()
    _, same = checks.run(checks.own(base, base.material.law))
    _, box = checks.run(checks.box_inputs(base, checks.L2))
    numbers = {
        "own_hardening_matrix_law_eqps": checks.largest_p_inside(same[1]),
        "own_hardening_matrix_law_cells": float((same[1].volume["phase"] > 0).sum()),
        "own_hardening_l2_yield": float(checks.L2.yield_stress(np.zeros(1))[0]),
        "own_hardening_l2_eqps": float(box[1].volume["equivalent_plastic_strain"].max()),
    }
    for ratio in (1.0, 2.0):
        _, low = checks.run(checks.own(base, checks.LOW, ratio))
        numbers[f"own_hardening_low_eqps_{ratio:g}"] = checks.largest_p_inside(low[1])
    return numbers | staircase_constraint()


def staircase_constraint() -> dict[str, float]:
    """Constraint 1 + σ11/(2μ εp11) of the cells of a staircase sphere holding a uniform
    deviatoric eigenstrain, against Eshelby's 2 S1212 = 2(4 − 5ν)/(15(1 − ν)) (Mura §11).

    The sphere of ``tests/test_inhomogeneity_solver.py``'s ``eshelby_inputs`` (4 radii deep) at
    :data:`CONSTRAINT_CELLS` cells per radius; its stress from ``sacflow.residual_stress`` (the
    half-space operator of the run's cells). In an infinite body the uniform eigenstrain gives
    the uniform constraint 2 S1212; each cell of the staircase has its own. Returns the
    extremes, mean and standard deviation at the first resolution, the standard deviation at
    the others, and Eshelby's value.
    """
    sys.path.insert(0, str(ROOT / "tests"))
    import test_inhomogeneity_solver as eshelby

    from sacflow import residual_stress
    from sacflow.solver.phase import phase_field
    from sacflow.solver.simulation import Simulation

    mu = eshelby.E / (2.0 * (1.0 + eshelby.NU))
    numbers = {"staircase_constraint_eshelby": float(2.0 * eshelby.eshelby_tensor()[3, 3])}
    for cells in CONSTRAINT_CELLS:
        inputs = eshelby.eshelby_inputs(1.0, cells)
        coords = Simulation(inputs).coords
        inside = phase_field(inputs.inhomogeneities, coords.x1, coords.x2, coords.x3) == 1
        strain = np.zeros((*inside.shape, 6))
        strain[inside] = DEVIATORIC_EIGENSTRAIN
        spacing = (*inputs.grid.cell, inputs.grid.depth / inputs.grid.nz)
        stress = residual_stress(strain, spacing, eshelby.E, eshelby.NU)[inside]
        constraint = 1.0 + stress[:, 0] / (2.0 * mu * DEVIATORIC_EIGENSTRAIN[0])
        numbers[f"staircase_constraint_std_{cells}"] = float(constraint.std())
        if cells == CONSTRAINT_CELLS[0]:
            numbers["staircase_constraint_min"] = float(constraint.min())
            numbers["staircase_constraint_max"] = float(constraint.max())
            numbers["staircase_constraint_mean"] = float(constraint.mean())
    return numbers


#: Cells per radius and modulus ratios E*/E of the deep yielding sphere's comparison.
MATERIAL_POINT_CELLS, MATERIAL_POINT_RATIOS = (2, 3, 5), (1.0, 2.0)


def own_hardening_material_point(out: Path) -> dict[str, float]:
    """The deep sphere yielding under σ11 = σ22 = 1 GPa against the material point of
    Eshelby's uniform interior field (``tests/test_inhomogeneity_hardening.py``'s
    ``deep_yielding_sphere``): the relative error of the mean interior stress and the mean p's
    offset, at 2, 3 and 5 cells per radius, E*/E = 1 and 2 (the last run half a minute)."""
    checks = _tests()
    numbers = {}
    for ratio in MATERIAL_POINT_RATIOS:
        for cells in MATERIAL_POINT_CELLS:
            deep = checks.deep_yielding_sphere(ratio, cells)
            stem = f"own_hardening_point_{ratio:g}_{cells}"
            numbers[f"{stem}_stress"] = deep["stress_error"]
            numbers[f"{stem}_p"] = deep["p_offset"]
    return numbers


def cost_step(n: int, configuration: str) -> dict[str, float]:
    """One load step of ``benchmarks/inclusion.py``'s case and sphere with the sphere
    ``configuration`` (:data:`COST_CONFIGURATIONS`): the residual-stress applications, GMRES
    iterations, the sphere's cells, the largest p inside and outside it, the step's time."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import inclusion as benchmark
    from _common import hertz_step_case

    from sacflow.config.solver_inputs import simulation_for
    from sacflow.mechanics.hardening import LinearHardening
    from sacflow.solver.inputs import Inhomogeneity
    from sacflow.solver.simulation import Simulation
    from sacflow.storage.case_file import case_from_dict

    case = case_from_dict(hertz_step_case(n, "coupled", "mild"))
    inputs = simulation_for(case).inputs
    hardening = case.body.hardening
    laws = {"elastic": None, "matrix_law": inputs.material.law,
            "half_yield": LinearHardening(hardening.yield_stress / 2, hardening.modulus)}
    if configuration != "none":
        sphere = Inhomogeneity("sphere", (0.0, 0.0, benchmark.DEPTH * case.hertz().a),
                               (benchmark.RADIUS_CELLS * inputs.grid.cell[0],) * 3,
                               benchmark.MODULUS, 0.25, law=laws[configuration])
        inputs = replace(inputs, inhomogeneities=(sphere,))
    simulation = Simulation(inputs)
    start = time.perf_counter()  # the step alone, as the benchmark times it
    state = next(iter(simulation.run()))
    seconds = time.perf_counter() - start
    p = state.volume["equivalent_plastic_strain"]
    inside = state.volume["phase"] > 0 if configuration != "none" else np.zeros(p.shape, bool)
    return {"applications": float(state.plasticity_iterations),
            "gmres": float(state.inclusion_iterations), "cells": float(inside.sum()),
            "eqps_in": float(p[inside].max()) if inside.any() else float("nan"),
            "eqps_out": float(p[~inside].max()), "step_s": seconds}


#: The cost table's grid: n × n × n/2 cells.
COST_GRID = 32


def own_hardening_cost(out: Path) -> dict[str, float]:
    """docs/inclusions.md's cost table (counts, largest p): :func:`cost_step` at n = 32 for each
    configuration (seconds each; its times are measurements, not recorded)."""
    numbers = {}
    for configuration in COST_CONFIGURATIONS:
        step = cost_step(COST_GRID, configuration)
        for name in ("applications", "gmres", "eqps_out"):
            numbers[f"own_hardening_cost_{configuration}_{name}"] = step[name]
        if configuration != "none":
            numbers[f"own_hardening_cost_{configuration}_eqps_in"] = step["eqps_in"]
            numbers["own_hardening_cost_cells"] = step["cells"]
    return numbers


def data_rows(name: str) -> list[dict[str, str]]:
    """The rows of the CSV table ``data/<name>`` (the study's tables the groups read back)."""
    with open(ROOT / "data" / name, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


#: The cases of the together table -> the prefix of their keys.
TOGETHER_CASES = {"nanoindentation-650mN": "together", "nanoindentation-190mN": "together_190mN",
                  "nanoindentation-linear-650mN": "together_linear"}
#: docs/convergence.md's table of the together sequence: quantity -> key stem.
TOGETHER = {"print_depth": "print_depth", "peak_pressure": "peak_pressure",
            "max_plastic_strain": "max_eqps", "approach_at_peak_load": "approach",
            "max_plastic_strain_refined": "max_eqps_refined"}


def convergence_together(out: Path) -> dict[str, float]:
    """docs/convergence.md's together sequence (650 mN), read back from
    ``data/convergence-together-summary.csv`` and ``data/convergence-together.csv``
    (regenerated by the command of data/README.md): order, limit, uncertainty, the shipped
    grid's and the finest level's errors, and the three levels' smallest residual σ11 on the
    axis."""
    numbers: dict[str, float] = {}
    for case, prefix in TOGETHER_CASES.items():
        summary = {r["quantity"]: r for r in data_rows("convergence-together-summary.csv")
                   if r["case"] == case}
        levels = [r for r in data_rows("convergence-together.csv") if r["case"] == case]
        if not summary:  # a case of the table not run (yet)
            continue
        for quantity, stem in TOGETHER.items():
            row = summary[quantity]
            if not row["order"]:  # no order: an oscillating or diverging sequence
                continue
            numbers[f"{prefix}_{stem}_order"] = float(row["order"])
            numbers[f"{prefix}_{stem}_limit"] = float(row["limit"])
            numbers[f"{prefix}_{stem}_uncertainty"] = float(row["relative_uncertainty"])
            numbers[f"{prefix}_{stem}_shipped_error"] = float(row["shipped_error"])
            finest = [r for r in levels if r["quantity"] == quantity and r["level"] == "2"]
            numbers[f"{prefix}_{stem}_finest_error"] = float(finest[0]["relative_error"])
        for r in levels:
            if r["quantity"] == "residual_s11_axis_min":
                numbers[f"{prefix}_s11_axis_min_{r['level']}"] = float(r["value"])
    return numbers


#: docs/convergence.md's table of centre-sampled against cell-averaged stresses: case -> key stem.
CELL_MEAN_CASES = {"nanoindentation-650mN": "650mN", "nanoindentation-190mN": "190mN",
                   "nanoindentation-linear-650mN": "linear", "nanoindentation-perfect-650mN":
                   "perfect", "dent-from-indentation-press": "press"}
#: Its quantities: quantity -> key stem.
CELL_MEAN_QUANTITIES = {"print_depth": "print_depth", "peak_pressure": "peak_pressure",
                        "max_plastic_strain": "max_eqps"}
#: The summaries compared: stem -> file of data/ (the same study, ``--set
#: solver.stress_sampling=2`` for the cell mean).
CELL_MEAN_SUMMARIES = {"centre": "convergence-summary.csv",
                       "cell": "convergence-cell-mean-summary.csv"}


def convergence_cell_mean(out: Path) -> dict[str, float]:
    """The lateral and layers sequences with centre-sampled and cell-averaged stresses.

    For each case, quantity and sequence of :data:`CELL_MEAN_CASES` and
    :data:`CELL_MEAN_QUANTITIES`: the observed order and the shipped error of each summary of
    :data:`CELL_MEAN_SUMMARIES`, where the sequence converged monotonically (a diverging or
    oscillating sequence has neither); keys ``cellmean_{case}_{quantity}_{sequence}_{summary}``
    ``_order`` and ``_error``. And the press's print depth at the three levels of its cell-mean
    layers sequence (``cellmean_press_print_depth_layers_level{0,1,2}``).
    """
    numbers: dict[str, float] = {}
    for stem, name in CELL_MEAN_SUMMARIES.items():
        for r in data_rows(name):
            case, quantity = CELL_MEAN_CASES.get(r["case"]), CELL_MEAN_QUANTITIES.get(r["quantity"])
            if case is None or quantity is None or r["sequence"] not in ("lateral", "layers"):
                continue
            if not r["order"]:
                continue
            key = f"cellmean_{case}_{quantity}_{r['sequence']}_{stem}"
            numbers[f"{key}_order"] = float(r["order"])
            numbers[f"{key}_error"] = float(r["shipped_error"])
    for r in data_rows("convergence-cell-mean.csv"):
        if (r["case"], r["sequence"], r["quantity"]) == ("dent-from-indentation-press",
                                                         "layers", "print_depth"):
            numbers[f"cellmean_press_print_depth_layers_level{r['level']}"] = float(r["value"])
    return numbers


def convergence_cell_mean_together(out: Path) -> dict[str, float]:
    """The together sequence with cell-averaged stresses, read back from
    ``data/convergence-cell-mean-together-summary.csv`` and ``-together.csv``: for each case of
    :data:`CELL_MEAN_CASES` and quantity of :data:`TOGETHER` that converged monotonically, the
    order, limit, relative uncertainty, shipped error and finest level's error (keys
    ``cellmean_together_{case}_{quantity}_...``)."""
    summary = data_rows("convergence-cell-mean-together-summary.csv")
    levels = data_rows("convergence-cell-mean-together.csv")
    numbers: dict[str, float] = {}
    for r in summary:
        case, stem = CELL_MEAN_CASES.get(r["case"]), TOGETHER.get(r["quantity"])
        if case is None or stem is None or not r["order"]:
            continue
        key = f"cellmean_together_{case}_{stem}"
        numbers[f"{key}_order"] = float(r["order"])
        numbers[f"{key}_limit"] = float(r["limit"])
        numbers[f"{key}_uncertainty"] = float(r["relative_uncertainty"])
        numbers[f"{key}_shipped_error"] = float(r["shipped_error"])
        finest = [v for v in levels if (v["case"], v["quantity"], v["level"])
                  == (r["case"], r["quantity"], "2")]
        numbers[f"{key}_finest_error"] = float(finest[0]["relative_error"])
    return numbers


#: docs/convergence.md's advice and check: quantity -> key stem (of the together sequences).
CHECKED = {"print_depth": "print_depth", "peak_pressure": "peak_pressure",
           "max_plastic_strain": "max_eqps", "max_plastic_strain_refined": "max_eqps_refined",
           "approach_at_peak_load": "approach", "residual_s11_axis_min": "s11_min"}


def convergence_check(out: Path) -> dict[str, float]:
    """The advice of ``pipelines/convergence.py --advise`` and the check of ``--check 1/3``.

    From ``data/convergence-together-summary.csv``: the step h at which each quantity of
    :data:`CHECKED` is within the study's target error of its limit by the summary's model
    (``advice_{case}_{stem}_step``). From ``data/convergence-check.csv``: the checked run's error
    against the limit, the model's prediction of it, their difference and the limit's relative
    uncertainty (``check_{case}_{stem}_error``, ``_predicted``, ``_discrepancy``,
    ``_uncertainty``), the checked level's cells and layers (``check_nx``, ``check_nz``), and the
    largest |discrepancy| of the print depths and peak pressures and of every quantity.
    """
    from sacflow.studies.convergence_table import advised_step, read_summary

    numbers: dict[str, float] = {}
    summary = read_summary(ROOT / "data" / "convergence-together-summary.csv")
    for (case_name, _, quantity), fit in summary.items():
        case, stem = CELL_MEAN_CASES.get(case_name), CHECKED.get(quantity)
        if case is None or stem is None or math.isnan(fit["order"]):
            continue
        numbers[f"advice_{case}_{stem}_step"] = advised_step(fit)
    largest = {"all": 0.0, "depth_pressure": 0.0}
    for r in data_rows("convergence-check.csv"):
        case, stem = CELL_MEAN_CASES.get(r["case"]), CHECKED.get(r["quantity"])
        if case is None or stem is None:
            continue
        key = f"check_{case}_{stem}"
        for column, suffix in (("relative_error", "error"), ("predicted_error", "predicted"),
                               ("discrepancy", "discrepancy"),
                               ("relative_uncertainty", "uncertainty")):
            numbers[f"{key}_{suffix}"] = float(r[column])
        numbers["check_nx"], numbers["check_nz"] = float(r["nx"]), float(r["nz"])
        size = abs(float(r["discrepancy"]))
        largest["all"] = max(largest["all"], size)
        if stem in ("print_depth", "peak_pressure"):
            largest["depth_pressure"] = max(largest["depth_pressure"], size)
    numbers["check_largest_discrepancy"] = largest["all"]
    numbers["check_largest_discrepancy_depth_pressure"] = largest["depth_pressure"]
    return numbers


#: docs/convergence.md's sections from the print depth at the axis on: tag -> (summary, levels)
#: of data/ (the study rerun with ``print_depth_refined``, its layers to a fourth level, the
#: linear-hardening case's increments with the cell mean, the σ11 read on the axis, the study
#: with the configs' finer shipped grids, five and six increment levels at 32² × 12 cells, the
#: linear-hardening case's `together` at h = 1, 1/2, 1/4 and 1/5, and its increments on the
#: 80² × 48 grid from 20 + 10; the press's `together` at h = 1, 2/3 and 1/2, its increments
#: at its shipped 96² × 128 cells, and its lateral cells and layers from there with 40 + 12;
#: the press's lateral cells and its `together` to a fourth level, its `together`, lateral
#: cells, layers and increments on sub-cells whose pressure loads the body (that `together` also
#: to a fourth level, those lateral cells through their finest three of four), its window, the
#: 650 mN case's window at its shipped grid and the 190 mN and linear-hardening cases' at the
#: study's base grid).
REFINED_TABLES = {
    "refined": ("convergence-refined-summary.csv", "convergence-refined.csv"),
    "layers4": ("convergence-refined-layers4-summary.csv", "convergence-refined-layers4.csv"),
    "lincm": ("convergence-linear-cell-mean-increments-summary.csv",
              "convergence-linear-cell-mean-increments.csv"),
    "axis": ("convergence-axis-summary.csv", "convergence-axis.csv"),
    "shipped": ("convergence-shipped-summary.csv", "convergence-shipped.csv"),
    "inccoarse": ("convergence-increments-coarse-summary.csv",
                  "convergence-increments-coarse.csv"),
    "incsix": ("convergence-increments-six-summary.csv", "convergence-increments-six.csv"),
    "steps": ("convergence-steps-summary.csv", "convergence-steps.csv"),
    "incgrid": ("convergence-increments-grid-summary.csv", "convergence-increments-grid.csv"),
    "presssteps": ("convergence-press-steps-summary.csv", "convergence-press-steps.csv"),
    "pressinc": ("convergence-press-increments-summary.csv",
                 "convergence-press-increments.csv"),
    "pressgrid": ("convergence-press-grid-summary.csv", "convergence-press-grid.csv"),
    "presslat4": ("convergence-press-lateral4-summary.csv", "convergence-press-lateral4.csv"),
    "presssteps4": ("convergence-press-steps4-summary.csv", "convergence-press-steps4.csv"),
    "presssub": ("convergence-press-subcells-summary.csv", "convergence-press-subcells.csv"),
    "presssub4": ("convergence-press-subcells4-summary.csv", "convergence-press-subcells4.csv"),
    "presssubstress": ("convergence-press-subcell-stress-summary.csv",
                       "convergence-press-subcell-stress.csv"),
    "presssubstress4": ("convergence-press-subcell-stress4-summary.csv",
                        "convergence-press-subcell-stress4.csv"),
    "presssubgrid": ("convergence-press-subcell-stress-grid-summary.csv",
                     "convergence-press-subcell-stress-grid.csv"),
    "presssubinc": ("convergence-press-subcell-stress-increments-summary.csv",
                    "convergence-press-subcell-stress-increments.csv"),
    "presslatfine": ("convergence-press-lateral-finest-summary.csv",
                     "convergence-press-lateral-finest.csv"),
    "presswin": ("convergence-press-window-summary.csv", "convergence-press-window.csv"),
    "steps650five": ("convergence-650-steps5-summary.csv", "convergence-650-steps5.csv"),
    "steps650six": ("convergence-650-steps6-summary.csv", "convergence-650-steps6.csv"),
    "steps190six": ("convergence-190-steps6-summary.csv", "convergence-190-steps6.csv"),
    "stepslinsix": ("convergence-linear-steps6-summary.csv", "convergence-linear-steps6.csv"),
    "win650": ("convergence-window-650-summary.csv", "convergence-window-650.csv"),
    "winbase": ("convergence-window-base-summary.csv", "convergence-window-base.csv"),
    "presswinfar": ("convergence-press-window-far-summary.csv",
                    "convergence-press-window-far.csv"),
    "win650far": ("convergence-window-650-far-summary.csv", "convergence-window-650-far.csv"),
    "winbasefar": ("convergence-window-base-far-summary.csv", "convergence-window-base-far.csv"),
}
#: Level tables whose levels and limits are also compared with the limits of another table of
#: the same case, sequence and quantity (the window with and without the traction beyond the
#: box; the press's lateral cells through their finest three and their first three): tag -> the
#: other tag (``{tag}_..._level{L}_against_error``, ``_limit_against_error``).
AGAINST_LIMITS = {"presswinfar": "presswin", "win650far": "win650", "winbasefar": "winbase",
                  "presslatfine": "presssubgrid"}
#: Sequences whose advised cells per side docs/convergence.md quotes: tag -> sequence (the
#: press's lateral cells through their first three and their finest three levels).
ADVISED_CELLS = {"presssubgrid": "lateral", "presslatfine": "lateral"}
#: Level tables whose levels are also compared with the `together` limits of
#: ``data/convergence-shipped-summary.csv`` (``{tag}_..._level{L}_together_error``).
AGAINST_TOGETHER = ("incgrid",)
#: Checks of ``data/convergence-shipped-summary.csv``'s `together` models at h = 1/3 and 1/5,
#: of the press's on sub-cells at h = 1/3 and, its body loaded by their pressure, at h = 2/5
#: and 1/3, and of that press's lateral model at its first level with 4 × 4 sub-cells, 3³
#: stress points or 49² cells (the load axis on a cell's centre) and at h = 1/3
#: (``pipelines/convergence.py --check``): tag -> table.
SHIPPED_CHECKS = {"shipcheck": "convergence-shipped-check.csv",
                  "shipcheck5": "convergence-shipped-check-5.csv",
                  "presssubcheck": "convergence-press-subcells-check-3.csv",
                  "presssubstresscheck": "convergence-press-subcell-stress-check-5.csv",
                  "presssubstresscheck3": "convergence-press-subcell-stress-check-3.csv",
                  "lincheck6": "convergence-linear-check-6.csv",
                  "presslatsub4": "convergence-press-lateral-subcells4-check-1.csv",
                  "presslatss3": "convergence-press-lateral-sampling3-check-1.csv",
                  "presslatodd49": "convergence-press-lateral-odd49-check-1.csv",
                  "presslatcheck3": "convergence-press-subcell-stress-grid-check-3.csv"}
#: The press's checks whose largest miss of the model over the certified quantities of
#: :data:`PRESS_CHECK_STEMS` is quoted (``{tag}_press_largest_discrepancy``): the smeared
#: pressure's at h = 1/3, the sub-cells' pressure's at h = 2/5 and 1/3, and its lateral model's
#: at h = 1/3.
PRESS_LARGEST_CHECKS = ("presssubcheck", "presssubstresscheck", "presssubstresscheck3",
                        "presslatcheck3")
#: The certified quantities of the press's checks.
PRESS_CHECK_STEMS = ("print_depth_refined", "peak_pressure", "max_eqps_refined",
                     "s11_min_refined", "s11_025a_refined", "s11_05a_refined", "s11_1a_refined",
                     "s11_15a_refined", "s11_2a_refined")
#: The quantities of docs/convergence.md's table of the Swift cases at their shipped grids.
SWIFT_TABLE_STEMS = ("approach", "print_depth_refined", "max_eqps_refined",
                     "max_eqps_refined_depth", "s11_min_refined", "s11_05a_refined",
                     "s11_1a_refined", "s11_2a_refined", "peak_pressure")
#: Level tables compared with the model of that `together` sequence at their steps.
AGAINST_MODEL = ("steps",)
#: Their quantities: quantity -> key stem.
REFINED_QUANTITIES = {**CHECKED, "print_depth_refined": "print_depth_refined",
                      "max_plastic_strain_refined_depth": "max_eqps_refined_depth",
                      "residual_s11_axis_min_refined": "s11_min_refined",
                      "residual_s11_axis_at_1a": "s11_1a",
                      "residual_s11_axis_at_0.5a": "s11_05a",
                      "residual_s11_axis_refined_at_0.5a": "s11_05a_refined",
                      "residual_s11_axis_refined_at_1a": "s11_1a_refined",
                      "residual_s11_axis_refined_at_2a": "s11_2a_refined",
                      "residual_s11_axis_refined_at_0.25a": "s11_025a_refined",
                      "residual_s11_axis_refined_at_1.5a": "s11_15a_refined",
                      "residual_s33_layer1_axis": "s33_layer1_axis",
                      "residual_s33_layer1_extreme": "s33_layer1_extreme"}
#: The columns of a summary row recorded: column -> key suffix.
REFINED_COLUMNS = {"order": "order", "previous_order": "previous_order", "limit": "limit",
                   "relative_uncertainty": "uncertainty", "shipped_error": "shipped_error"}


def _level_numbers(tag: str, levels: str) -> dict[str, float]:
    """Each level's value and error of the levels table ``levels`` (``{tag}_..._level{L}``,
    ``_error``), its change from the level before and its difference from the finest level
    (``_change``, ``_from_finest``): see :func:`convergence_refined`. A level without the
    quantity (a profile depth below its box) has no value, and its sequence no differences."""
    from sacflow.studies.richardson import relative_errors

    numbers: dict[str, float] = {}
    sequences: dict[str, list[float | None]] = {}
    for r in data_rows(levels):
        case, stem = CELL_MEAN_CASES.get(r["case"]), REFINED_QUANTITIES.get(r["quantity"])
        if case is None or stem is None:
            continue
        key = f"{tag}_{case}_{r['sequence']}_{stem}_level"
        value = float(r["value"]) if r["value"] else None
        sequences.setdefault(key, []).append(value)
        if value is None:
            continue
        numbers[f"{key}{r['level']}"] = value
        if r["relative_error"]:
            numbers[f"{key}{r['level']}_error"] = float(r["relative_error"])
    for key, values in sequences.items():
        present = [v for v in values if v is not None]
        if len(present) < len(values):
            continue
        from_finest = relative_errors(present, present[-1])
        for level in range(1, len(present)):
            numbers[f"{key}{level}_change"] = present[level] - present[level - 1]
            numbers[f"{key}{level - 1}_from_finest"] = from_finest[level - 1]
    return numbers


def convergence_refined(out: Path) -> dict[str, float]:
    """The tables of :data:`REFINED_TABLES` and ``data/convergence-refined-check.csv``.

    For each case of :data:`CELL_MEAN_CASES`, sequence and quantity of
    :data:`REFINED_QUANTITIES`: the summary's :data:`REFINED_COLUMNS` where present
    (``{tag}_{case}_{sequence}_{stem}_{suffix}``), each level's value and error against the
    sequence's limit (``..._level{L}``, ``..._level{L}_error``), its change from the level before
    (``..._level{L}_change``) and its difference from the finest level, relative as the study's
    errors, (value − finest) / |finest| (``..._level{L}_from_finest``, and
    ``..._shipped_from_finest`` for the shipped value); from the check at h = 1/3, each
    quantity's error against the limit (``refcheck_{case}_{stem}_error``).
    """
    from sacflow.studies.richardson import relative_errors

    numbers: dict[str, float] = {}
    for tag, (summary, levels) in REFINED_TABLES.items():
        for r in data_rows(summary):
            case, stem = CELL_MEAN_CASES.get(r["case"]), REFINED_QUANTITIES.get(r["quantity"])
            if case is None or stem is None:
                continue
            key = f"{tag}_{case}_{r['sequence']}_{stem}"
            numbers.update({f"{key}_{suffix}": float(r[column])
                            for column, suffix in REFINED_COLUMNS.items() if r[column]})
            if r["shipped_value"] and r["finest_value"]:
                numbers[f"{key}_shipped_from_finest"] = relative_errors(
                    [float(r["shipped_value"])], float(r["finest_value"]))[0]
        numbers.update(_level_numbers(tag, levels))
    for r in data_rows("convergence-refined-check.csv"):
        case, stem = CELL_MEAN_CASES.get(r["case"]), REFINED_QUANTITIES.get(r["quantity"])
        if case is not None and stem is not None:
            numbers[f"refcheck_{case}_{stem}_error"] = float(r["relative_error"])
    for tag, table in SHIPPED_CHECKS.items():
        for r in data_rows(table):
            case, stem = CELL_MEAN_CASES.get(r["case"]), REFINED_QUANTITIES.get(r["quantity"])
            if case is not None and stem is not None:
                numbers.update({f"{tag}_{case}_{stem}_{suffix}": float(r[column])
                                for column, suffix in (("relative_error", "error"),
                                                       ("predicted_error", "predicted"),
                                                       ("discrepancy", "discrepancy"),
                                                       ("value", "value"))})
    for case in ("650mN", "190mN"):
        sizes = {stem: abs(numbers[key]) for stem in SWIFT_TABLE_STEMS
                 if (key := f"shipcheck5_{case}_{stem}_discrepancy") in numbers}
        numbers[f"shipcheck5_{case}_largest_discrepancy"] = max(sizes.values())
        numbers[f"shipcheck5_{case}_largest_discrepancy_but_depth"] = max(
            v for stem, v in sizes.items() if stem != "max_eqps_refined_depth")
    for tag in PRESS_LARGEST_CHECKS:
        numbers[f"{tag}_press_largest_discrepancy"] = max(
            abs(numbers[key]) for stem in PRESS_CHECK_STEMS
            if (key := f"{tag}_press_{stem}_discrepancy") in numbers)
    numbers.update(_against_together())
    numbers.update(_against_limits())
    numbers.update(_advised_cells())
    return numbers


def _advised_cells() -> dict[str, float]:
    """Cells per side at which each sequence of :data:`ADVISED_CELLS` puts each quantity within
    the study's target of its limit (``pipelines/convergence.py --advise``; h = 1 is the cells
    of the levels table's first level times its h): ``{tag}_..._advised_cells``."""
    from sacflow.studies.convergence_table import advised_step, count_at_step, read_summary

    numbers: dict[str, float] = {}
    for tag, sequence in ADVISED_CELLS.items():
        summary, levels = REFINED_TABLES[tag]
        first = next(r for r in data_rows(levels) if r["sequence"] == sequence)
        # the sequence's cells at h = 1, whole; the table's h has ten digits
        cells_at_unit_step = round(float(first["nx"]) * float(first["h"]))
        for (case_name, seq, quantity), row in read_summary(ROOT / "data" / summary).items():
            case, stem = CELL_MEAN_CASES.get(case_name), REFINED_QUANTITIES.get(quantity)
            step = advised_step(row)
            if seq == sequence and case and stem and math.isfinite(step) and step > 0.0:
                numbers[f"{tag}_{case}_{seq}_{stem}_advised_cells"] = float(
                    count_at_step(cells_at_unit_step, step))
    return numbers


def _against_limits() -> dict[str, float]:
    """The levels and limit of each table of :data:`AGAINST_LIMITS` against the other table's
    limit, relative as the study's errors (``{tag}_..._level{L}_against_error``,
    ``{tag}_..._limit_against_error``)."""
    from sacflow.studies.richardson import relative_errors

    numbers: dict[str, float] = {}
    for tag, other in AGAINST_LIMITS.items():
        limits = {(r["case"], r["sequence"], r["quantity"]): float(r["limit"])
                  for r in data_rows(REFINED_TABLES[other][0]) if r["limit"]}
        for table, column, suffix in ((1, "value", "level{level}"), (0, "limit", "limit")):
            for r in data_rows(REFINED_TABLES[tag][table]):
                case, stem = CELL_MEAN_CASES.get(r["case"]), REFINED_QUANTITIES.get(r["quantity"])
                limit = limits.get((r["case"], r["sequence"], r["quantity"]))
                if case is None or stem is None or limit is None or not r[column]:
                    continue
                name = suffix.format(level=r.get("level"))
                numbers[f"{tag}_{case}_{r['sequence']}_{stem}_{name}_against_error"] = (
                    relative_errors([float(r[column])], limit)[0])
    return numbers


def _against_together() -> dict[str, float]:
    """Levels and limits of other tables against the `together` sequence of the same case and
    quantity in ``data/convergence-shipped-summary.csv`` (relative, as the study's errors).

    For the tables of :data:`AGAINST_TOGETHER`: each level's error against that limit
    (``{tag}_..._level{L}_together_error``) and its difference from that sequence's finest
    level (``..._level{L}_together_from_finest``), and the table's own limit against it
    (``{tag}_..._limit_together_error``). For those of :data:`AGAINST_MODEL`: each level's
    distance from that sequence's model f∞ + C hᵖ at its step, relative to f∞
    (``..._level{L}_model_discrepancy``, as ``--check`` gives it).
    """
    from sacflow.studies.convergence_table import model_check, read_summary
    from sacflow.studies.richardson import relative_errors

    together = {(case, quantity): row for (case, sequence, quantity), row
                in read_summary(ROOT / "data" / "convergence-shipped-summary.csv").items()
                if sequence == "together"}
    numbers: dict[str, float] = {}

    def fits(tags: tuple[str, ...], table: int):
        for tag in tags:
            for r in data_rows(REFINED_TABLES[tag][table]):
                case, stem = CELL_MEAN_CASES.get(r["case"]), REFINED_QUANTITIES.get(r["quantity"])
                fit = together.get((r["case"], r["quantity"]))
                if case is not None and stem is not None and fit is not None:
                    yield f"{tag}_{case}_{r['sequence']}_{stem}", r, fit

    for key, r, fit in fits(AGAINST_TOGETHER, 1):
        if r["value"]:
            value, level = float(r["value"]), r["level"]
            numbers[f"{key}_level{level}_together_from_finest"] = relative_errors(
                [value], fit["finest_value"])[0]
            if math.isfinite(fit["limit"]):
                numbers[f"{key}_level{level}_together_error"] = relative_errors(
                    [value], fit["limit"])[0]
    for key, r, fit in fits(AGAINST_TOGETHER, 0):
        if r["limit"] and math.isfinite(fit["limit"]):
            numbers[f"{key}_limit_together_error"] = relative_errors(
                [float(r["limit"])], fit["limit"])[0]
    for key, r, fit in fits(AGAINST_MODEL, 1):
        if r["value"] and math.isfinite(fit["limit"]) and math.isfinite(fit["order"]):
            _, error, predicted = model_check(fit, float(r["value"]), float(r["h"]))
            numbers[f"{key}_level{r['level']}_model_discrepancy"] = error - predicted
    return numbers


#: The groups of this module: name -> (speed, function of the output folder).
GROUPS = {
    "own_hardening_checks": ("fast", own_hardening_checks),
    "own_hardening_material_point": ("slow", own_hardening_material_point),
    "own_hardening_cost": ("slow", own_hardening_cost),
    "convergence_together": ("fast", convergence_together),
    "convergence_cell_mean": ("fast", convergence_cell_mean),
    "convergence_cell_mean_together": ("fast", convergence_cell_mean_together),
    "convergence_check": ("fast", convergence_check),
    "convergence_refined": ("fast", convergence_refined),
}


if __name__ == "__main__":
    size = int(sys.argv[1]) if len(sys.argv) > 1 else COST_GRID
    print(json.dumps({c: cost_step(size, c) for c in COST_CONFIGURATIONS}, indent=2))
