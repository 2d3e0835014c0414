"""The convergence study (issue #32): its arithmetic, its levels, its pipeline end to end.

* :func:`sacflow.studies.richardson.extrapolate` recovers p and f∞ of synthetic sequences
  f = f∞ + C hᵖ (any ratio, either sign of C), flags oscillating, diverging and unchanged ones;
* the refinement sequences build the levels they say (box depth fixed, or scaled with the layers;
  the window widened at the same cells);
* ``pipelines/press_edge_position.py`` reads the contact edge inside its cell and runs its windows;
* ``pipelines/convergence.py --quick`` on one case and two sequences (a few seconds): the tables'
  columns, one row per level and quantity, a second run read from the cache, no table
  overwritten without ``--overwrite``;
* the prediction of a level the study did not run (``--check``) and the step a target accuracy
  needs (``--advise``) recover the model f = f∞ + C hᵖ they assume, and ``--check`` runs the
  level between two of a sequence.
"""

from __future__ import annotations

import csv
import importlib.util
import json
import math
import re
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from sacflow.studies.convergence import (
    SEQUENCES,
    STUDY_CASES,
    ConvergenceError,
    Discretisation,
    base_case,
    shipped_discretisation,
    source_fingerprint,
)
from sacflow.studies.convergence_table import (
    CHECK_COLUMNS,
    LEVEL_COLUMNS,
    SUMMARY_COLUMNS,
    check_rows,
    count_at_step,
)
from sacflow.studies.richardson import (
    GCI_SAFETY_FACTOR,
    extrapolate,
    extrapolate_steps,
    observed_order,
    relative_errors,
    step_for_error,
    value_at_step,
)

PIPELINE = Path(__file__).parent.parent / "pipelines" / "convergence.py"


def synthetic(limit: float, coefficient: float, order: float, ratio: float,
              levels: int = 3) -> list[float]:
    """f = f∞ + C hᵖ on h = 1, 1/r, 1/r², ... (coarse to fine)."""
    return [limit + coefficient * ratio ** (-k * order) for k in range(levels)]


@pytest.mark.parametrize(("order", "ratio", "coefficient"),
                         [(2.0, 2.0, 0.3), (1.0, 2.0, -5.0), (2.55, 1.5, 1e-3), (0.7, 3.0, 2.0)])
def test_richardson_recovers_order_and_limit_of_synthetic_sequences(order, ratio, coefficient):
    values = synthetic(10.0, coefficient, order, ratio)
    fit = extrapolate(values, ratio, formal_order=2.0)
    assert fit.behaviour == "monotone"
    assert fit.order == pytest.approx(order, rel=1e-9)
    assert fit.limit == pytest.approx(10.0, rel=1e-12)
    # GCI of the finest level: F_s times its exact error (the sequence is asymptotic), or
    # larger when the observed order exceeds the formal one (no credit taken for it)
    exact = abs(values[-1] - 10.0)
    credited = min(order, 2.0)
    expected = exact * (ratio**order - 1.0) / (ratio**credited - 1.0)
    assert fit.uncertainty == pytest.approx(GCI_SAFETY_FACTOR * expected, rel=1e-6)
    assert fit.uncertainty >= GCI_SAFETY_FACTOR * exact * (1.0 - 1e-9)
    assert math.isnan(fit.previous_order)
    errors = relative_errors(values, fit.limit)
    assert errors[-1] == pytest.approx((values[-1] - 10.0) / 10.0, rel=1e-6)


def test_formal_limit_equals_observed_one_at_the_formal_order():
    fit = extrapolate(synthetic(-3.0, 0.5, 2.0, 2.0), 2.0, formal_order=2.0)
    assert fit.formal_limit == pytest.approx(fit.limit, rel=1e-12)
    fit = extrapolate(synthetic(-3.0, 0.5, 1.0, 2.0), 2.0, formal_order=2.0)
    assert abs(fit.formal_limit - fit.limit) > 0.01  # first order read as second: off


def test_four_levels_give_the_previous_order_too():
    values = synthetic(1.0, 1.0, 2.0, 2.0, levels=3)
    values.insert(0, 3.0)  # a pre-asymptotic coarsest level
    fit = extrapolate(values, 2.0)
    assert fit.order == pytest.approx(2.0)
    assert fit.previous_order == pytest.approx(observed_order(*values[:3], 2.0))
    assert not fit.previous_order == pytest.approx(2.0, abs=0.1)


