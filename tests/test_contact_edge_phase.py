"""``pipelines/contact_edge_phase.py``: which edge's phase a scan's zigzag follows."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np
import pytest

from sacflow.errors import SacflowError

ROOT = Path(__file__).resolve().parent.parent
SCAN_COLUMNS = ("case", "nx", "edge_phase", "contact_phase", "approach")


def pipeline():
    """The script as a module (``pipelines/`` is not a package)."""
    sys.path.insert(0, str(ROOT / "pipelines"))
    import contact_edge_phase

    return contact_edge_phase


def write_scan(path: Path, columns: tuple[str, ...] = SCAN_COLUMNS) -> None:
    """A scan whose approach zigzags with a contact 10 % wider than Hertz's (a quarter of the
    window): the Hertz edge's phase is 0 or ½ at every even count, the contact's drifts."""
    counts = np.arange(116, 142, 2)
    hertz, own = 0.25 * counts, 0.275 * counts
    approach = 3.7e-7 + 1e-12 * counts + 5e-12 * np.cos(2 * np.pi * (own - np.round(own)))
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        for n, h, c, a in zip(counts, hertz, own, approach, strict=True):
            writer.writerow({"case": "plastic", "nx": int(n), "edge_phase": h - np.round(h),
                             "contact_phase": c - np.round(c), "approach": a})


def test_the_contact_s_own_edge_explains_the_zigzag_and_the_table_says_so(tmp_path, capsys):
    scan, table = tmp_path / "scan.csv", tmp_path / "fits.csv"
    write_scan(scan)
    assert pipeline().main([str(scan), "--table", str(table)]) == 0
    with table.open(encoding="utf-8") as f:
        rows = {r["edge"]: r for r in csv.DictReader(f)}
    assert set(rows) == {"hertz", "contact"}
    assert int(rows["contact"]["counts"]) == 9  # 120 to 136 in steps of two
    assert float(rows["contact"]["explained"]) > 0.999
    assert float(rows["hertz"]["explained"]) < 0.5
    assert float(rows["contact"]["amplitude"]) == pytest.approx(5e-12, rel=1e-6)
    assert "explained" in capsys.readouterr().out


def test_a_scan_without_the_contact_phase_is_named(tmp_path, capsys):
    scan = tmp_path / "old.csv"
    write_scan(scan, ("case", "nx", "edge_phase", "approach"))
    assert pipeline().main([str(scan)]) == 2
    assert "lacks the column(s) contact_phase" in capsys.readouterr().err


@pytest.mark.parametrize("text, words", [("120", "two whole numbers"),
                                         ("136,120", "not below")])
def test_a_bad_range_is_named(text, words):
    with pytest.raises(SacflowError, match=words):
        pipeline().count_range(text)


def test_an_existing_table_is_not_replaced(tmp_path):
    scan, table = tmp_path / "scan.csv", tmp_path / "fits.csv"
    write_scan(scan)
    table.write_text("the user's own\n")
    with pytest.raises(SystemExit, match="exists; nothing was changed"):
        pipeline().main([str(scan), "--table", str(table)])
    assert table.read_text() == "the user's own\n"


def test_too_few_counts_in_the_range_are_named(tmp_path, capsys):
    scan = tmp_path / "scan.csv"
    write_scan(scan)
    assert pipeline().main([str(scan), "--nx-range", "120,126"]) == 2
    assert "4 counts within --nx-range 120,126" in capsys.readouterr().err
