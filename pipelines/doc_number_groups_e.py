"""Groups of ``pipelines/record_doc_numbers.py`` for docs/convergence.md's lateral cells refined
further, each count putting the Hertz contact's edge on a cell boundary: the lateral part of
the limit from the parts (``data/convergence-parts-lateral-fine.csv`` and ``-summary.csv``,
written by
``pipelines/convergence.py``; #32), against the scans at 120–136 cells per side
(``data/convergence-650-lateral-scan.csv``) and the first lateral sequence
(``data/convergence-parts-steps6.csv``); and for the edge the approach's zigzag follows
(``data/contact-edge-phase.csv``, written by ``pipelines/contact_edge_phase.py`` from the scans
of ``pipelines/contact_edge_scan.py``).

Each group is a function of the output folder (unused: the numbers are read from ``data/``)
returning ``{key: value in SI units}``; ``record_doc_numbers.GROUPS`` registers it.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from doc_number_groups_c import CELL_MEAN_CASES, REFINED_QUANTITIES, data_rows  # noqa: E402

from sacflow.studies.richardson import MONOTONE, extrapolate_steps  # noqa: E402

#: The finer lateral sequence's table, and the quantity whose `together` levels it gives a
#: limit through the parts.
FINE, APPROACH = "convergence-parts-lateral-fine", "approach_at_peak_load"
#: The cells per side whose Hertz edge falls on a cell boundary on the ±2 a window (a / Δx is
#: a quarter of the count): the scan's counts that keep the finer sequence's phase.
EDGE_PERIOD = 4
#: The first lateral sequence's finest level (cells per side), also a multiple of four, and the
#: coarsest lateral level both sequences' steps are relative to.
ALTERNATIVE, COARSEST = 192, 32
#: Counts at which the 650 mN contact's own edge falls within a tenth of a cell of one phase
#: (``data/contact-edge-650.csv``): the first from the lateral scan, the others the finer
#: sequence's.
KEPT_PHASE = (120, 160, 200)


def _lateral(table: str, name: str, quantity: str) -> dict[int, float]:
    """One case's lateral levels of ``quantity`` in ``data/{table}.csv``: cells -> value."""
    return {int(r["nx"]): float(r["value"]) for r in data_rows(f"{table}.csv")
            if r["case"] == name and r["sequence"] == "lateral" and r["quantity"] == quantity
            and r["value"]}


def lateral_fine(out: Path) -> dict[str, float]:
    """The finer lateral sequence (128², 160² and 200² cells): per case its approach's order,
    limit and relative uncertainty (``fine_{case}_approach_order``, ``_limit``,
    ``_uncertainty``) and its changes level to level (``fine_{case}_approach_step_{nx}``, to
    ``nx`` cells, SI); for the 650 mN case the reversal of its approach from the first lateral
    sequence's 192² cells to the finer one's 200² relative to the limit
    (``fine_650mN_approach_reversal``), the scan's changes of the approach from one multiple of
    four cells to the next (``fine_650mN_scan_step_{nx}``, SI) and how far the 64² level lies
    above the 120² one (``fine_650mN_base_above_120``, SI); and each quantity's order where
    the finer sequence converges (``fine_{case}_{quantity}_order``); per case, the approach's
    limit through 128², 160² and the first sequence's 192² cells instead of 200², relative to
    the finer sequence's (``fine_{case}_approach_alternative_shift``), where both converge; the
    650 mN approach's limit through the counts that keep its contact's own edge's phase
    (:data:`KEPT_PHASE`) relative to the finer sequence's
    (``fine_650mN_approach_kept_phase_shift``)."""
    numbers: dict[str, float] = {}
    summary = data_rows(f"{FINE}-summary.csv")
    for name, case in CELL_MEAN_CASES.items():
        rows = {r["quantity"]: r for r in summary if r["case"] == name}
        if not rows:
            continue
        for quantity, r in rows.items():
            if r["behaviour"] == "monotone":
                numbers[f"fine_{case}_{quantity}_order"] = float(r["order"])
        approach = rows[APPROACH]
        if approach["behaviour"] == "monotone":
            limit = float(approach["limit"])
            numbers[f"fine_{case}_approach_order"] = float(approach["order"])
            numbers[f"fine_{case}_approach_limit"] = limit
            numbers[f"fine_{case}_approach_uncertainty"] = float(approach["uncertainty"]) / limit
        levels = _lateral(FINE, name, APPROACH)
        cells = sorted(levels)
        other = _lateral("convergence-parts-steps6", name, APPROACH)
        triple = [levels[cells[0]], levels[cells[1]], other[ALTERNATIVE]]
        alternative = extrapolate_steps(triple, [COARSEST / n for n in (*cells[:2], ALTERNATIVE)],
                                        float(approach["formal_order"]))
        if approach["behaviour"] == "monotone" and alternative.behaviour == MONOTONE:
            limit = float(approach["limit"])
            numbers[f"fine_{case}_approach_alternative_shift"] = (alternative.limit - limit) / limit
            numbers[f"fine_{case}_approach_alternative_uncertainty"] = (
                alternative.uncertainty / alternative.limit)
        for coarse, fine in zip(cells, cells[1:], strict=False):
            numbers[f"fine_{case}_approach_step_{fine}"] = levels[fine] - levels[coarse]
    name = next(n for n, c in CELL_MEAN_CASES.items() if c == "650mN")
    rows_650 = {r["quantity"]: r for r in summary if r["case"] == name}
    first = _lateral("convergence-parts-steps6", name, APPROACH)
    fine = _lateral(FINE, name, APPROACH)
    numbers["fine_650mN_approach_reversal"] = (first[192] - fine[200]) / numbers[
        "fine_650mN_approach_limit"]
    scan = {nx: v for nx, v in _lateral("convergence-650-lateral-scan", name, APPROACH).items()
            if nx % EDGE_PERIOD == 0}
    counts = sorted(scan)
    for coarse, finer in zip(counts, counts[1:], strict=False):
        numbers[f"fine_650mN_scan_step_{finer}"] = scan[finer] - scan[coarse]
    numbers["fine_650mN_base_above_120"] = first[64] - scan[min(counts)]
    kept = [scan[KEPT_PHASE[0]], *(fine[n] for n in KEPT_PHASE[1:])]
    other = extrapolate_steps(kept, [COARSEST / n for n in KEPT_PHASE],
                              float(rows_650[APPROACH]["formal_order"]))
    numbers["fine_650mN_approach_kept_phase_shift"] = (
        other.limit - numbers["fine_650mN_approach_limit"]) / numbers["fine_650mN_approach_limit"]
    return numbers | _parts_moved()