def test_non_monotone_sequences_are_flagged_without_order():
    oscillating = extrapolate([1.0, 1.2, 1.1], 2.0, formal_order=2.0)
    assert oscillating.behaviour == "oscillating"
    assert math.isnan(oscillating.order) and math.isnan(oscillating.limit)
    assert oscillating.uncertainty == pytest.approx(0.1)  # half the range
    diverging = extrapolate([1.0, 1.1, 1.3], 2.0)
    assert diverging.behaviour == "diverging"
    assert math.isnan(diverging.order) and math.isnan(diverging.limit)
    unchanged = extrapolate([2.0, 2.0, 2.0], 2.0)
    assert (unchanged.behaviour, unchanged.limit, unchanged.uncertainty) == ("unchanged", 2.0, 0.0)
    assert all(math.isnan(e) for e in relative_errors([1.0, 2.0], math.nan))


def test_extrapolation_needs_three_levels_and_a_ratio_above_one():
    with pytest.raises(ValueError, match="three levels"):
        extrapolate([1.0, 2.0], 2.0)
    with pytest.raises(ValueError, match="ratio"):
        extrapolate([1.0, 2.0, 2.5], 1.0)


@pytest.mark.parametrize(("order", "coefficient"),
                         [(2.0, 0.3), (1.3, -4.0), (3.7, 5.0), (0.6, 1.0)])
def test_unequal_steps_recover_order_and_limit(order, coefficient):
    """Levels at h = 1/2, 1/3, 1/4, 1/5 of f = f∞ + C hᵖ: the root of the unequal-ratio equation
    is p, the limit f∞, and the GCI uses the finest pair's ratio 5/4."""
    steps = [1 / 2, 1 / 3, 1 / 4, 1 / 5]
    values = [-565.0 + coefficient * h**order for h in steps]
    fit = extrapolate_steps(values, steps, formal_order=2.0)
    assert fit.behaviour == "monotone"
    assert fit.order == pytest.approx(order, rel=1e-9)
    assert fit.previous_order == pytest.approx(order, rel=1e-9)
    assert fit.limit == pytest.approx(-565.0, abs=1e-9)
    credited = min(order, 2.0)
    gci = GCI_SAFETY_FACTOR * abs(values[-1] - values[-2]) / (1.25**credited - 1.0)
    assert fit.uncertainty == pytest.approx(gci, rel=1e-9)
    assert fit.formal_limit == pytest.approx(
        values[-1] + (values[-1] - values[-2]) / (1.25**2 - 1.0), rel=1e-12)


def test_unequal_steps_with_a_constant_ratio_are_the_ratio_form():
    values = [3.0, 2.2, 2.05, 2.01]
    steps = [1.0, 1 / 3, 1 / 9, 1 / 27]
    assert extrapolate_steps(values, steps, 2.0) == extrapolate(values, 3.0, 2.0)


def test_unequal_steps_flag_differences_that_no_positive_order_explains():
    # h = 1/2, 1/3, 1/4: order 0+ gives the ratio ln(3/2) / ln(4/3) = 1.41 of the differences
    steps = [1 / 2, 1 / 3, 1 / 4]
    assert extrapolate_steps([1.0, 2.3, 3.3], steps).behaviour == "diverging"  # ratio 1.3
    assert extrapolate_steps([1.0, 2.5, 3.5], steps).behaviour == "monotone"  # ratio 1.5
    assert extrapolate_steps([1.0, 2.0, 1.5], steps).behaviour == "oscillating"
    with pytest.raises(ValueError, match="decrease"):
        extrapolate_steps([1.0, 2.0, 2.5], [1.0, 1.0, 0.5])
    with pytest.raises(ValueError, match="one step per level"):
        extrapolate_steps([1.0, 2.0, 2.5], [1.0, 0.5])


@pytest.mark.parametrize(("order", "coefficient"), [(2.0, 0.3), (1.3, -4.0), (2.6, 1e-3)])
def test_the_model_through_the_finest_level_predicts_any_step(order, coefficient):
    """On f = f∞ + C hᵖ the fitted model gives f at any step, and the step whose error is the
    target is the one the closed form h = (ε |f∞| / |C|)^(1/p) gives."""
    limit, ratio = 81.5, 2.0
    values = synthetic(limit, coefficient, order, ratio)
    fit = extrapolate(values, ratio, formal_order=2.0)
    finest = ratio ** -2.0
    for step in (1.0, 1 / 3, 0.1):
        assert value_at_step(values[-1], fit.limit, fit.order, finest, step) == pytest.approx(
            limit + coefficient * step**order, rel=1e-12)
    target = 1e-4
    exact = (target * limit / abs(coefficient)) ** (1.0 / order)
    assert step_for_error(values[-1], fit.limit, fit.order, finest, target) == pytest.approx(
        exact, rel=1e-9)


