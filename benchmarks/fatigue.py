"""Fatigue stage on the seed's rolling case (configs/rolling-smooth.toml, 177 steps).

Runs the case once with the stress stored at every step (``output.volume_every = 1``; the
shipped config stores it every 10 steps) and times that run, then times the fatigue stage on the
stored run (Dang Van and Crossland over every cuboid's 177-step history) in a fresh process,
with its peak memory, for the default block size and for blocks 16 times smaller (the
``max_memory`` option; the results are identical). Prints JSON.

Usage: ``python benchmarks/fatigue.py [--out DIR]`` (default: a temporary folder; with
``--out`` an existing run there of the same case is reused and its time not reported).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

from _common import ROOT, emit, isolated

OVERRIDES = ["output.volume_every=1", "output.compression=1"]


def run_case(out: str) -> dict:
    from sacflow.runner import run_case as run
    from sacflow.storage.case_file import load_case

    case = load_case(ROOT / "configs/rolling-smooth.toml", OVERRIDES)
    t0 = time.perf_counter()
    summary = run(case, out, progress=False)
    return {"what": "run", "wall_s": time.perf_counter() - t0, "steps": summary.steps}


def stage(out: str, max_memory: int | None) -> dict:
    import xarray as xr

    from sacflow.compare.fatigue_index import DEFAULT_MAX_MEMORY, fatigue, history_blocks

    path = Path(out) / "rolling-smooth.nc"
    budget = DEFAULT_MAX_MEMORY if max_memory is None else max_memory
    with xr.open_dataset(path) as ds:
        shape = tuple(ds.sizes[d] for d in ("step", "x1", "x2", "x3"))
    t0 = time.perf_counter()
    result = fatigue(path, max_memory=budget)
    wall = time.perf_counter() - t0
    return {
        "what": "fatigue stage",
        "wall_s": wall,
        "steps": shape[0],
        "cuboids": shape[1] * shape[2] * shape[3],
        "history_mb": shape[0] * shape[1] * shape[2] * shape[3] * 48 / 2**20,
        "max_memory_mb": budget / 2**20,
        "blocks": len(history_blocks(shape, budget)),
        "dang_van_max": float(result["dang_van_max"]),
        "dang_van_max_depth_m": float(result["dang_van_max_depth"]),
    }


def main() -> None:
    args = sys.argv[1:]
    out = args[args.index("--out") + 1] if "--out" in args else tempfile.mkdtemp()
    results = []
    if not (Path(out) / "rolling-smooth.nc").exists():
        results.append(isolated(run_case, out))
    results.append(isolated(stage, out, None))
    results.append(isolated(stage, out, 2**20 * 16))
    emit("fatigue", results)


if __name__ == "__main__":
    main()
