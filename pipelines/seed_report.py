"""Run the seed's cases and the comparison stages that report on them; print one JSON document.

    python pipelines/seed_report.py [--out runs/seed-report] [--only NAME ...] [--set KEY=VALUE ...]

Cases (configs/): nanoindentation-190mN and -650mN (stage ``indentation``), rolling-smooth
(``track``), dent-vertical with its elastic twin (``elastic-vs-plastic``, ``residual-map``) and
dent-rolling (``vertical-vs-rolling`` against dent-vertical run on dent-rolling's grid, so that
both profiles come from the same cuboid layer). Each run is written to
``OUT/<case>.nc`` (finished runs are reused), each stage to ``OUT/compare/<stem>.nc/.png``. The
JSON holds, per case, the wall time and iteration counts, and per stage its summary numbers
(0-d variables, SI units). ``--set`` overrides apply to every case (e.g. a coarser grid for a
quick look). Nothing here is asserted: it is the report the issues ask for, not a test.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

CASES = {
    "nanoindentation-190mN": [("indentation", {})],
    "nanoindentation-650mN": [("indentation", {})],
    "rolling-smooth": [("track", {})],
    "dent-vertical": [("residual-map", {"depth": 65e-6})],
    "dent-vertical-elastic": [],
    "dent-vertical-rolling-grid": [],
    "dent-rolling": [],
}
PAIRS = [
    ("elastic-vs-plastic", "dent-vertical-elastic", "dent-vertical", {}),
    # like for like: the vertical case on the rolling case's grid (same cuboid layers)
    ("vertical-vs-rolling", "dent-vertical-rolling-grid", "dent-rolling", {"depth": 75e-6}),
]


def build(name: str, overrides: list[str]):
    """The shipped case ``name``; ``-elastic``: with an elastic body; ``-rolling-grid``: on the
    grid of ``dent-rolling``."""
    from sacflow.config.schema import Case
    from sacflow.storage.case_file import load_case

    base = name.removesuffix("-elastic").removesuffix("-rolling-grid")
    case = load_case(ROOT / "configs" / f"{base}.toml", overrides)
    if name == base:
        return case
    data = case.model_dump()
    data["name"] = name
    if name.endswith("-elastic"):
        data["body"]["hardening"] = {"law": "elastic"}
    else:
        rolling = load_case(ROOT / "configs" / "dent-rolling.toml", overrides)
        data["grid"] = rolling.grid.model_dump()
    return Case.model_validate(data)


def run(name: str, out: Path, overrides: list[str]) -> dict:
    from sacflow.runner import run_case
    from sacflow.storage.run_reader import open_run

    case = build(name, overrides)
    t0 = time.perf_counter()
    summary = run_case(case, out, progress=False)
    ds = open_run(summary.path)
    return {
        "path": str(summary.path),
        "grid": f"{case.grid.nx}x{case.grid.ny}x{ds.sizes['x3']}",
        "steps": int(ds.sizes["step"]),
        "wall_s": round(time.perf_counter() - t0, 1) if not summary.skipped else None,
        "reused": summary.skipped,
        "contact_iterations_per_step": float(ds["contact_iterations"].mean()),
        "plasticity_iterations_per_step": float(ds["plasticity_iterations"].mean()),
        "plasticity_iterations_max": int(ds["plasticity_iterations"].max()),
    }


def numbers(result) -> dict:
    from sacflow.compare import summary_numbers

    return {
        key: {"value": value if np.isfinite(value) else None, "units": units}
        for key, (value, units) in summary_numbers(result).items()
    }


def main() -> None:
    from sacflow import compare
    from sacflow.compare import write

    stages = {
        "indentation": compare.indentation,
        "track": compare.track,
        "residual-map": compare.residual_map,
        "elastic-vs-plastic": compare.elastic_vs_plastic,
        "vertical-vs-rolling": compare.vertical_vs_rolling,
    }

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="runs/seed-report")
    parser.add_argument("--only", nargs="*", default=None)
    parser.add_argument("--set", dest="overrides", action="append", default=[])
    args = parser.parse_args()
    out = Path(args.out)
    names = [n for n in CASES if args.only is None or n in args.only]
    report: dict = {"cases": {}, "stages": {}}
    for name in names:
        report["cases"][name] = info = run(name, out, args.overrides)
        for stage, options in CASES[name]:
            result = stages[stage](info["path"], **options)
            write(result, out / "compare", f"{name}-{stage}")
            report["stages"][f"{name}-{stage}"] = numbers(result)
    for stage, first, second, options in PAIRS:
        if first in report["cases"] and second in report["cases"]:
            result = stages[stage](report["cases"][first]["path"],
                                   report["cases"][second]["path"], **options)
            write(result, out / "compare", f"{second}-{stage}")
            report["stages"][f"{second}-{stage}"] = numbers(result)
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
