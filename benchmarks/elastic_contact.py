"""Elastic Hertz contact on n×n grids: wall time, iterations, peak memory, error vs Hertz.

Usage: ``python benchmarks/elastic_contact.py [n ...]`` (default 128 256 512 1024). The window
is ±1.5 a; the tolerance is the solver default 1e-10. Prints JSON.
"""

from __future__ import annotations

import sys
import time

from _common import emit, isolated, timed


def measure(n: int) -> dict:
    import numpy as np

    from sacflow.kernels.convolution import Convolution
    from sacflow.kernels.surface import rectangle_displacement
    from sacflow.mechanics.contact import solve_contact
    from sacflow.mechanics.hertz import composite_modulus, hertz_contact, hertz_pressure

    e_star = composite_modulus(210e9, 0.3)
    radius, load = 105e-6, 0.65
    hz = hertz_contact(load, radius, e_star)
    dx = 3.0 * hz.a / n
    x = (np.arange(n) - n / 2 + 0.5) * dx
    X, Y = np.meshgrid(x, x, indexing="ij")
    t0 = time.perf_counter()

    def love(d1, d2):
        return (rectangle_displacement(d1 * dx, d2 * dx, dx / 2, dx / 2) / (np.pi * e_star))[
            None, None
        ]

    conv = Convolution(love, (n, n), (n, n))
    setup = time.perf_counter() - t0
    h = (X**2 + Y**2) / (2 * radius)
    wall, res = timed(lambda: solve_contact(h, conv, dx * dx, load=load, tol=1e-10))
    r = np.hypot(X, Y)
    uncut = np.abs(r - hz.a) > dx / np.sqrt(2)
    err = np.abs(res.pressure - hertz_pressure(r, hz.a, hz.p0)) / hz.p0
    return {
        "grid": f"{n}x{n}",
        "cells": n * n,
        "cells_across_contact": round(2 * hz.a / dx, 1),
        "setup_s": round(setup, 4),
        "solve_s": round(wall, 4),
        "iterations": res.iterations,
        "p0_rel_error": float(res.pressure.max() / hz.p0 - 1),
        "approach_rel_error": float(res.approach / hz.approach - 1),
        "pressure_max_error_uncut_cells_over_p0": float(err[uncut].max()),
        "pressure_max_error_all_cells_over_p0": float(err.max()),
        "load_balance_rel_error": float(res.load / load - 1),
    }


if __name__ == "__main__":
    sizes = [int(a) for a in sys.argv[1:]] or [128, 256, 512, 1024]
    emit("elastic_contact", [isolated(measure, n) for n in sizes])
