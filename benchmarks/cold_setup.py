"""Cold set-up of shipped configs: everything a run computes before its first step.

Usage: ``python benchmarks/cold_setup.py [--repeat R] [CONFIG ...]`` (default: the press of the
indentation-made dent, the linear-hardening and the Swift 650 mN nano-indentations). Each run is
a fresh process with a new, empty kernel cache, so every influence coefficient is computed: the
contact's (cells and, with ``solver.contact_subcells``, sub-cells), the eigenstrain operator's
kernel spectra (``eigenstrain_setup_s``), those of the traction beyond the box. The runs of the
configs alternate, ``R`` rounds; the summary gives each config's median with its range. Prints
JSON.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time

from _common import ROOT, emit, isolated, time_eigenstrain_builds

DEFAULT_CONFIGS = ("pipelines/dent-from-indentation-press.toml",
                   "configs/nanoindentation-linear-650mN.toml",
                   "configs/nanoindentation-650mN.toml")


def cold_setup(config: str) -> dict:
    """Set up ``config``'s simulation with an empty kernel cache; the times it took."""
    with tempfile.TemporaryDirectory(prefix="sacflow-cold-setup-") as cache:
        os.environ["SACFLOW_CACHE_DIR"] = cache
        from sacflow.machine.malloc import tune_malloc

        tune_malloc()  # the process allocates as `sacflow run` does
        from sacflow.config.solver_inputs import simulation_for
        from sacflow.storage.case_file import load_case

        spent = time_eigenstrain_builds()
        case = load_case(ROOT / config)
        t0 = time.perf_counter()
        simulation_for(case)
        grid, solver = case.grid, case.solver
        return {"config": config, "cells": [grid.nx, grid.ny, grid.nz],
                "stress_sampling": solver.stress_sampling,
                "contact_subcells": solver.contact_subcells,
                "setup_s": round(time.perf_counter() - t0, 2),
                "eigenstrain_setup_s": round(spent["eigenstrain_s"], 2)}


def main(argv: list[str] | None = None) -> None:
    """Parse the options (module notes) and print the JSON of every run and the medians."""
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("configs", nargs="*", default=list(DEFAULT_CONFIGS),
                        help="case files, relative to the repository root")
    parser.add_argument("--repeat", type=int, default=3, help="rounds of runs (default 3)")
    args = parser.parse_args(argv)
    missing = [c for c in args.configs if not (ROOT / c).is_file()]
    if missing:
        parser.error(f"no case file {', '.join(missing)} under {ROOT}")
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1, got {args.repeat}")
    results = [isolated(cold_setup, config) for _ in range(args.repeat)
               for config in args.configs]
    medians = {}
    for config in args.configs:
        times = [r["setup_s"] for r in results if r.get("config") == config]
        if times:
            medians[config] = {"median_setup_s": statistics.median(times),
                               "range_s": [min(times), max(times)]}
    emit("cold_setup", results, medians=medians)


if __name__ == "__main__":
    main()
