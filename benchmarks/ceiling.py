"""What a second thread can gain on this machine: streaming passes, the operator, a step.

``python benchmarks/ceiling.py [--n 128] [--repeat 5] [--threads 1,2] [--no-step]``

For each thread count, in a fresh process (``SACFLOW_FFT_THREADS`` set before the import):

* ``stream``: the memory bandwidth of a compiled triad ``a = b + s c`` and of a copy over
  vectors of the strongly plastic step's box (``n × n × n/2`` cuboids × 6 components), shared
  out by the same :func:`sacflow.machine.threads.over_ranges` as the solver's passes, at any
  size (GB/s: bytes read and written over the median time);
* ``operator``: one application of the residual-stress operator
  (:class:`sacflow.kernels.eigenstrain.HalfSpaceEigenstrain`: ``surface_fields`` then
  ``stress``) on a random eigenstrain of that box: its FFTs, depth transforms, sums and
  spectral products;
* ``step`` (unless ``--no-step``): one strongly plastic load step of ``scale.py`` (the case of
  ``_common.hertz_step_case(n, hardening="strong")``), its wall time, residual-stress
  applications and the time outside them (``step − applications × operator``).

Then, per thread count against the first, the ratios, and an upper bound of the step's
ratio: the applications at the operator's ratio and the rest at the stream's (the best the
passes outside the operator can do, being memory-bound). Medians of ``--repeat`` timings. The
kernel cache is a fresh temporary directory shared by the processes (the first one computes
the kernels). JSON on stdout.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time

from _common import emit, hertz_step_case, isolated

#: Scale of the triad (any value; a multiply-add per entry, as the solver's passes).
TRIAD_SCALE = 0.5


def _median_seconds(call, repeat: int) -> float:
    """Median wall time of ``call()`` over ``repeat`` runs after one untimed warm-up."""
    call()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def stream_seconds(size: int, threads: int, repeat: int) -> tuple[float, float]:
    """Median seconds of a compiled triad and copy over vectors of ``size`` entries."""
    import numba
    import numpy as np

    from sacflow.machine.threads import SPLIT_ITEMS, over_ranges

    @numba.njit(nogil=True)
    def triad(a, b, c, scale, first, last):  # pragma: no cover - compiled
        a, b, c = a[first:last], b[first:last], c[first:last]
        for i in range(a.size):
            a[i] = b[i] + scale * c[i]

    @numba.njit(nogil=True)
    def copy(a, b, first, last):  # pragma: no cover - compiled
        a, b = a[first:last], b[first:last]
        for i in range(a.size):
            a[i] = b[i]

    rng = np.random.default_rng(0)
    a, b, c = np.zeros(size), rng.random(size), rng.random(size)
    # weighted so that every size is shared out: the machine's ceiling, not the solver's choice
    triad_s = _median_seconds(lambda: over_ranges(triad, size, threads, a, b, c, TRIAD_SCALE,
                                                  weight=SPLIT_ITEMS), repeat)
    copy_s = _median_seconds(lambda: over_ranges(copy, size, threads, a, b, weight=SPLIT_ITEMS),
                             repeat)
    return triad_s, copy_s


def operator_seconds(shape: tuple[int, int, int], threads: int, repeat: int) -> float:
    """Median seconds of one residual-stress application on a random eigenstrain."""
    import numpy as np

    from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain

    operator = HalfSpaceEigenstrain(shape, (1e-6, 1e-6, 1e-6), 210e9, 0.3, threads=threads)
    eps = np.random.default_rng(0).standard_normal((*shape, 6)) * 1e-3

    def application() -> None:
        traction, _ = operator.surface_fields(eps, with_displacement=False)
        operator.stress(traction)

    return _median_seconds(application, repeat)


def measure(n: int, threads: int, repeat: int, cache: str, with_step: bool) -> dict:
    """Time the stream, the operator and (optionally) a step on ``threads`` threads."""
    os.environ["SACFLOW_FFT_THREADS"] = str(threads)
    os.environ["SACFLOW_CACHE_DIR"] = cache
    from sacflow.machine.malloc import tune_malloc
    from sacflow.machine.threads import single_threaded_blas

    tune_malloc()
    shape = (n, n, n // 2)
    size = shape[0] * shape[1] * shape[2] * 6
    entry = 8  # bytes of a float64
    triad_s, copy_s = stream_seconds(size, threads, repeat)
    result: dict = {
        "threads": threads, "box": "x".join(map(str, shape)), "vector_mb": size * entry / 2**20,
        "triad_s": round(triad_s, 5), "triad_gb_s": round(3 * size * entry / triad_s / 1e9, 2),
        "copy_s": round(copy_s, 5), "copy_gb_s": round(2 * size * entry / copy_s / 1e9, 2),
    }
    with single_threaded_blas():
        result["operator_s"] = round(operator_seconds(shape, threads, repeat), 4)
        if with_step:
            from sacflow.config.solver_inputs import simulation_for
            from sacflow.storage.case_file import case_from_dict

            simulation = simulation_for(case_from_dict(hertz_step_case(n, hardening="strong")))
            start = time.perf_counter()
            state = next(iter(simulation.run()))
            step = time.perf_counter() - start
            applications = int(state.plasticity_iterations)
            result.update(step_s=round(step, 3), applications=applications,
                          contact_iterations=int(state.contact_iterations),
                          outside_operator_s=round(step - applications * result["operator_s"],
                                                   3))
    return result


def ratios(results: list[dict]) -> list[dict]:
    """Each thread count against the first: measured ratios and the step's upper bound."""
    base = results[0]
    rows = []
    for row in results[1:]:
        entry = {"threads": f"{base['threads']} -> {row['threads']}",
                 "triad": round(base["triad_s"] / row["triad_s"], 3),
                 "copy": round(base["copy_s"] / row["copy_s"], 3),
                 "operator": round(base["operator_s"] / row["operator_s"], 3)}
        if "step_s" in base and "step_s" in row:
            entry["step"] = round(base["step_s"] / row["step_s"], 3)
            # best case: the applications at the operator's gain, the rest at the stream's
            best = (base["applications"] * row["operator_s"]
                    + base["outside_operator_s"] * row["triad_s"] / base["triad_s"])
            entry["step_upper_bound"] = round(base["step_s"] / best, 3)
        rows.append(entry)
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=128, help="lateral cells (box n × n × n/2)")
    parser.add_argument("--repeat", type=int, default=5, help="timed runs of each pass")
    parser.add_argument("--threads", default="1,2", help="thread counts, comma-separated")
    parser.add_argument("--no-step", action="store_true", help="skip the plastic step")
    args = parser.parse_args(argv)
    try:
        counts = [int(t) for t in args.threads.split(",")]
    except ValueError:
        parser.error(f"--threads must be whole numbers separated by commas, got {args.threads!r}")
    if args.n < 8 or args.n % 2 or args.repeat < 1 or min(counts) < 1:
        parser.error("--n must be an even number >= 8, --repeat and each thread count >= 1")
    with tempfile.TemporaryDirectory(prefix="sacflow-ceiling-cache-") as cache:
        results = [isolated(measure, args.n, t, args.repeat, cache, not args.no_step)
                   for t in counts]
    failed = [r for r in results if "error" in r]
    if failed:
        sys.exit(f"ceiling.py: a measurement failed: {failed[0]['error']}")
    emit("ceiling", results, ratios=ratios(results))


if __name__ == "__main__":
    main()