def _parts_moved() -> dict[str, float]:
    """The limits from the parts with the first lateral sequence
    (``data/convergence-parts-limits-first-lateral.csv``) against those with the finer one:
    per quantity in both the first's limit and relative uncertainty
    (``fine_{case}_{stem}_first_limit``, ``_first_uncertainty``), the largest distance between
    the two over their uncertainties added (``fine_parts_moved_max``) and how many quantities
    are in both (``fine_parts_in_both``)."""
    first = {(r["case"], r["quantity"]): r
             for r in data_rows("convergence-parts-limits-first-lateral.csv")}
    numbers: dict[str, float] = {}
    moved = []
    for r in data_rows("convergence-parts-limits.csv"):
        old = first.get((r["case"], r["quantity"]))
        case, stem = CELL_MEAN_CASES.get(r["case"]), REFINED_QUANTITIES.get(r["quantity"])
        if old is None or case is None or stem is None:
            continue
        old_limit = float(old["limit"])
        numbers[f"fine_{case}_{stem}_first_limit"] = old_limit
        numbers[f"fine_{case}_{stem}_first_uncertainty"] = float(old["uncertainty"]) / abs(
            old_limit)
        moved.append(abs(float(r["limit"]) - old_limit)
                     / (float(r["uncertainty"]) + float(old["uncertainty"])))
    numbers["fine_parts_moved_max"] = max(moved)
    numbers["fine_parts_in_both"] = float(len(moved))
    return numbers


#: The scans the zigzag's edge is read from, by case: their ``contact-edge-*.csv`` tables.
EDGE_SCANS = {"hertz-elastic": "contact-edge-hertz", "nanoindentation-650mN": "contact-edge-650",
              "nanoindentation-190mN": "contact-edge-190"}
#: The lateral levels whose contact edge's phase the doc quotes (cells per side).
PHASE_LEVELS = (64, 120, 128, 160, 192, 200)


def contact_edge_phase(out: Path) -> dict[str, float]:
    """Which edge the approach's zigzag follows (``pipelines/contact_edge_phase.py``,
    ``data/contact-edge-phase.csv``): per case and edge (``hertz``, ``contact``) the share of
    the spread it explains and the periodic part's amplitude relative to the approach
    (``phase_{case}_{edge}_explained``, ``_amplitude``); per plastic case the contact's radius
    over Hertz's at its finest count (``phase_{case}_radius_ratio``) and its edge's phase at
    the lateral levels (``phase_{case}_level_{nx}``, in cells)."""
    numbers: dict[str, float] = {}
    short = CELL_MEAN_CASES | {"hertz-elastic": "hertz"}
    for r in data_rows("contact-edge-phase.csv"):
        key = f"phase_{short[r['case']]}_{r['edge']}"
        scan = data_rows(f"{EDGE_SCANS[r['case']]}.csv")
        approach = max(float(s["approach"]) for s in scan)
        numbers[f"{key}_explained"] = float(r["explained"])
        numbers[f"{key}_amplitude"] = float(r["amplitude"]) / approach
    for name, table in EDGE_SCANS.items():
        if name not in CELL_MEAN_CASES:
            continue
        scan = {int(s["nx"]): s for s in data_rows(f"{table}.csv")}
        finest = scan[max(scan)]
        case = CELL_MEAN_CASES[name]
        numbers[f"phase_{case}_radius_ratio"] = (float(finest["contact_radius"])
                                                 / float(finest["hertz_radius"]))
        numbers.update({f"phase_{case}_level_{nx}": float(scan[nx]["contact_phase"])
                        for nx in PHASE_LEVELS if nx in scan})
    return numbers


#: The groups of this module: name -> (speed, function of the output folder).
GROUPS = {"lateral_fine": ("fast", lateral_fine),
          "contact_edge_phase": ("fast", contact_edge_phase)}
