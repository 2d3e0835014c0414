"""Shared helpers of the benchmark scripts: isolated runs with peak memory, JSON output.

Benchmarks print JSON and never assert (they are not tests). Each measurement runs in a fresh
process so that its peak resident memory (``ru_maxrss``) is its own.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import platform
import resource
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: Repository root: benchmarks find the shipped configs from here, wherever they are run from.
ROOT = Path(__file__).resolve().parent.parent


def _child(func: Callable[..., dict], args: tuple, queue) -> None:
    try:
        result = func(*args)
        result["peak_memory_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    except Exception as exc:  # report, do not hang the parent
        result = {"error": f"{type(exc).__name__}: {exc}", "args": [str(a) for a in args]}
    queue.put(result)


def isolated(func: Callable[..., dict], *args: Any) -> dict:
    """Run ``func(*args)`` in a fresh process; return its dict plus ``peak_memory_mb``."""
    ctx = mp.get_context("spawn")
    queue = ctx.Queue()
    proc = ctx.Process(target=_child, args=(func, args, queue))
    proc.start()
    result = queue.get()
    proc.join()
    return result


#: Plasticity of the one-step benchmark case: (yield stress, hardening modulus) [Pa].
#: ``mild``: σ_Y = p0/2, H = 0.05 E (a small plastic zone, about a tenth of the box at n = 128);
#: ``strong``: the nano-indentation steel's linear law, σ_Y = 1655.6 MPa, H = 21 GPa (largest
#: εp about 2.3 %, a plastic zone of about half the box): the cases users run.
HARDENING = {"mild": (8.4696e9 / 2, 0.05 * 210e9), "strong": (1655.6e6, 21e9)}


def hertz_step_case(n: int, scheme: str = "coupled", hardening: str = "mild",
                    increments: int = 1) -> dict:
    """One elastic-plastic load step of a rigid sphere on linear hardening, n × n × n/2 box.

    R = 105 µm, W = 0.65 N (Hertz p0 = 8.47 GPa), E = 210 GPa, ν = 0.3, linear hardening of
    :data:`HARDENING` (``mild`` or ``strong``), one increment, plasticity tolerance 1e-6,
    ±1.5 a (the case of ``elastic_plastic.py`` and ``scale.py``).
    """
    E = 210e9
    yield_stress, modulus = HARDENING[hardening]
    return {
        "name": f"hertz-step-{hardening}-{n}",
        "body": {"E": E, "nu": 0.3,
                 "hardening": {"law": "linear", "yield_stress": yield_stress,
                               "modulus": modulus}},
        "counterbody": {"kind": "rigid", "radius": 105e-6},
        "grid": {"nx": n, "ny": n, "nz": n // 2, "half_width": 1.5},
        "load_path": [{"kind": "load", "to": 0.65, "increments": increments}],
        "solver": {"plasticity_tolerance": 1e-6, "scheme": scheme},
    }


def time_eigenstrain_builds() -> dict[str, float]:
    """Time every eigenstrain operator built from now on in this process; return the tally.

    ``HalfSpaceEigenstrain.__init__`` is wrapped so that ``tally["eigenstrain_s"]`` accumulates
    the wall time of the outermost builds only (the traction beyond the box builds a second
    operator inside the first: counted once).
    """
    from sacflow.kernels import eigenstrain

    tally = {"eigenstrain_s": 0.0}
    depth = [0]
    build = eigenstrain.HalfSpaceEigenstrain.__init__

    def timed_build(self, *args, **kwargs):
        depth[0] += 1
        t = time.perf_counter()
        try:
            build(self, *args, **kwargs)
        finally:
            depth[0] -= 1
        if not depth[0]:
            tally["eigenstrain_s"] += time.perf_counter() - t

    eigenstrain.HalfSpaceEigenstrain.__init__ = timed_build
    return tally


def timed(func: Callable[[], Any], repeat: int = 3) -> tuple[float, Any]:
    """Best wall time of ``repeat`` calls of ``func`` and the last result."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = func()
        best = min(best, time.perf_counter() - t0)
    return best, out


def emit(name: str, results: list[dict], **summary: object) -> None:
    """Print the benchmark JSON document on stdout (``summary``: extra top-level entries)."""
    doc = {
        "benchmark": name,
        "python": sys.version.split()[0],
        "machine": platform.machine(),
        "cpus": mp.cpu_count(),
        "results": results,
        **summary,
    }
    print(json.dumps(doc, indent=2))
