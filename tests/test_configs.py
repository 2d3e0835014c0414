"""Every shipped case runs at a tiny grid and reproduces its recorded numbers (issue #15).

The numbers (peak pressure over the load path, approach at maximum load; for plastic bodies the
maximum equivalent plastic strain and the residual print depth at the end) are in one table,
``data/config_regression.csv``, written by ``pipelines/record_config_numbers.py`` with the
:func:`tiny` grid and :func:`measure` of this file. They are the current code's own numbers at
the tiny grid, not the physical (full-grid) values: the table's ``reference`` column gives the
full-grid or closed-form value beside them for a sanity reading. A deliberate physics change is
one command: ``python pipelines/record_config_numbers.py`` (then review the diff of the table).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from sacflow.runner import run_case
from sacflow.storage.case_file import load_case
from sacflow.storage.run_reader import open_run

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = sorted(p for p in (ROOT / "configs").glob("*.toml") if "campaign" not in p.name)
TABLE = ROOT / "data" / "config_regression.csv"
#: Relative tolerance of the regression numbers (issue #15: ±2 %).
RTOL = 0.02


def tiny(path: Path):
    """The case at 16×16 cells (or the smallest grid its checks allow), 4 layers, few steps."""
    case = load_case(path)
    nx = max(16, int(np.ceil(16 * case.grid.half_width / 1.5)))
    return tiny_case(case, nx, 4)


def tiny_case(case, nx: int, nz: int):
    """``case`` on nx × nx cells and nz layers, one increment per load segment, 3 roll steps."""
    segments = []
    for seg in case.load_path:
        if seg.kind == "roll":
            seg = seg.model_copy(update={"steps": 3})
        elif seg.kind in ("load", "unload"):
            seg = seg.model_copy(update={"increments": 1})
        segments.append(seg)
    grid = case.grid.model_copy(update={"nx": nx, "ny": nx, "nz": nz})
    return case.model_copy(update={"grid": grid, "load_path": tuple(segments)})


def measure(path: Path, out: Path) -> tuple[dict[str, float], int, int]:
    """Run ``path`` at the tiny grid into ``out``: its numbers (SI), stored and planned steps.

    ``peak_pressure``: the largest peak pressure of all steps (a rolled dent's passage
    included); ``approach`` at the first step of maximum load; for a plastic body also
    ``max_plastic_strain`` (maximum equivalent plastic strain) and ``print_depth`` (maximum
    residual surface displacement, positive into the body) at the last step.
    """
    case = tiny(path)
    summary = run_case(case, out, progress=False)
    ds = open_run(summary.path)
    loaded = int(np.argmax(ds["load"].values))  # ds.load is Dataset.load()
    numbers = {
        "peak_pressure": float(ds["max_pressure"].max()),
        "approach": float(ds["approach"].values[loaded]),
    }
    if case.body.hardening.law != "elastic":
        numbers["max_plastic_strain"] = float(
            ds["equivalent_plastic_strain"].isel(step=-1).max())
        numbers["print_depth"] = float(ds["residual_displacement"].isel(step=-1).max())
    return numbers, int(ds.sizes["step"]), summary.steps


def recorded() -> dict[str, dict[str, float]]:
    """The table: {config: {quantity: value}}."""
    table: dict[str, dict[str, float]] = {}
    with TABLE.open(encoding="utf-8") as f:
        for row in csv.DictReader(line for line in f if not line.startswith("#")):
            table.setdefault(row["config"], {})[row["quantity"]] = float(row["value"])
    return table


def test_table_covers_every_shipped_config():
    table = recorded()
    assert sorted(table) == sorted(p.stem for p in CONFIGS), "rerun record_config_numbers.py"
    for name, row in table.items():
        assert {"peak_pressure", "approach"} <= set(row), name


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_shipped_config_reproduces_recorded_numbers(path, tmp_path):
    expected = recorded()[path.stem]
    numbers, stored, planned = measure(path, tmp_path)
    assert stored == planned
    assert set(numbers) == set(expected), f"{path.stem}: quantities {sorted(numbers)}"
    for quantity, value in expected.items():
        assert numbers[quantity] == pytest.approx(value, rel=RTOL, abs=0), (
            f"{path.stem} {quantity}: {numbers[quantity]:.6g} vs recorded {value:.6g} "
            f"({numbers[quantity] / value - 1:+.2%}); a deliberate change: "
            "python pipelines/record_config_numbers.py")
