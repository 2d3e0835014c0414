"""The reference data of ``data/`` as the tests read them (one reader, one place)."""

from __future__ import annotations

import csv
from functools import cache
from pathlib import Path

DATA = Path(__file__).resolve().parents[1] / "data"


@cache
def seed_rows() -> dict[str, dict[str, str]]:
    """Rows of ``data/seed_values.csv`` by key (``#`` lines are comments)."""
    with open(DATA / "seed_values.csv", newline="", encoding="utf-8") as f:
        rows = csv.DictReader(line for line in f if not line.startswith("#"))
        return {row["key"]: row for row in rows}


def seed_value(key: str) -> float:
    """A value the seed paper states, in SI units (``data/seed_values.csv``)."""
    return float(seed_rows()[key]["value"])