def test_no_prediction_without_an_order_or_a_limit():
    assert math.isnan(value_at_step(1.0, math.nan, 2.0, 0.25, 0.3))
    assert math.isnan(value_at_step(1.0, 1.0, math.nan, 0.25, 0.3))
    assert math.isnan(step_for_error(1.0, 0.0, 2.0, 0.25, 0.005))  # no relative error of 0
    assert math.isinf(step_for_error(2.0, 2.0, 2.0, 0.25, 0.005))  # the finest is the limit


BASE = Discretisation(64, 24, 1.5e-5, (10, 5))


def test_sequences_build_their_levels():
    lateral = SEQUENCES["lateral"].levels(BASE)
    assert [(d.nx, d.nz, d.depth, d.increments) for d in lateral] == [
        (32, 24, 1.5e-5, (10, 5)), (64, 24, 1.5e-5, (10, 5)), (128, 24, 1.5e-5, (10, 5))]
    layers = SEQUENCES["layers"].levels(BASE, 4)
    assert [d.nz for d in layers] == [12, 24, 48, 96]
    assert {d.depth for d in layers} == {1.5e-5}  # the box depth does not move with nz
    depth = SEQUENCES["depth"].levels(BASE)
    assert [d.nz for d in depth] == [24, 36, 54]
    assert [d.depth / d.nz for d in depth] == pytest.approx([1.5e-5 / 24] * 3)
    increments = SEQUENCES["increments"].levels(BASE)
    assert [d.increments for d in increments] == [(10, 5), (20, 10), (40, 20)]
    together = SEQUENCES["together"].levels(BASE)
    assert [(d.nx, d.nz, d.total_increments) for d in together] == [
        (32, 12, 15), (64, 24, 30), (128, 48, 60)]
    assert "grid.depth=1.5e-05" in BASE.overrides()
    with pytest.raises(ConvergenceError, match="fractional|divisible"):
        SEQUENCES["depth"].levels(Discretisation(64, 25, 1e-5, (10, 5)))


def test_a_step_between_the_levels_scales_every_refined_number():
    together = SEQUENCES["together"]
    assert together.at_step(BASE, 1 / 3) == Discretisation(96, 36, 1.5e-5, (30, 15))
    for k in range(3):  # the steps of the levels give the levels
        assert together.at_step(BASE, 2.0**-k) == together.level(BASE, k)
    assert SEQUENCES["depth"].at_step(BASE, 1 / 1.5).nz == 36
    with pytest.raises(ConvergenceError, match="step 0.3 would have"):
        together.at_step(BASE, 0.3)  # 32 / 0.3 cells
    with pytest.raises(ConvergenceError, match="> 0"):
        together.at_step(BASE, 0.0)


def test_the_window_sequence_widens_the_window_at_the_same_cells():
    """``window`` scales grid.half_width and the surface cells together: the cell size stays,
    its first level is the base's run, and a case giving its window as an extent is refused."""
    base = Discretisation(48, 64, 5e-4, (20, 6), case_half_width=3.0)
    window = SEQUENCES["window"]
    levels = window.levels(base)
    assert [(d.nx, d.half_width) for d in levels] == [(48, None), (72, 4.5), (108, 6.75)]
    assert levels[0] == base and levels[0].overrides() == base.overrides()
    assert "grid.half_width=4.5" in levels[1].overrides()
    assert {d.nz for d in levels} == {64} and {d.increments for d in levels} == {(20, 6)}
    assert window.at_step(base, 1 / 2) == replace(base, nx=96, half_width=6.0)
    assert window.formal_order is None
    with pytest.raises(ConvergenceError, match="grid.extent"):
        window.levels(replace(base, case_half_width=None))
    study = STUDY_CASES["dent-from-indentation-press"]
    shipped = shipped_discretisation(base_case(study))
    assert shipped.case_half_width == 3.0 and shipped.half_width is None
    cells = []
    for level in window.levels(replace(shipped, nx=48, nz=16)):
        case = base_case(study, level.overrides())
        cells.append(2.0 * case.grid.half_width * case.hertz().a / case.grid.nx)
    assert cells == pytest.approx([cells[0]] * 3, rel=1e-12)  # the same cells, a wider window


