"""Fine meshes on one machine: set-up (cold and warm kernel cache), one step, peak memory.

One elastic-plastic load step of a rigid sphere (R = 105 µm, W = 0.65 N, Hertz p0 = 8.47 GPa)
on linear hardening, plasticity tolerance 1e-6, n × n surface cells over ±1.5 a and an
n × n × n/2 cuboid box (the case of ``benchmarks/elastic_plastic.py``), for two materials
(``_common.HARDENING``): ``mild`` (σ_Y = p0/2, H = 0.05 E: a small plastic zone) and
``strong`` (the nano-indentation steel, σ_Y = 1655.6 MPa, H = 21 GPa: a plastic zone of about
half the box). A cost that grows with the plastic zone shows in the second only: both are run.

For each n, in fresh processes sharing a new, empty kernel cache directory:

* ``cold``: set-up with an empty cache (the kernels computed and stored), then the step;
* ``warm``: set-up from the cache (memory-mapped), then the step.

The processes have the malloc settings of ``sacflow run``
(:func:`sacflow.machine.malloc.tune_malloc`).
Prints JSON: set-up and step wall times, the step's operator applications and contact
iterations, the time per plastic iteration (step time over residual-stress applications), the
plastic zone (cells with εp > 0, and their share of the box), the peak resident memory of each
process, and where the set-up's time went (the eigenstrain operator alone). ``--profile`` adds
the ten functions of the step with the most own time. ``--hardening=mild`` or ``=strong`` runs
one material only; ``--threads=K`` sets the FFT threads (``SACFLOW_FFT_THREADS``, also the
threads of the compiled passes over the box); ``--threads=1,2`` runs each thread count in turn
(``--repeat=R`` times, alternated) and adds ``thread_scaling``: the median step per thread count
and the speed-up of the most threads over the fewest. ``--stress-sampling=2`` runs the case with
cell-averaged stresses (``solver.stress_sampling``: the kernel set-up evaluates 8 times more).
Usage: ``python benchmarks/scale.py [--profile] [--hardening=H] [--threads=K[,K2]] [--repeat=R]
[--stress-sampling=S] [n ...]`` (default 64 128).
"""

from __future__ import annotations

import os
import tempfile
import time

from _common import emit, hertz_step_case, isolated, time_eigenstrain_builds


def one_step(n: int, cache: str, label: str, profile: bool, hardening: str,
             threads: str | None, sampling: int = 1) -> dict:
    os.environ["SACFLOW_CACHE_DIR"] = cache
    if threads is not None:
        os.environ["SACFLOW_FFT_THREADS"] = threads
    import numpy as np

    from sacflow.machine.malloc import tune_malloc

    tune_malloc()  # the process allocates as `sacflow run` and the campaign workers do

    from sacflow.config.solver_inputs import simulation_for
    from sacflow.kernels.fft import default_threads
    from sacflow.storage.case_file import case_from_dict

    spent = time_eigenstrain_builds()
    t0 = time.perf_counter()
    case = hertz_step_case(n, hardening=hardening)
    if sampling != 1:
        case.setdefault("solver", {})["stress_sampling"] = sampling
    sim = simulation_for(case_from_dict(case))
    setup = time.perf_counter() - t0
    import resource

    setup_peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    profiler = None
    if profile:
        import cProfile

        profiler = cProfile.Profile()
        profiler.enable()
    t0 = time.perf_counter()
    state = next(iter(sim.run()))
    step = time.perf_counter() - t0
    cuboids = int(np.prod(sim.equivalent_plastic_strain.shape))
    plastic = int((sim.equivalent_plastic_strain > 0).sum())
    result = {
        "n": n,
        "hardening": hardening,
        "stress_sampling": sampling,
        "fft_threads": sim.inputs.settings.fft_threads or default_threads(),
        "cache": label,
        "cuboids": cuboids,
        "setup_s": round(setup, 2),
        "eigenstrain_setup_s": round(spent["eigenstrain_s"], 2),
        "setup_peak_memory_mb": round(setup_peak),
        "step_s": round(step, 2),
        "residual_stress_applications": state.plasticity_iterations,
        "step_s_per_plastic_iteration": round(step / max(state.plasticity_iterations, 1), 3),
        "contact_iterations": state.contact_iterations,
        "plastic_cells": plastic,
        "plastic_share": round(plastic / cuboids, 4),
        "max_equivalent_plastic_strain": float(sim.equivalent_plastic_strain.max()),
    }
    if profiler is not None:
        import io
        import pstats

        profiler.disable()
        text = io.StringIO()
        pstats.Stats(profiler, stream=text).sort_stats("tottime").print_stats(10)
        result["profile"] = text.getvalue().splitlines()[-14:]
    return result


def thread_scaling(results: list[dict]) -> list[dict]:
    """Median step time per thread count, and the fewest threads' over the most threads'."""
    import statistics

    rows = []
    keys = sorted({(r["n"], r["hardening"], r["cache"]) for r in results})
    for n, hardening, cache in keys:
        times: dict[int, list[float]] = {}
        for r in results:
            if (r["n"], r["hardening"], r["cache"]) == (n, hardening, cache):
                times.setdefault(r["fft_threads"], []).append(r["step_s"])
        medians = {k: statistics.median(v) for k, v in sorted(times.items())}
        fewest, most = min(medians), max(medians)
        rows.append({"n": n, "hardening": hardening, "cache": cache,
                     "median_step_s": medians, "runs": {k: len(v) for k, v in times.items()},
                     "speed_up": round(medians[fewest] / medians[most], 3)})
    return rows


def main(argv: list[str] | None = None) -> None:
    """Parse the options (module notes) and print the JSON of every run."""
    import argparse

    from sacflow.kernels.cell_average import MAX_SAMPLING

    def positive(text: str) -> int:
        if not text.isdigit() or int(text) < 1:
            raise argparse.ArgumentTypeError(f"a whole number of at least 1, got {text!r}")
        return int(text)

    def thread_counts(text: str) -> list[str]:
        return [str(positive(part)) for part in text.split(",")]

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n", type=positive, nargs="*", default=[64, 128],
                        help="surface cells per side (n × n × n/2 cuboids); default 64 128")
    parser.add_argument("--profile", action="store_true", help="the step's ten costliest functions")
    parser.add_argument("--hardening", choices=["mild", "strong"], default=None,
                        help="one material only (default: both)")
    parser.add_argument("--threads", type=thread_counts, default=None,
                        help="FFT and pass threads, or a comma-separated list run in turn")
    parser.add_argument("--repeat", type=positive, default=1, help="runs of each thread count")
    parser.add_argument("--stress-sampling", type=int, default=1,
                        choices=range(1, MAX_SAMPLING + 1), metavar="S",
                        help=f"solver.stress_sampling of the case, 1 to {MAX_SAMPLING} "
                        "(1: centre values, 2: cell mean)")
    args = parser.parse_args(argv)
    materials = [args.hardening] if args.hardening else ["mild", "strong"]
    counts: list[str | None] = list(args.threads) if args.threads else [None]
    results = []
    for n in args.n:
        for hardening in materials:
            for _ in range(args.repeat):
                for threads in counts:  # alternated: a drift of the machine hits all
                    with tempfile.TemporaryDirectory(prefix="sacflow-scale-cache-") as cache:
                        for label in ("cold", "warm"):
                            results.append(isolated(one_step, n, cache, label, args.profile,
                                                    hardening, threads, args.stress_sampling))
    extra = {}
    if len(counts) > 1:
        extra["thread_scaling"] = thread_scaling(results)
    emit("scale", results, **extra)


if __name__ == "__main__":
    main()
