"""``pipelines/press_load_phases.py``: the press's increments' error split between the halves of
its load.

* the four schedules refine the half of the load they say, and keep the config's unloading;
* the split is additive (what the script's table is read for): at a tiny grid, the error of the
  uniform schedule against the reference is the sum of the two halves' parts, each read as a
  schedule with the other half refined;
* a wrong count stops before anything runs, and a table is never replaced unasked.
"""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).parent.parent / "pipelines" / "press_load_phases.py"
#: A tiny press: 24² × 8 cells, one increment per half (two in a refined one).
TINY = ["--grid", "24", "8", "--increments", "2", "--factor", "2"]
#: Quantities whose parts must add up, and how closely (of the uniform schedule's error): the
#: split neglects the halves' interaction, a higher-order term.
ADDITIVE = ("print_depth_refined", "max_plastic_strain_refined",
            "residual_s11_axis_min_refined", "residual_s11_axis_refined_at_0.5a")
ADDITIVITY = 0.1


def load_script():
    spec = importlib.util.spec_from_file_location("press_load_phases", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(("schedule", "halves"),
                         [("uniform", (2, 2)), ("early", (6, 2)), ("late", (2, 6)),
                          ("reference", (6, 6))])
def test_each_schedule_refines_the_half_it_names(schedule, halves):
    module = load_script()
    case = module.case_for(schedule, 24, 8, 4, 3)
    first, second, unload = case.load_path
    peak = second.to
    assert (first.kind, second.kind, unload.kind) == ("load", "load", "unload")
    assert first.to == pytest.approx(peak / 2.0)
    assert (first.increments, second.increments) == halves
    shipped = module.base_case(module.CASE)
    assert peak == shipped.load_path[0].to
    assert unload.increments == shipped.load_path[-1].increments and unload.to == 0.0
    # as the press ships (cell mean, far traction), its contact on the cells as recorded
    assert case.solver == shipped.solver.model_copy(update={"contact_subcells": 1})
    assert shipped.solver.contact_subcells == 2


@pytest.mark.parametrize(("argv", "message"),
                         [(["--increments", "3"], "even number"),
                          (["--factor", "1"], "refinement of 2 or more"),
                          (["--grid", "16", "8"], "grid.nx")])
def test_a_wrong_count_stops_before_anything_runs(tmp_path, argv, message):
    module = load_script()
    table = tmp_path / "phases.csv"
    with pytest.raises(SystemExit, match=message):
        module.main([*argv, "--table", str(table)])
    assert not table.exists()


def test_the_halves_errors_add_up_and_the_table_is_kept(tmp_path, capsys):
    module = load_script()
    table = tmp_path / "phases.csv"
    module.main([*TINY, "--table", str(table)])
    rows = {r["schedule"]: r for r in csv.DictReader(table.open())}
    assert set(rows) == set(module.SCHEDULES)
    for quantity in ADDITIVE:
        value = {name: float(row[quantity]) for name, row in rows.items()}
        total = value["uniform"] - value["reference"]
        second_half = value["early"] - value["reference"]
        first_half = value["late"] - value["reference"]
        assert abs(total) > 0.0
        assert first_half + second_half == pytest.approx(total, rel=ADDITIVITY), quantity
    before = table.read_bytes()
    with pytest.raises(SystemExit, match="exists; nothing was changed"):
        module.main([*TINY, "--table", str(table)])
    assert table.read_bytes() == before
    assert "reference (2 + 2)" in capsys.readouterr().out


def test_a_table_that_cannot_be_written_stops_before_anything_runs(tmp_path, capsys):
    """A ``--table`` under a file (not a folder) ends in one line before any run; the shared
    CSV writer names such a path too instead of raising an OSError."""
    from sacflow.errors import SacflowError
    from sacflow.studies.convergence_table import write_csv

    module = load_script()
    blocker = tmp_path / "a-file"
    blocker.write_text("the user's file\n")
    with pytest.raises(SystemExit, match="is not a folder this user can write"):
        module.main([*TINY, "--table", str(blocker / "phases.csv")])
    assert capsys.readouterr().out == ""  # nothing ran
    with pytest.raises(SacflowError, match="cannot write the table"):
        write_csv(blocker / "phases.csv", [{"a": 1.0}], ["a"])
    assert blocker.read_text() == "the user's file\n"