def test_a_checked_run_is_compared_with_the_prediction_at_its_step():
    """A run that lands on the model has no discrepancy; one off it by 0.1 % of the limit
    shows 0.1 %; sequences without an order are left out."""
    limit, coefficient, order = 80.0, -3.0, 2.0
    values = synthetic(limit, coefficient, order, 2.0)
    fit = extrapolate(values, 2.0, 2.0)
    summary = {("c", "together", "print_depth"): {
        "behaviour": "monotone", "limit": fit.limit, "order": fit.order, "ratio": 2.0,
        "levels": 3.0, "finest_value": values[-1], "relative_uncertainty": 1e-3},
        ("c", "together", "peak_pressure"): {"behaviour": "oscillating", "limit": math.nan}}
    on_model = limit + coefficient / 9.0
    record = {"converged": True,
              "quantities": {"print_depth": on_model + 0.08, "peak_pressure": 5e9}}
    level = SEQUENCES["together"].at_step(BASE, 1 / 3)
    (row,) = check_rows("c", "together", 1 / 3, level, record, summary)
    assert tuple(row) == CHECK_COLUMNS
    assert row["predicted"] == pytest.approx(on_model, rel=1e-12)
    assert row["discrepancy"] == pytest.approx(0.001, rel=1e-9)
    assert row["predicted_error"] == pytest.approx(coefficient / 9.0 / limit, rel=1e-9)
    assert (row["nx"], row["nz"], row["increments"]) == (96, 36, 45)


def test_shipped_discretisation_makes_the_automatic_depth_explicit():
    case = base_case(STUDY_CASES["nanoindentation-650mN"])
    shipped = shipped_discretisation(case)
    assert (shipped.nx, shipped.nz, shipped.increments) == (80, 48, (20, 10))
    assert case.grid.depth is None and shipped.depth > case.hertz().a
    perfect = base_case(STUDY_CASES["nanoindentation-perfect-650mN"])
    assert perfect.body.hardening.law == "perfectly_plastic"
    assert perfect.body.hardening.yield_stress == pytest.approx(1655.7e6, rel=1e-4)
    # without hardening, centre values admit a checkerboard whose levels do not finish: the
    # perfectly plastic variant runs with the cell mean, the Swift case it comes from does not
    assert perfect.solver.stress_sampling == 2 and case.solver.stress_sampling == 1


def test_source_fingerprint_names_the_numerical_code():
    assert re.fullmatch(r"[0-9a-f]{16}", source_fingerprint())
    assert source_fingerprint(("solver",)) != source_fingerprint(("kernels",))


