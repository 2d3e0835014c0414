"""Groups of ``pipelines/record_doc_numbers.py`` for docs/convergence.md's section on the
shipped configs against the limits of the grid and the window refined
(``data/convergence-certified.csv``, written by ``pipelines/convergence_certify.py``; #32), and
for the press's increments split between the halves of its load
(``data/press-load-phases.csv``, written by ``pipelines/press_load_phases.py``), and for its
pressure at the peak load on sub-cells (``data/press-pressure-profile.csv`` and ``-rows.csv``,
written by ``pipelines/press_pressure_profile.py``), and for the shape of its largest εp
(``data/press-plastic-peak.csv``, written by ``pipelines/press_plastic_peak.py``), and for where
its lateral cells' error lies (``data/press-lateral-error-split-*.csv``, written by
``pipelines/press_lateral_error_split.py``), and for the
solver's tolerances' share of the 650 mN `together` levels' changes
(``data/convergence-650-tolerances.csv`` against ``data/convergence-650-steps6.csv``).

Each group is a function of the output folder (unused: the numbers are read from ``data/``)
returning ``{key: value in SI units}``; ``record_doc_numbers.GROUPS`` registers it.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from doc_number_groups_c import CELL_MEAN_CASES, REFINED_QUANTITIES, data_rows  # noqa: E402

from sacflow.studies.certify import transfer  # noqa: E402

#: The certificate's columns recorded: column -> key suffix (the errors and uncertainties
#: relative to the certificate's scale, the value error to the limit itself).
CERTIFIED_COLUMNS = {"shipped_value": "shipped", "limit": "limit", "error": "error",
                     "value_error": "value_error", "relative_uncertainty": "uncertainty"}
#: Columns recorded relative to the certificate's scale: column -> key suffix.
SCALED_COLUMNS = {"window_shift": "window_shift", "transfer": "transfer"}
#: The lateral refinement "Where the press flows" prices: twice the cells along x1 and x2.
LATERAL_REFINEMENT = 2
#: The 650 mN case's window sequence at the study's base grid, without and with the traction
#: beyond the box (their shipped level is the config's grid): the transfer measured for the
#: case whose certificate has none (its window sequence runs at its shipped grid).
BASE_650 = ("convergence-window-650-base", "convergence-window-650-base-far")


def convergence_certified(out: Path) -> dict[str, float]:
    """Each row of ``data/convergence-certified.csv`` (``cert_{case}_{stem}_{suffix}``), and
    per case the largest |error| over the quantities within the target
    (``cert_{case}_largest_within``) and the largest transfer over its scale
    (``cert_{case}_largest_transfer``); over all cases the count of each verdict
    (``cert_count_within``, ``cert_count_outside``, ``cert_count_no_limit``) and of those with
    a limit (``cert_count_with_limit``)."""
    numbers: dict[str, float] = {"cert_count_within": 0.0, "cert_count_outside": 0.0,
                                 "cert_count_no_limit": 0.0}
    for r in data_rows("convergence-certified.csv"):
        case, stem = CELL_MEAN_CASES.get(r["case"]), REFINED_QUANTITIES.get(r["quantity"])
        if case is None or stem is None:
            continue
        key = f"cert_{case}_{stem}"
        numbers[f"cert_count_{r['verdict'].replace(' ', '_')}"] += 1.0
        numbers.update({f"{key}_{suffix}": float(r[column])
                        for column, suffix in CERTIFIED_COLUMNS.items() if r[column]})
        scale = float(r["scale"])
        numbers.update({f"{key}_{suffix}": float(r[column]) / scale
                        for column, suffix in SCALED_COLUMNS.items() if r[column]})
        if r["verdict"] == "within":
            name = f"cert_{case}_largest_within"
            numbers[name] = max(numbers.get(name, 0.0), abs(float(r["error"])))
        if r["transfer"] and math.isfinite(float(r["transfer"])):
            name = f"cert_{case}_largest_transfer"
            numbers[name] = max(numbers.get(name, 0.0), float(r["transfer"]) / scale)
    numbers["cert_count_with_limit"] = numbers["cert_count_within"] + numbers["cert_count_outside"]
    numbers["cert_650mN_base_transfer_max"] = _base_transfer()
    return numbers | _option_changes()


def _option_changes() -> dict[str, float]:
    """Per case and quantity, the change removing the traction beyond the box makes at the
    shipped grid (``cert_{case}_{stem}_far_shipped``) and at the window sequence's first level
    (``_far_window``), in SI units (``pipelines/convergence_certify.py``'s ``option_changes``)."""
    import convergence_certify

    numbers: dict[str, float] = {}
    for name, sources in convergence_certify.SOURCES.items():
        case = CELL_MEAN_CASES.get(name)
        for quantity, change in convergence_certify.option_changes(name, sources).items():
            stem = REFINED_QUANTITIES.get(quantity)
            if case is None or stem is None:
                continue
            numbers[f"cert_{case}_{stem}_far_shipped"] = change.at_shipped
            numbers[f"cert_{case}_{stem}_far_window"] = change.at_window
    return numbers


def _base_transfer() -> float:
    """Largest |d_s − d_b| / scale over the 650 mN case's certified quantities: the change the
    traction beyond the box makes at the shipped grid (d_s) against the study's base grid (d_b),
    from the window sequences of :data:`BASE_650`."""
    (off, on) = ({r["quantity"]: r for r in data_rows(f"{name}-summary.csv")} for name in BASE_650)
    (first_off, first_on) = ({r["quantity"]: float(r["value"]) for r in data_rows(f"{name}.csv")
                              if r["level"] == "0" and r["value"]} for name in BASE_650)
    largest = 0.0
    for r in data_rows("convergence-certified.csv"):
        q = r["quantity"]
        if r["case"] != "nanoindentation-650mN" or q not in first_off or q not in first_on:
            continue
        moved = transfer(float(on[q]["shipped_value"]), float(off[q]["shipped_value"]),
                         first_on[q], first_off[q])
        largest = max(largest, moved / float(r["scale"]))
    return largest


def press_load_phases(out: Path) -> dict[str, float]:
    """Each schedule's quantities of ``data/press-load-phases.csv``
    (``phases_{schedule}_{stem}``) and their error against the reference schedule, relative to
    it (``_error``): the early and late schedules' errors are the second and the first half's
    parts of the uniform schedule's (``pipelines/press_load_phases.py``)."""
    rows = {r["schedule"]: r for r in data_rows("press-load-phases.csv")}
    numbers: dict[str, float] = {}
    for quantity, stem in REFINED_QUANTITIES.items():
        if quantity not in rows["reference"]:
            continue
        reference = float(rows["reference"][quantity])
        for schedule, row in rows.items():
            value = float(row[quantity])
            numbers[f"phases_{schedule}_{stem}"] = value
            numbers[f"phases_{schedule}_{stem}_error"] = (value - reference) / reference
    return numbers


def press_pressure_profile(out: Path) -> dict[str, float]:
    """Per run of ``data/press-pressure-profile.csv`` (``profile_{nx}_...``): the largest cell
    pressure, its radius over the contact's and its distance inside the edge in cells, the
    contact radius, the splines' largest difference from the cuboids' displacement, each
    displacement's sub-cell alternation and the change of the largest cell pressure on the
    cuboids' displacement, relative; from ``-rows.csv`` the cells' pressure nearest the axis."""
    numbers: dict[str, float] = {}
    for r in data_rows("press-pressure-profile.csv"):
        key, value = f"profile_{r['nx']}", {k: float(v) for k, v in r.items()}
        numbers.update({
            f"{key}_peak_pressure": value["peak_pressure"],
            f"{key}_peak_fraction": value["peak_radius"] / value["contact_radius"],
            f"{key}_peak_inside_cells": (value["contact_radius"] - value["peak_radius"])
            / value["cell"],
            f"{key}_contact_radius": value["contact_radius"],
            f"{key}_splines_minus_cuboids": value["splines_minus_cuboids_max"],
            f"{key}_sawtooth_splines": value["sawtooth_splines"],
            f"{key}_sawtooth_cuboids": value["sawtooth_cuboids"],
            f"{key}_cuboids_peak_change": value["peak_pressure_cuboids"]
            / value["peak_pressure_splines"] - 1.0})
    for r in data_rows("press-pressure-profile-rows.csv"):
        name = f"profile_{r['nx']}_axis_pressure"
        if r["source"] == "cells" and name not in numbers:
            numbers[name] = float(r["pressure"])
    return numbers


def press_plastic_peak(out: Path) -> dict[str, float]:
    """Each row of ``data/press-plastic-peak.csv`` (``plastic_peak_{quantity}``): the shape of
    the shipped press's largest εp, written by ``pipelines/press_plastic_peak.py``; and of
    ``data/press-plastic-peak-increments20.csv`` (``plastic_peak_increments20_{quantity}``), the
    same with the 20 + 6 increments it shipped before. With the extent of the flow, its half
    width and depth over the box's (``plastic_peak_half_width_over_box``,
    ``plastic_peak_depth_over_box``) and the cells, in boxes, of twice the lateral cells over
    the sub-box that holds it and the box's own cells elsewhere (``plastic_peak_subbox_cells``)."""
    numbers = {f"plastic_peak_{prefix}{r['quantity']}": float(r["value"])
               for prefix, name in (("", "press-plastic-peak.csv"),
                                    ("increments20_", "press-plastic-peak-increments20.csv"))
               for r in data_rows(name)}
    share = numbers["plastic_peak_plastic_subbox_volume_share"]
    numbers.update(
        plastic_peak_half_width_over_box=(numbers["plastic_peak_plastic_half_width"]
                                          / numbers["plastic_peak_box_half_width"]),
        plastic_peak_depth_over_box=(numbers["plastic_peak_plastic_depth"]
                                     / numbers["plastic_peak_box_depth"]),
        plastic_peak_subbox_cells=LATERAL_REFINEMENT**2 * share + (1.0 - share))
    return numbers


#: The press's lateral refinements split (``pipelines/press_lateral_error_split.py``): key ->
#: table (the coarse and fine cells per side; ``inc40``: with 40 + 12 increments; ``inc_N``:
#: 20 + 6 against 40 + 12 increments on N² cells).
SPLIT_TABLES = {"48_96": "press-lateral-error-split-48-96.csv",
                "48_144": "press-lateral-error-split-48-144.csv",
                "72_144": "press-lateral-error-split-72-144.csv",
                "48_96_inc40": "press-lateral-error-split-48-96-inc40.csv",
                "inc_48": "press-increments-error-split-48.csv",
                "inc_96": "press-increments-error-split-96.csv"}


def press_lateral_error_split(out: Path) -> dict[str, float]:
    """Per table of :data:`SPLIT_TABLES` (``split_{key}_...``) and profile depth: the σ11 on
    the axis of each run, their difference (``_change_``) and each part of it
    (``_{part}_{depth}``, depth as ``05a``); per region ``r{from}_{to}_z{from}_{to}`` (Hertz
    radii, ``inf`` unbounded) its flow part, its εp change summed over its volume, the change
    of largest magnitude and the coarse εp there; and the same summed or largest over the
    bands of :func:`_split_bands` (``_core_...``, ``_edge_...``)."""
    numbers: dict[str, float] = {}
    for tag, name in SPLIT_TABLES.items():
        key = f"split_{tag}"
        for r in data_rows(name):
            profile = {c.removeprefix("s11_at_").replace(".", ""): float(v)
                       for c, v in r.items() if c.startswith("s11_at_") and v}
            if r["part"] != "flow_region":
                numbers.update({f"{key}_{r['part']}_{d}": v for d, v in profile.items()})
                if r["part"] == "fine":
                    numbers.update({f"{key}_change_{d}": v - numbers[f"{key}_coarse_{d}"]
                                    for d, v in profile.items()})
                continue
            bounds = [f"{float(r[c]):g}" for c in ("r_from", "r_to", "z_from", "z_to")]
            region = "r{}_{}_z{}_{}".format(*bounds).replace(".", "")
            numbers.update({f"{key}_{region}_{d}": v for d, v in profile.items()})
            for column in ("strain_change_volume", "largest_strain_change", "strain_there"):
                numbers[f"{key}_{region}_{column}"] = float(r[column])
            for band, inside in _split_bands(r).items():
                if not inside:
                    continue
                for d, v in profile.items():
                    numbers[f"{key}_{band}_{d}"] = numbers.get(f"{key}_{band}_{d}", 0.0) + v
                name = f"{key}_{band}_largest_strain_change"
                if abs(float(r["largest_strain_change"])) > abs(numbers.get(name, 0.0)):
                    numbers[name] = float(r["largest_strain_change"])
                    numbers[f"{key}_{band}_strain_there"] = float(r["strain_there"])
    return numbers


def _split_bands(row: dict[str, str]) -> dict[str, bool]:
    """Whether a region of the split lies under the axis (``core``: r < 0.5 a, every depth) or
    in the surface band at the contact's edge (``edge``: a ≤ r < 1.5 a, x3 < 0.25 a)."""
    r_from, r_to, z_to = (float(row[c]) for c in ("r_from", "r_to", "z_to"))
    return {"core": r_to <= 0.5, "edge": r_from >= 1.0 and r_to <= 1.5 and z_to <= 0.25}


#: The 650 mN `together` levels with tight tolerances, and the same levels with the defaults.
TOLERANCE_TABLES = ("convergence-650-tolerances.csv", "convergence-650-steps6.csv")


def convergence_tolerances(out: Path) -> dict[str, float]:
    """Per quantity, the largest change the tight tolerances make over the levels both tables
    hold: relative to the default run's value (``tol650_{stem}_largest``), in the quantity's
    unit (``tol650_{stem}_largest_absolute``) and, for the σ11 on the axis, relative to the
    largest magnitude of its profile, the finest common level's minimum σ11 on the axis
    (``tol650_{stem}_largest_scaled``)."""
    tight, default = ({(r["level"], r["quantity"]): float(r["value"])
                       for r in data_rows(name) if r["value"]} for name in TOLERANCE_TABLES)
    common = sorted(key for key in tight if key in default)
    finest = max(int(level) for level, _ in common)
    scale = abs(default[(str(finest), "residual_s11_axis_min_refined")])
    numbers: dict[str, float] = {}
    for level, quantity in common:
        stem = REFINED_QUANTITIES.get(quantity)
        if stem is None:
            continue
        change = abs(tight[(level, quantity)] - default[(level, quantity)])
        sizes = {"largest": change / abs(default[(level, quantity)]), "largest_absolute": change}
        if quantity.startswith("residual_s11_axis"):
            sizes["largest_scaled"] = change / scale
        for suffix, size in sizes.items():
            key = f"tol650_{stem}_{suffix}"
            numbers[key] = max(numbers.get(key, 0.0), size)
    return numbers


#: The press's shipped value with the traction beyond the box removed before its increments were
#: doubled (96² × 128 cells, 20 + 6 increments), and the levels of its increments sequence at
#: the shipped grid (without that traction) whose 20 + 6 and 40 + 12 levels predicted the
#: doubling (docs/convergence.md, "The press's increments doubled").
PRESS_SHIPPED_BEFORE = "convergence-press-shipped-subcell-stress-far-summary.csv"
PRESS_INCREMENTS = ("convergence-press-subcell-stress-increments.csv", "increments", 0, 2)


def press_increments_doubled(out: Path) -> dict[str, float]:
    """Per certified quantity of the press (``doubled_{stem}_``), its error against the
    certified limit as it shipped with 20 + 6 increments (``before``), as predicted for 40 + 12
    from its increments sequence's levels plus the change removing the traction beyond the box
    made at 20 + 6 (``predicted``), and as it ships with 40 + 12 (``after``), each relative to
    the certificate's scale; that change of the largest εp's depth at 20 + 6
    (``doubled_max_eqps_refined_depth_far_before``, in metres); and the largest |after −
    predicted| over the quantities but that depth (``doubled_largest_miss_but_depth``)."""
    import convergence_certify

    from sacflow.studies.certify import level_values

    case = "dent-from-indentation-press"
    table, sequence, first, doubled = PRESS_INCREMENTS
    levels = [level_values(convergence_certify.DATA / table, case, sequence, level)
              for level in (first, doubled)]
    before = {r["quantity"]: float(r["shipped_value"])
              for r in data_rows(PRESS_SHIPPED_BEFORE) if r["shipped_value"]}
    numbers: dict[str, float] = {}
    for c in convergence_certify.certificates(case, convergence_certify.SOURCES[case]):
        stem = REFINED_QUANTITIES[c.quantity]
        far_before = before[c.quantity] - levels[0][c.quantity]
        predicted = levels[1][c.quantity] + far_before
        for suffix, value in (("before", before[c.quantity]), ("predicted", predicted),
                              ("after", c.shipped_value)):
            numbers[f"doubled_{stem}_{suffix}"] = (value - c.limit) / c.scale
        if stem == "max_eqps_refined_depth":
            numbers["doubled_max_eqps_refined_depth_far_before"] = far_before
        else:
            miss = abs(c.shipped_value - predicted) / c.scale
            numbers["doubled_largest_miss_but_depth"] = max(
                numbers.get("doubled_largest_miss_but_depth", 0.0), miss)
    return numbers


#: ``data/press-flow-points.csv``'s quantities in docs/convergence.md -> key stem.
FLOW_POINTS = {"print_depth_refined": "print_depth", "peak_pressure": "peak_pressure",
               "max_plastic_strain_refined": "max_eqps",
               "residual_s11_axis_min_refined": "min_s11",
               "residual_s11_axis_refined_at_0.5a": "s11_0.5a",
               "residual_s11_axis_refined_at_1.5a": "s11_1.5a"}


def press_flow_points(out: Path) -> dict[str, float]:
    """``pipelines/press_flow_points.py``'s four runs (``data/press-flow-points.csv`` and
    ``-averaged.csv``): the 96² cells' values (``flow_points_fine_{stem}``), the others relative
    to them (``flow_points_{coarse,points,averaged}_{stem}``); the largest εp over the 48²
    cells' footprints (``_max_eqps_coarse_cells``: the coarse run's cells, the others' 2 × 2
    block means); each run's plasticity iterations; the largest εp of a point and of a block
    of the ``points`` run (``flow_points_points_max_eqps_cell``, ``_block``); its iterations
    over the 96² cells' (``flow_points_iterations_ratio``). The ``averaged`` run's σ11 on the
    axis at 0.5 a and 1.5 a as it reads it and read through the 48² cells' operator
    (``flow_points_read_{own,coarse}_s11_{depth}``, ``data/press-flow-points-averaged-read.csv``),
    their difference (``_reading_``), and at 0.5 a its distance from the 96² cells' value split
    into the 48² cells' own error (``_coarse_error_``) and that of the strain (``_strain_``)."""
    rows = {row["variant"]: row for name in ("press-flow-points.csv",
                                             "press-flow-points-averaged.csv")
            for row in data_rows(name)}
    fine = rows["fine"]
    numbers: dict[str, float] = {}
    for quantity, stem in FLOW_POINTS.items():
        numbers[f"flow_points_fine_{stem}"] = float(fine[quantity])
        for variant in ("coarse", "points", "averaged"):
            numbers[f"flow_points_{variant}_{stem}"] = (float(rows[variant][quantity])
                                                        / float(fine[quantity]) - 1.0)
    # the largest εp over the 48² cells' footprints: the coarse run's own cells, the others'
    # 2 × 2 block means
    coarse_cells = {"coarse": float(rows["coarse"]["max_plastic_strain"]),
                    **{v: float(rows[v]["max_plastic_strain_block_mean"])
                       for v in ("points", "averaged", "fine")}}
    numbers["flow_points_fine_max_eqps_coarse_cells"] = coarse_cells["fine"]
    for variant in ("coarse", "points", "averaged"):
        numbers[f"flow_points_{variant}_max_eqps_coarse_cells"] = (coarse_cells[variant]
                                                                   / coarse_cells["fine"] - 1.0)
    for variant, row in rows.items():
        numbers[f"flow_points_{variant}_iterations"] = float(row["plasticity_iterations"])
    numbers["flow_points_points_max_eqps_cell"] = float(rows["points"]["max_plastic_strain"])
    numbers["flow_points_points_max_eqps_block"] = coarse_cells["points"]
    numbers["flow_points_iterations_ratio"] = (numbers["flow_points_points_iterations"]
                                               / numbers["flow_points_fine_iterations"])
    # the averaged run's σ11 on the axis read through the 48² cells' operator
    # (data/press-flow-points-averaged-read.csv), split against the fine and coarse runs
    (read,) = data_rows("press-flow-points-averaged-read.csv")
    for depth in ("0.5a", "1.5a"):
        own = float(read[f"residual_s11_axis_refined_at_{depth}"])
        coarse_read = float(read[f"coarse_read_s11_axis_refined_at_{depth}"])
        numbers[f"flow_points_read_own_s11_{depth}"] = own
        numbers[f"flow_points_read_coarse_s11_{depth}"] = coarse_read
        numbers[f"flow_points_read_reading_s11_{depth}"] = own - coarse_read
    fine_s11 = float(fine["residual_s11_axis_refined_at_0.5a"])
    coarse_s11 = float(rows["coarse"]["residual_s11_axis_refined_at_0.5a"])
    numbers["flow_points_read_distance_s11_0.5a"] = (numbers["flow_points_read_own_s11_0.5a"]
                                                     - fine_s11)
    numbers["flow_points_read_coarse_error_s11_0.5a"] = coarse_s11 - fine_s11
    numbers["flow_points_read_strain_s11_0.5a"] = (numbers["flow_points_read_coarse_s11_0.5a"]
                                                   - coarse_s11)
    return numbers


#: The parts table's columns recorded relative to the limit from the parts: column -> suffix.
PARTS_RELATIVE = {"uncertainty": "uncertainty", "parts_uncertainty": "parts_uncertainty",
                  "misfit": "misfit", "lateral_share": "lateral_share",
                  "layers_share": "layers_share", "increments_share": "increments_share"}


def convergence_parts(out: Path) -> dict[str, float]:
    """Each row of ``data/convergence-parts-limits.csv`` (``parts_{case}_{stem}_...``): the
    limit the one-at-a-time sequences give (``_limit``, SI), its uncertainties, misfit and the
    parts' shares of the base's error relative to it (:data:`PARTS_RELATIVE`), and, where the
    `together` sequence has a limit of its own, that limit (``_together_limit``) and its relative
    uncertainty, how far the parts' lies from it relative to it (``_vs_together``) and that
    distance over the two uncertainties added (``_vs_together_spread``; its largest,
    ``parts_vs_together_spread_max``)."""
    numbers: dict[str, float] = {}
    for r in data_rows("convergence-parts-limits.csv"):
        case, stem = CELL_MEAN_CASES.get(r["case"]), REFINED_QUANTITIES.get(r["quantity"])
        if case is None or stem is None:
            continue
        key, limit = f"parts_{case}_{stem}", float(r["limit"])
        numbers[f"{key}_limit"] = limit
        numbers.update({f"{key}_{suffix}": float(r[column]) / abs(limit)
                        for column, suffix in PARTS_RELATIVE.items()})
        if r["together_behaviour"] == "monotone":
            own = float(r["together_limit"])
            numbers[f"{key}_together_limit"] = own
            numbers[f"{key}_together_uncertainty"] = float(r["together_uncertainty"]) / abs(own)
            numbers[f"{key}_vs_together"] = (limit - own) / abs(own)
            numbers[f"{key}_vs_together_spread"] = abs(limit - own) / (
                float(r["uncertainty"]) + float(r["together_uncertainty"]))
    numbers["parts_vs_together_spread_max"] = max(
        v for k, v in numbers.items() if k.endswith("_vs_together_spread"))
    return numbers


#: The certified quantities whose lateral zigzag ``contact_edge`` records: quantity -> stem.
EDGE_QUANTITIES = {q: REFINED_QUANTITIES[q] for q in (
    "approach_at_peak_load", "print_depth_refined", "max_plastic_strain_refined",
    "max_plastic_strain_refined_depth", "residual_s11_axis_min_refined",
    "residual_s11_axis_refined_at_0.25a", "residual_s11_axis_refined_at_0.5a",
    "residual_s11_axis_refined_at_1a", "residual_s11_axis_refined_at_1.5a",
    "residual_s11_axis_refined_at_2a", "peak_pressure")}
#: Neighbouring even counts of surface cells the zigzag compares (cells per side).
EDGE_NEIGHBOUR = 2


def _zigzag(values: dict[int, float]) -> float:
    """Largest |f(n) − (f(n − 2) + f(n + 2)) / 2| over the counts n with both neighbours: a
    smooth error of the cell size gives a second difference of order Δx² beside it."""
    return max((abs(v - 0.5 * (values[n - EDGE_NEIGHBOUR] + values[n + EDGE_NEIGHBOUR]))
                for n, v in values.items()
                if n - EDGE_NEIGHBOUR in values and n + EDGE_NEIGHBOUR in values), default=math.nan)


def _lateral_zigzag(case: str, name: str) -> dict[str, float]:
    """One case's zigzag per certified quantity at 120–136 cells per side
    (``data/convergence-{case}-lateral-scan.csv``) and its lateral sequence's change from 128²
    to 192² cells (``data/convergence-parts-steps6.csv``), both over the certificate's scale:
    ``edge_{case}_zigzag_{stem}`` and ``edge_{case}_step_{stem}``."""
    scale = {r["quantity"]: float(r["scale"]) for r in data_rows("convergence-certified.csv")
             if r["case"] == name}
    scan: dict[str, dict[int, float]] = {}
    for r in data_rows(f"convergence-{case}-lateral-scan.csv"):
        if r["quantity"] in EDGE_QUANTITIES and r["value"]:
            scan.setdefault(r["quantity"], {})[int(r["nx"])] = float(r["value"])
    lateral: dict[str, dict[int, float]] = {}
    for r in data_rows("convergence-parts-steps6.csv"):
        if (r["case"] == name and r["sequence"] == "lateral"
                and r["quantity"] in EDGE_QUANTITIES and r["value"]):
            lateral.setdefault(r["quantity"], {})[int(r["nx"])] = float(r["value"])
    numbers: dict[str, float] = {}
    for quantity, stem in EDGE_QUANTITIES.items():
        if quantity not in scale or quantity not in scan:
            continue
        numbers[f"edge_{case}_zigzag_{stem}"] = _zigzag(scan[quantity]) / scale[quantity]
        numbers[f"edge_{case}_step_{stem}"] = (lateral[quantity][192]
                                               - lateral[quantity][128]) / scale[quantity]
    return numbers


def contact_edge(out: Path) -> dict[str, float]:
    """The contact's edge within its cells (``pipelines/contact_edge_scan.py``,
    ``pipelines/convergence.py``): the elastic Hertz scan's approach error against δ = a²/R,
    smallest and largest (``edge_hertz_error_min``, ``_max``) and its largest zigzag relative
    to δ (``edge_hertz_zigzag``), the same with the contact on 2 × 2 sub-cells
    (``edge_hertz_subcells_zigzag``); the 650 mN case's loaded cells against the Hertz radius in
    cells per count (``edge_650_cells_{nx}``, ``edge_650_hertz_cells_{nx}``); its lateral scan's
    zigzag per certified quantity relative to the certificate's scale
    (``edge_650_zigzag_{stem}``, and the 190 mN case's, ``edge_190_...``) and the largest
    (``edge_650_zigzag_max``); and each quantity's change from 128² to 192² cells of the
    one-at-a-time lateral sequence, on the same scale (``edge_650_step_{stem}``,
    ``edge_190_step_{stem}``: :func:`_lateral_zigzag`), and per case that change over the
    zigzag: its largest among the quantities whose lateral sequence turns
    (``edge_650_ratio_turn_max``, ``edge_190_...``), its smallest among those whose sequence
    converges (``edge_650_ratio_converge_min``, ``edge_190_...``)."""
    hertz = data_rows("contact-edge-hertz.csv")
    errors = {int(r["nx"]): float(r["approach_error"]) for r in hertz}
    exact = float(hertz[0]["approach"]) / (1.0 + float(hertz[0]["approach_error"]))
    numbers = {"edge_hertz_error_min": min(errors.values()),
               "edge_hertz_error_max": max(errors.values()),
               "edge_hertz_zigzag": _zigzag({int(r["nx"]): float(r["approach"]) for r in hertz})
               / exact,
               "edge_hertz_subcells_zigzag": _zigzag(
                   {int(r["nx"]): float(r["approach"])
                    for r in data_rows("contact-edge-hertz-subcells.csv")}) / exact}
    for r in data_rows("contact-edge-650.csv"):
        numbers[f"edge_650_cells_{r['nx']}"] = float(r["edge_cells"])
        numbers[f"edge_650_hertz_cells_{r['nx']}"] = float(r["hertz_radius"]) / float(r["cell"])
    for case, name in (("650", "nanoindentation-650mN"), ("190", "nanoindentation-190mN")):
        numbers.update(_lateral_zigzag(case, name))
    numbers["edge_650_zigzag_max"] = max(numbers[f"edge_650_zigzag_{stem}"]
                                         for stem in EDGE_QUANTITIES.values())
    summary = data_rows("convergence-parts-steps6-summary.csv")
    for case, name in (("650", "nanoindentation-650mN"), ("190", "nanoindentation-190mN")):
        behaviour = {r["quantity"]: r["behaviour"] for r in summary
                     if r["case"] == name and r["sequence"] == "lateral"}
        ratios = {q: abs(numbers[f"edge_{case}_step_{s}"]) / numbers[f"edge_{case}_zigzag_{s}"]
                  for q, s in EDGE_QUANTITIES.items() if f"edge_{case}_step_{s}" in numbers}
        numbers[f"edge_{case}_ratio_turn_max"] = max(r for q, r in ratios.items()
                                                     if behaviour[q] != "monotone")
        numbers[f"edge_{case}_ratio_converge_min"] = min(r for q, r in ratios.items()
                                                         if behaviour[q] == "monotone")
    return numbers


#: The groups of this module: name -> (speed, function of the output folder).
GROUPS = {"convergence_certified": ("fast", convergence_certified),
          "convergence_parts": ("fast", convergence_parts),
          "contact_edge": ("fast", contact_edge),
          "press_increments_doubled": ("fast", press_increments_doubled),
          "press_load_phases": ("fast", press_load_phases),
          "press_pressure_profile": ("fast", press_pressure_profile),
          "press_plastic_peak": ("fast", press_plastic_peak),
          "press_flow_points": ("fast", press_flow_points),
          "press_lateral_error_split": ("fast", press_lateral_error_split),
          "convergence_tolerances": ("fast", convergence_tolerances)}
