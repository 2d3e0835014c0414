"""Groups of ``pipelines/record_doc_numbers.py`` for docs/convergence.md's section on the
shipped configs against the limits of the grid and the window refined
(``data/convergence-certified.csv``, written by ``pipelines/convergence_certify.py``; #32).

Each group is a function of the output folder (unused: the numbers are read from ``data/``)
returning ``{key: value in SI units}``; ``record_doc_numbers.GROUPS`` registers it.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from doc_number_groups_c import CELL_MEAN_CASES, REFINED_QUANTITIES, data_rows  # noqa: E402

#: The certificate's columns recorded: column -> key suffix (the errors and uncertainties
#: relative to the certificate's scale, the value error to the limit itself).
CERTIFIED_COLUMNS = {"shipped_value": "shipped", "limit": "limit", "error": "error",
                     "value_error": "value_error", "relative_uncertainty": "uncertainty"}
#: Columns recorded relative to the certificate's scale: column -> key suffix.
SCALED_COLUMNS = {"window_shift": "window_shift", "transfer": "transfer"}


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
    return numbers


#: The groups of this module: name -> (speed, function of the output folder).
GROUPS = {"convergence_certified": ("fast", convergence_certified)}
