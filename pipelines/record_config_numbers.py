"""Record the regression numbers of every shipped case at its tiny test grid.

    python pipelines/record_config_numbers.py [--check] [--only NAME ...]

Runs each ``configs/*.toml`` (except the campaign) at the tiny grid of ``tests/test_configs.py``
(:func:`tiny`, :func:`measure`: the very code the test runs) and rewrites
``data/config_regression.csv``: one row per case and quantity with the value (SI), a reference
value where one exists (closed-form Hertz, the shipped full grid or the seed paper) with its
source, and how the row was obtained (command, commit, date, grid). ``--check`` prints the
relative change against the table without writing it; ``--only NAME`` (repeatable) runs and
rewrites the rows of those configs only (a new config), keeping every other row as it is. Run
this after a deliberate physics change and review the table's diff; the test
(``pytest tests/test_configs.py``) reads the table and allows ±2 %.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from test_configs import CONFIGS, TABLE, measure, recorded, tiny  # noqa: E402

UNITS = {"peak_pressure": "Pa", "approach": "m", "max_plastic_strain": "1", "print_depth": "m"}
#: Full-grid or seed values, for a sanity reading of the tiny-grid numbers (not asserted).
REFERENCES = {
    ("nanoindentation-650mN", "print_depth"): (
        81.3e-9, "shipped grid 80x80x48 (pytest -m reference); seed Sec. 3.2: about 80 nm"),
    ("nanoindentation-650mN", "max_plastic_strain"): (0.015, "seed Sec. 3.2: about 1.5 %"),
    ("nanoindentation-190mN", "max_plastic_strain"): (
        0.00644, "108x108x40 grid, refined peak (tests/test_grid_convergence.py); seed: 0.6 %"),
}


def commit() -> str:
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True,
                              check=False).stdout.strip()

    sha = git("rev-parse", "--short", "HEAD") or "unknown"
    return sha + ("+uncommitted-changes" if git("status", "--porcelain", "--", "sacflow") else "")


def rows(only: set[str] | None = None) -> list[dict[str, str]]:
    """The table's rows for every shipped config, or for the configs named in ``only``."""
    how = (f"python pipelines/record_config_numbers.py; commit {commit()}; "
           f"{datetime.date.today().isoformat()}; current code at the tiny grid")
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for path in CONFIGS:
            if only is not None and path.stem not in only:
                continue
            case = tiny(path)
            numbers, _, _ = measure(path, Path(tmp))
            hertz = case.hertz()
            grid = f"{case.grid.nx}x{case.grid.ny}x{case.grid.nz}"
            for quantity, value in numbers.items():
                ref, source = REFERENCES.get((path.stem, quantity), (None, ""))
                if ref is None and quantity == "peak_pressure":
                    ref, source = hertz.p0, "Hertz p0 (elastic, smooth), closed form"
                if ref is None and quantity == "approach":
                    ref, source = hertz.approach, "Hertz approach (elastic, smooth), closed form"
                out.append({
                    "config": path.stem,
                    "quantity": quantity,
                    "value": f"{value:.6e}",
                    "units": UNITS[quantity],
                    "reference": "" if ref is None else f"{ref:.4e}",
                    "value_over_reference": "" if ref is None else f"{value / ref:.3f}",
                    "reference_source": source,
                    "obtained": f"{how} {grid}",
                })
            print(f"{path.stem}: {numbers}", file=sys.stderr)
    return out


def merged(new: list[dict[str, str]], only: set[str]) -> list[dict[str, str]]:
    """The stored rows with those of the configs in ``only`` replaced by ``new``, by config."""
    with TABLE.open(encoding="utf-8") as f:
        kept = [row for row in csv.DictReader(line for line in f if not line.startswith("#"))
                if row["config"] not in only]
    return sorted(kept + new, key=lambda row: CONFIG_ORDER[row["config"]])


CONFIG_ORDER = {path.stem: k for k, path in enumerate(CONFIGS)}


def _change(value: float, was: float) -> str:
    """The relative change from the recorded value (a recorded zero: the value itself)."""
    if was == 0.0:
        return "+0.000%" if value == 0.0 else f"{value:+.6g} (recorded 0)"
    return f"{value / was - 1:+.3%}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare, do not write")
    parser.add_argument("--only", action="append", metavar="NAME",
                        help="record this config only (repeatable); other rows are kept")
    args = parser.parse_args()
    only = None if args.only is None else set(args.only)
    unknown = sorted((only or set()) - {path.stem for path in CONFIGS})
    if unknown:
        parser.error(f"no shipped config named {', '.join(unknown)} in configs/")
    new = rows(only)
    if args.check:
        old = recorded()
        for row in new:
            was = old.get(row["config"], {}).get(row["quantity"])
            change = "new" if was is None else _change(float(row["value"]), was)
            print(f"{row['config']:32s} {row['quantity']:20s} {row['value']}  {change}")
        return
    if only is not None:
        new = merged(new, only)
    TABLE.parent.mkdir(exist_ok=True)
    with TABLE.open("w", encoding="utf-8", newline="") as f:
        f.write("# Regression numbers of the shipped cases at their tiny test grid "
                "(tests/test_configs.py, +-2 %).\n# Written by pipelines/record_config_numbers.py;"
                " 'reference' is a full-grid, seed or closed-form value for a sanity reading "
                "only.\n")
        writer = csv.DictWriter(f, fieldnames=list(new[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(new)
    print(f"wrote {TABLE.relative_to(ROOT)} ({len(new)} rows)", file=sys.stderr)


if __name__ == "__main__":
    main()
