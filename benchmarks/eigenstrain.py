"""Eigenstrain operators: set-up and per-application times against the FFT floor.

Usage: ``python benchmarks/eigenstrain.py [n1xn2xn3 ...]`` (default 32x32x16 64x64x32
128x128x64). The floor is the time of twelve
forward+inverse pairs of 3-D real FFTs of the padded (2 n1 × 2 n2 × 2 n3) grid with pyfftw on
all cores, planned with FFTW_MEASURE and no time limit (the operator's own 3-D plans have a
0.3 s limit). An application transforms six components forward and six back (cosine and sine
transforms along depth on the footprint lines, 2-D FFTs on 2 n3 + 1 planes), about six pairs'
worth: that tighter figure and its ratio are printed too. Also the residual stress with the
traction beyond the box (``traction_beyond_box``: a second, coarse operator,
``sacflow/kernels/far_traction.py``), its set-up (cold or from the kernel cache) and its
ratio to the bare application. Prints JSON.
"""

from __future__ import annotations

import sys
import time

from _common import emit, isolated, timed


def measure(shape: tuple[int, int, int]) -> dict:
    import numpy as np
    import pyfftw

    from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
    from sacflow.kernels.eigenstrain_memory import kernel_bytes
    from sacflow.kernels.fft import default_threads

    t0 = time.perf_counter()
    op = HalfSpaceEigenstrain(shape, (1e-6, 1e-6, 0.5e-6), 210e9, 0.3)
    setup = time.perf_counter() - t0
    eps = np.random.default_rng(0).standard_normal((*shape, 6)) * 1e-3
    t_stress, _ = timed(lambda: op.residual_stress(eps), repeat=9)
    t_disp, _ = timed(lambda: op.residual_displacement(eps), repeat=9)
    t_both, _ = timed(lambda: op.residual_stress(eps, with_displacement=True), repeat=9)
    t0 = time.perf_counter()
    beyond = HalfSpaceEigenstrain(shape, (1e-6, 1e-6, 0.5e-6), 210e9, 0.3,
                                  traction_beyond_box=True)
    setup_beyond = time.perf_counter() - t0
    t_beyond, _ = timed(lambda: beyond.residual_stress(eps), repeat=9)
    # The floor's transform: the best plan FFTW finds (FFTW_MEASURE, no planning time limit,
    # unlike the operator's own 3-D plans), all cores: the strictest floor.
    real = pyfftw.empty_aligned(op.padded)
    spectrum = pyfftw.empty_aligned((*op.padded[:-1], op.padded[-1] // 2 + 1), dtype=complex)
    cores = default_threads()
    forward = pyfftw.FFTW(real, spectrum, axes=(0, 1, 2), flags=("FFTW_MEASURE",),
                          threads=cores)
    inverse = pyfftw.FFTW(spectrum, real, axes=(0, 1, 2), direction="FFTW_BACKWARD",
                          flags=("FFTW_MEASURE", "FFTW_DESTROY_INPUT"), threads=cores)
    real[...] = np.random.default_rng(1).random(real.shape)

    def six_pairs():
        for _ in range(6):
            forward.execute()
            inverse.execute()  # unnormalised: values grow by the grid size, far from overflow

    t_six, _ = timed(six_pairs, repeat=9)
    t_floor, _ = timed(lambda: (six_pairs(), six_pairs()), repeat=9)
    return {
        "cells": "x".join(map(str, shape)),
        "padded_grid": "x".join(map(str, op.padded)),
        "setup_s": round(setup, 3),
        "residual_stress_s": round(t_stress, 4),
        "residual_displacement_s": round(t_disp, 4),
        "stress_and_displacement_s": round(t_both, 4),
        "beyond_box_setup_s": round(setup_beyond, 3),
        "residual_stress_beyond_box_s": round(t_beyond, 4),
        "beyond_box_over_bare": round(t_beyond / t_stress, 3),
        "floor_12_fft_pairs_s": round(t_floor, 4),
        "stress_over_floor": round(t_stress / t_floor, 2),
        "displacement_over_floor": round(t_disp / t_floor, 2),
        "six_fft_pairs_s": round(t_six, 4),
        "stress_over_six_pairs": round(t_stress / t_six, 2),
        "kernel_memory_mb": round(kernel_bytes(shape) / 2**20, 1),
    }


if __name__ == "__main__":
    shapes = [tuple(int(v) for v in a.split("x")) for a in sys.argv[1:]] or [
        (32, 32, 16), (64, 64, 32), (128, 128, 64)]
    emit("eigenstrain", [isolated(measure, s) for s in shapes])
