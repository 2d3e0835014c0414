"""``pipelines/contact_edge_scan.py``: a case at several lateral cell counts, the edge's phase."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import pytest

from sacflow.errors import SacflowError
from sacflow.mechanics.hertz import hertz_contact

ROOT = Path(__file__).resolve().parent.parent
HERTZ = ROOT / "configs" / "hertz-elastic.toml"
#: The Hertz config (window ±1.5 a) on a few layers: a / Δx = nx / 3.
TINY = ["grid.nz=4", "solver.fft_threads=1"]


def pipeline():
    """The script as a module (``pipelines/`` is not a package)."""
    sys.path.insert(0, str(ROOT / "pipelines"))
    import contact_edge_scan

    return contact_edge_scan


def test_the_edge_phase_is_the_hertz_radius_in_cells_less_its_nearest_whole_number():
    scan = pipeline()
    hertz = hertz_contact(0.65, 105e-6, 210e9 / (1 - 0.3**2))
    for nx, phase in ((24, 0.0), (26, 26 / 3 - 9), (28, 28 / 3 - 9)):
        row = scan.scan_one(HERTZ, TINY, nx)
        assert row["cell"] == pytest.approx(3.0 * hertz.a / nx, rel=1e-12)
        assert row["edge_phase"] == pytest.approx(phase, abs=1e-9)
        # the loaded cells of the axis row reach the Hertz edge to within a cell
        assert abs(row["edge_cells"] - hertz.a / row["cell"]) <= 1.0
        # the circle of the loaded cells' area is Hertz's to a quarter of a cell, and its phase
        # is read off it as the Hertz edge's
        assert abs(row["contact_radius"] - hertz.a) <= 0.25 * row["cell"]
        in_cells = row["contact_radius"] / row["cell"]
        assert row["contact_phase"] == pytest.approx(in_cells - round(in_cells), abs=1e-12)
        assert abs(row["approach_error"]) < 0.01  # δ = a²/R within 1 % on 8 cells per radius


def test_the_table_has_a_row_per_count(tmp_path: Path, capsys):
    table = tmp_path / "scan.csv"
    assert pipeline().main([str(HERTZ), *TINY, "--nx", "12,14", "--table", str(table)]) == 0
    with table.open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["nx"]) for r in rows] == [12, 14]
    assert "nx   12" in capsys.readouterr().out


@pytest.mark.parametrize("text, words", [("12,x", "'x' is not a whole number"),
                                         ("2", "too few")])
def test_a_bad_cell_count_is_named(text, words):
    with pytest.raises(SacflowError, match=words):
        pipeline().cell_counts(text)


def test_an_existing_table_stops_the_scan_before_it_runs(tmp_path: Path, capsys):
    table = tmp_path / "scan.csv"
    table.write_text("the user's own\n")
    with pytest.raises(SystemExit, match="exists; nothing was changed"):
        pipeline().main([str(HERTZ), *TINY, "--nx", "12", "--table", str(table)])
    assert "nx   12" not in capsys.readouterr().out  # nothing ran
    assert table.read_text() == "the user's own\n"


def test_on_sub_cells_the_contact_s_radius_is_that_of_the_loaded_sub_cells():
    """With the contact on 2 × 2 sub-cells a cell is loaded when any of its sub-cells is: the
    circle of the loaded cells would be too wide, that of the sub-cells' area is Hertz's to a
    tenth of a cell at 8 cells per radius (0.14 of a cell on the cells themselves)."""
    scan = pipeline()
    hertz = hertz_contact(0.65, 105e-6, 210e9 / (1 - 0.3**2))
    row = scan.scan_one(HERTZ, [*TINY, "solver.contact_subcells=2"], 24)
    assert abs(row["contact_radius"] - hertz.a) <= 0.1 * row["cell"]
