"""Record the case id of every shipped case (``data/case_ids.csv``, ``tests/test_case_ids.py``).

    python pipelines/record_case_ids.py

The ids name stored runs: rewrite the table only after a deliberate change of what a case id
covers, and say so in the commit (every stored run of a changed id is then another case's).
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from test_case_ids import TABLE, case_ids  # noqa: E402


def main() -> None:
    """Write ``data/case_ids.csv`` from the current code (``--help`` writes nothing)."""
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, text=True,
                            capture_output=True, check=False).stdout.strip() or "unknown"
    with tempfile.TemporaryDirectory() as folder:
        rows = list(case_ids(Path(folder)))
    with open(TABLE, "w", newline="", encoding="utf-8") as f:
        f.write("# Case ids of the shipped cases (tests/test_case_ids.py); written by "
                f"pipelines/record_case_ids.py at commit {commit}.\n")
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(["case", "case_id"])
        writer.writerows(rows)
    print(f"{TABLE}: {len(rows)} case ids")


if __name__ == "__main__":
    main()