def load_script(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def load_pipeline():
    return load_script(PIPELINE, "convergence_pipeline")


def test_the_ladders_keep_their_base_while_the_configs_ship_finer_discretisations():
    # the nano-indentations ship 80² × 48 cells (96² at 190 mN) and 20 + 10 increments; the
    # study's levels stay around 64² × 24 and 10 + 5, those of its recorded tables, and the
    # shipped discretisation is run as a level of its own
    pipeline = load_pipeline()
    for name, cells in (("nanoindentation-650mN", 80), ("nanoindentation-190mN", 96)):
        base, shipped, sequences, _ = pipeline.case_setup(
            pipeline.parse(["--cases", name]), name)
        assert (base.nx, base.nz, base.increments) == (64, 24, (10, 5))
        assert (shipped.nx, shipped.nz, shipped.increments) == (cells, 48, (20, 10))
        assert base.depth == shipped.depth
        for seq in ("increments", "together"):
            assert sequences[seq].levels(base)[1] == replace(base, increments=(20, 10))
        assert [level.increments for level in sequences["lateral"].levels(base)] == [(10, 5)] * 3
        assert [level.nz for level in sequences["layers"].levels(base)] == [12, 24, 48]
    # an override of the load path (here --quick's, with the grid) is the base itself
    base, shipped, _, _ = pipeline.case_setup(
        pipeline.parse(["--cases", "nanoindentation-650mN", "--quick"]), "nanoindentation-650mN")
    assert base == shipped and base.increments == (2, 1)
    # an override of the grid alone keeps the base increments
    base, shipped, _, _ = pipeline.case_setup(
        pipeline.parse(["--cases", "nanoindentation-650mN", "--set", "grid.nz=30"]),
        "nanoindentation-650mN")
    assert (base.nx, base.nz, base.increments) == (80, 30, (10, 5))
    # an override of the box depth alone keeps the base cells
    base, shipped, _, _ = pipeline.case_setup(
        pipeline.parse(["--cases", "nanoindentation-650mN", "--set", "grid.depth=2e-5"]),
        "nanoindentation-650mN")
    assert (base.nx, base.nz, base.depth) == (64, 24, 2e-5) and shipped.nx == 80
    # the press ships 96² × 128 cells with 40 + 12 increments; its ladders stay at 48² × 16
    # with 10 + 3, those of its recorded tables
    base, shipped, _, _ = pipeline.case_setup(
        pipeline.parse(["--cases", "dent-from-indentation-press"]), "dent-from-indentation-press")
    assert (base.nx, base.nz, base.increments) == (48, 16, (10, 3))
    assert (shipped.nx, shipped.nz, shipped.increments) == (96, 128, (40, 12))
    assert base.depth == shipped.depth


def read(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def test_quick_pipeline_end_to_end(tmp_path, capsys):
    pipeline = load_pipeline()
    table, summary, cache = tmp_path / "levels.csv", tmp_path / "summary.csv", tmp_path / "c"
    argv = ["--quick", "--cases", "nanoindentation-190mN", "--sequences", "layers,increments",
            "--cache", str(cache), "--table", str(table), "--summary", str(summary),
            "--plots", str(tmp_path / "plots")]
    assert pipeline.main(argv) == 0
    levels, rows = read(table), read(summary)
    assert tuple(levels[0]) == LEVEL_COLUMNS
    assert tuple(rows[0]) == SUMMARY_COLUMNS
    quantities = {r["quantity"] for r in rows}
    assert {"approach_at_peak_load", "print_depth", "print_depth_refined", "max_plastic_strain",
            "max_plastic_strain_refined", "max_plastic_strain_refined_depth",
            "residual_s11_axis_min", "residual_s11_axis_at_1a", "residual_s11_axis_min_refined",
            "residual_s11_axis_refined_at_1a", "peak_pressure",
            "residual_s33_layer1_axis", "hydrostatic_layer1_extreme"} <= quantities
    assert len(levels) == 3 * len(rows)  # three levels per (sequence, quantity)
    assert len(rows) == 2 * len(quantities)
    by_level = {(r["sequence"], r["level"]): (r["nx"], r["nz"], r["increments"])
                for r in levels}
    assert by_level[("layers", "0")] == ("32", "4", "3")
    assert by_level[("increments", "2")] == ("32", "8", "12")
    print_depth = [r for r in rows if r["quantity"] == "print_depth"]
    assert all(r["behaviour"] in {"monotone", "oscillating", "diverging"} for r in print_depth)
    assert all(float(r["shipped_value"]) > 0.0 for r in print_depth)  # a print, in metres
    # 32 cells: the axis is a cell corner, and the print is deeper there than at any centre
    refined = {(r["sequence"], r["level"]): float(r["value"]) for r in levels
               if r["quantity"] == "print_depth_refined"}
    for r in levels:
        if r["quantity"] == "print_depth":
            assert refined[r["sequence"], r["level"]] > float(r["value"])
    assert sorted(p.name for p in (tmp_path / "plots").iterdir()) == [
        "nanoindentation-190mN-increments-s11.png", "nanoindentation-190mN-increments.png",
        "nanoindentation-190mN-layers-s11.png", "nanoindentation-190mN-layers.png"]
    assert {r["converged"] for r in levels} == {r["converged"] for r in rows} == {"True"}
    cached = sorted(cache.glob("*.json"))
    assert len(cached) == 5  # shipped level shared by both sequences
    record = json.loads(cached[0].read_text(encoding="utf-8"))
    profile, quantities_of_run = record["profile"], record["quantities"]
    assert quantities_of_run["residual_s11_axis_min"] == min(profile["residual_s11"])
    assert len(profile["x3"]) == record["nz"]
    assert isinstance(record["plasticity_iterations"], int)
    assert record["plasticity_iterations"] > 0  # the 190 mN case flows as it is loaded
    assert "plasticity iterations, all steps converged" in capsys.readouterr().out

    # the tables exist: refused without --overwrite; with it, every run comes from the cache
    assert pipeline.main(argv) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert pipeline.main([*argv, "--overwrite"]) == 0
    assert "running" not in capsys.readouterr().out
    assert read(table) == levels
    assert sorted(cache.glob("*.json")) == cached

    # --plan lists the levels, all cached now, and runs nothing
    assert pipeline.main([*argv, "--plan"]) == 0
    plan = capsys.readouterr().out
    assert plan.count("cached") == 7 and "to run" not in plan  # shipped + 2 x 3 levels


def test_quick_check_and_advice(tmp_path, capsys):
    """--check runs the level at step 1/3 of a quick study's sequence (between its levels 1/2
    and 1/4) and writes its comparison; --advise runs nothing and names a discretisation."""
    pipeline = load_pipeline()
    summary, cache = tmp_path / "summary.csv", tmp_path / "c"
    common = ["--quick", "--cases", "nanoindentation-190mN", "--sequences", "layers",
              "--cache", str(cache), "--summary", str(summary)]
    assert pipeline.main([*common, "--table", str(tmp_path / "levels.csv")]) == 0
    runs = len(list(cache.glob("*.json")))
    checked = tmp_path / "check.csv"
    capsys.readouterr()
    # --plan with --check lists the check's level and runs nothing
    assert pipeline.main([*common, "--check", "1/3", "--check-table", str(checked),
                          "--plan"]) == 0
    plan = capsys.readouterr().out
    assert "32² ×  12 layers" in plan and plan.count("to run") == 1
    assert len(list(cache.glob("*.json"))) == runs and not checked.exists()
    assert pipeline.main([*common, "--check", "1/3", "--check-table", str(checked)]) == 0
    rows = read(checked)
    assert rows and tuple(rows[0]) == CHECK_COLUMNS
    assert {(r["nx"], r["nz"]) for r in rows} == {("32", "12")}  # 4 layers / (1/3)
    assert len(list(cache.glob("*.json"))) == runs + 1
    monotone = {r["quantity"] for r in read(summary) if r["behaviour"] == "monotone"}
    assert {r["quantity"] for r in rows} == monotone
    capsys.readouterr()
    assert pipeline.main([*common, "--check", "1/3", "--check-table", str(checked)]) == 2
    assert "--overwrite" in capsys.readouterr().err  # the check table is kept
    assert pipeline.main([*common, "--advise", "--all"]) == 0
    advice = capsys.readouterr().out
    assert "within 0.5 % of the limit" in advice
    assert "residual_s33_layer1_axis" in advice and "nearly) zero" in advice
    assert len(list(cache.glob("*.json"))) == runs + 1  # --advise ran nothing
    with pytest.raises(SystemExit):
        pipeline.main([*common, "--check", "0"])
    assert "(0, 1]" in capsys.readouterr().err
    # the wrong table, or none: one line naming it, no traceback
    assert pipeline.main([*common, "--advise", "--against", str(tmp_path / "levels.csv")]) == 2
    assert "not a summary table" in capsys.readouterr().err
    assert pipeline.main([*common, "--advise", "--against", str(tmp_path / "none.csv")]) == 2
    assert "no summary table" in capsys.readouterr().err


def test_quick_study_at_chosen_steps(tmp_path, capsys):
    """--steps runs a sequence at h = 1, 1/2, 1/3 (not a constant ratio): the levels table
    gives those steps, the summary the finest step and the finest pair's ratio, and its
    limits are those of :func:`extrapolate_steps` through the three levels."""
    pipeline = load_pipeline()
    table, summary = tmp_path / "levels.csv", tmp_path / "summary.csv"
    argv = ["--quick", "--cases", "nanoindentation-190mN", "--sequences", "layers",
            "--cache", str(tmp_path / "c"), "--table", str(table), "--summary", str(summary),
            "--steps", "1,1/2,1/3"]
    assert pipeline.main(argv) == 0
    levels, rows = read(table), read(summary)
    steps = {(r["level"], r["nz"]): float(r["h"]) for r in levels}
    assert steps == {("0", "4"): 1.0, ("1", "8"): 0.5, ("2", "12"): pytest.approx(1 / 3)}
    depth = next(r for r in rows if r["quantity"] == "print_depth")
    values = [float(r["value"]) for r in levels if r["quantity"] == "print_depth"]
    fit = extrapolate_steps(values, [1.0, 1 / 2, 1 / 3], 2.0)
    assert float(depth["ratio"]) == pytest.approx(1.5)
    assert float(depth["finest_step"]) == pytest.approx(1 / 3)
    assert depth["behaviour"] == fit.behaviour
    if fit.behaviour == "monotone":  # both from values written with 10 digits
        assert float(depth["limit"]) == pytest.approx(fit.limit, rel=1e-6)
        assert float(depth["order"]) == pytest.approx(fit.order, rel=1e-6)
    capsys.readouterr()
    with pytest.raises(SystemExit):
        pipeline.main([*argv, "--steps", "1/2,1/2,1/3"])
    assert "decreasing steps" in capsys.readouterr().err


EDGE_SCRIPT = Path(__file__).parent.parent / "pipelines" / "press_edge_position.py"


def load_edge_script():
    return load_script(EDGE_SCRIPT, "press_edge_position")


@pytest.mark.parametrize("share", [1.0, 0.5, 0.25])
def test_the_contact_edge_lies_its_cells_share_beyond_the_inner_face(share):
    """The outermost loaded cell, loaded at ``share`` of the cell inside it, puts the edge that
    share of a cell beyond its inner face; the row is read on either side of the axis alike."""
    module = load_edge_script()
    h = 2e-6
    x = (np.arange(16) - 7.5) * h  # the axis on a cell corner
    pressure = np.zeros((16, 16))
    pressure[3:13, :] = 8e9  # loaded cells out to 5 cells from the axis on each side
    pressure[12, :] = share * 8e9
    pressure[3, :] = share * 8e9
    state = SimpleNamespace(surface={"pressure": pressure}, load_x1=0.0, load_x2=0.0)
    assert module.contact_edge(state, x, x) == pytest.approx((4 + share) * h, rel=1e-12)


def test_the_edge_script_runs_its_windows_and_keeps_a_table(tmp_path, capsys):
    """Two tiny windows give two rows with the study's quantities and the edge's place in its
    cell; a second run does not replace the table, and a grid the press cannot run stops before
    anything runs."""
    module = load_edge_script()
    table = tmp_path / "edge.csv"
    module.main(["--runs", "26:3.0", "26:3.1", "--layers", "8", "--increments", "2", "1",
                 "--table", str(table)])
    rows = list(csv.DictReader(table.open()))
    assert [float(r["half_width"]) for r in rows] == [3.0, 3.1]
    for r in rows:
        assert 0.0 <= float(r["edge_in_cell"]) < 1.0
        cell = float(r["cell"])
        assert float(r["contact_radius"]) / cell % 1.0 == pytest.approx(float(r["edge_in_cell"]))
        assert float(r["print_depth_refined"]) > 0.0
    assert float(rows[1]["cell"]) == pytest.approx(float(rows[0]["cell"]) * 3.1 / 3.0)
    before = table.read_bytes()
    with pytest.raises(SystemExit, match="exists; nothing was changed"):
        module.main(["--runs", "26:3.0", "--table", str(table)])
    with pytest.raises(SystemExit, match="grid.nx"):
        module.main(["--runs", "26:3.0", "24:3.1", "--layers", "8", "--table",
                     str(tmp_path / "other.csv")])
    assert table.read_bytes() == before and not (tmp_path / "other.csv").exists()
    assert "edge at" in capsys.readouterr().out
    assert [int(r["subcells"]) for r in rows] == [1, 1]


def test_the_edge_script_solves_the_contact_on_sub_cells_when_asked(tmp_path):
    module = load_edge_script()
    table = tmp_path / "edge.csv"
    module.main(["--runs", "26:3.0", "--layers", "8", "--increments", "2", "1",
                 "--subcells", "2", "--table", str(table)])
    (row,) = csv.DictReader(table.open())
    assert int(row["subcells"]) == 2
    with pytest.raises(SystemExit, match="solver.contact_subcells"):
        module.main(["--runs", "26:3.0", "--subcells", "5", "--table", str(tmp_path / "x.csv")])
    assert not (tmp_path / "x.csv").exists()


def test_a_refined_count_rounds_up_but_not_past_a_whole_quotient():
    # 15 / (3/11) and 21 / (7/10) come out a hair above 55 and 30 in floats: those, not 56, 31
    assert count_at_step(15, 3 / 11) == 55
    assert count_at_step(21, 7 / 10) == 30
    assert count_at_step(48, 0.311) == 155  # 154.3, rounded up
    assert count_at_step(24, 1.0) == 24
