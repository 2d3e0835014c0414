"""The half-space correction of one cuboid: centre-sampled (the operator) against quadrature.

``python pipelines/traction_quadrature.py RATIO [--layer L] [--window W] [--layers Z]
[--gauss G]``, or ``... 0 --press RUN.npz [--sources L] [--window W] [--layers Z]``

The eigenstrain operator (:class:`~sacflow.kernels.eigenstrain.HalfSpaceEigenstrain`) removes
the normal traction ``t`` that the infinite-space cuboids and their images leave on the surface
as a uniform pressure on each surface cell equal to ``t`` at the cell's centre (Love's
rectangles). The exact correction (for the same piecewise-uniform eigenstrain and the same
footprint) is Boussinesq's response to ``t`` itself; the two differ by

    Δ(x) = ∫ B(x − y; x3) [t(y) − t(y_J)] dy,    y in surface cell J,

``B`` Boussinesq's stress of a point force (:func:`~sacflow.kernels.surface.boussinesq_stress`)
and ``t`` the closed-form traction of the cuboid and its image (as the operator's set-up takes
it). Here ``Δ`` is integrated with G × G Gauss–Legendre points per surface cell, for one cuboid
of unit eigenstrain (each of the six components) in layer L of a (2W + 1)² × Z box with
dx/dz = RATIO, at the centres of the box's cells. Two independent checks of the quadrature:

* the operator on a grid F times finer laterally (the same cuboid split, the traction sampled
  at the centres of the finer cells) must approach the operator plus ``Δ`` as F grows;
* ``Δ`` must not move when G doubles.

Prints, per source component: the largest first-layer stress of the cuboid, the largest
``|Δ|``, how far each finer grid is from the operator and from the operator plus ``Δ``, and the
largest ``|Δ|`` by lateral distance from the source (in cells) and by target layer: the reach
a short-range correction would need. Stress per unit eigenstrain, in units of μ (μ = 1).
With ``--press``: ``Δ`` of a stored press run's plastic strain (sources in its first L layers,
targets in its first Z layers, cut to ±W cells), added to the operator's residual stress.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from press_refined_traction import NU as PRESS_NU
from press_refined_traction import E as PRESS_E
from press_refined_traction import load_press

from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.kernels.traction_stencil import TractionStencil, stencil_kernels

E_UNIT, NU = 2.6, 0.3  # μ = E / (2 (1 + ν)) = 1: stress per unit eigenstrain, in units of μ
MU = E_UNIT / (2.0 * (1.0 + NU))
FINER = (3, 9)  # lateral refinements of the reference grids (odd: coarse centres stay centres)


def quadrature_delta(shape: tuple[int, int, int], spacing: tuple[float, float, float],
                     layer: int, gauss: int) -> np.ndarray:
    """``Δ`` at every cell centre of a (2W + 1)² × Z box, unit cuboid at the footprint's centre.

    :func:`~sacflow.kernels.traction_stencil.stencil_kernels` of that layer, laid out
    (6 sources, n1, n2, n3, 6 components).
    """
    n1, n2, n3 = shape
    if n1 != n2 or n1 % 2 == 0:
        raise ValueError(f"the box must be (2W + 1)² cells laterally, got {n1} × {n2}")
    kernels = stencil_kernels(spacing, NU, MU, layer + 1, n3, n1 // 2, gauss)[layer]
    return np.moveaxis(kernels, 3, 0)


def operator_stress(shape: tuple[int, int, int], spacing: tuple[float, float, float],
                    layer: int, finer: int) -> np.ndarray:
    """The operator's stress at the coarse centres, the surface ``finer`` times refined.

    Returns (6 sources, n1, n2, n3, 6).
    """
    n1, n2, n3 = shape
    f = finer
    op = HalfSpaceEigenstrain((n1 * f, n2 * f, n3), (spacing[0] / f, spacing[1] / f,
                                                     spacing[2]), E_UNIT, NU, threads=1)
    c1, c2 = n1 // 2, n2 // 2
    out = np.empty((6, n1, n2, n3, 6))
    for source in range(6):
        eps = np.zeros((n1 * f, n2 * f, n3, 6))
        eps[c1 * f:(c1 + 1) * f, c2 * f:(c2 + 1) * f, layer, source] = 1.0
        out[source] = op.residual_stress(eps)[f // 2::f, f // 2::f]
    return out


def corrected_field(eps: np.ndarray, spacing: tuple[float, float, float], E: float,
                    sources: int, targets: int, window: int, gauss: int) -> np.ndarray:
    """``Δ`` of a whole eigenstrain field, cut to a window: what the operator's stress lacks.

    Sources in the first ``sources`` layers, targets in the first ``targets`` layers and within
    ``window`` cells laterally of each source (the reach that :func:`reach` prints); Young's
    modulus ``E`` (``Δ`` is proportional to it at a fixed ν). Returns (n1, n2, targets, 6).
    """
    stencil = TractionStencil(eps.shape[:3], spacing, PRESS_NU, E / (2.0 * (1.0 + PRESS_NU)),
                              sources=sources, targets=targets, window=window, gauss=gauss)
    return stencil.apply(stencil.top(eps))


def reach(delta: np.ndarray, layer_cut: int) -> list[str]:
    """Largest |Δ| by Chebyshev distance from the source column, first ``layer_cut`` layers."""
    n1, n2 = delta.shape[:2]
    r = np.maximum(np.abs(np.arange(n1) - n1 // 2)[:, None],
                   np.abs(np.arange(n2) - n2 // 2)[None, :])
    rows = []
    for k in range(min(layer_cut, delta.shape[2])):
        by_r = [np.abs(delta[r == d, k]).max() for d in range(int(r.max()) + 1)]
        rows.append(f"    layer {k}: " + " ".join(f"{v:.1e}" for v in by_r))
    return rows


def press_check(path: Path, sources: int, targets: int, window: int, gauss: int) -> None:
    """The first layers' residual σ33 of a stored run's plastic strain, with and without ``Δ``.

    ``path``: an ``.npz`` of ``pipelines/press_run.py`` (stress sampling 1). Prints σ33 on the
    axis and its minimum, per layer, from the operator and from the operator plus ``Δ``.
    """
    eps, x1, x3 = load_press(path, 0)
    spacing = (float(x1[1] - x1[0]), float(x1[1] - x1[0]), float(x3[1] - x3[0]))
    stress = HalfSpaceEigenstrain(eps.shape[:3], spacing, PRESS_E, PRESS_NU).residual_stress(eps)
    delta = corrected_field(eps, spacing, PRESS_E, sources, targets, window, gauss)
    centre = int(np.argmin(np.abs(x1)))
    print(f"{path.name}: dx/dz {spacing[0] / spacing[2]:.2f}; Δ from {sources} source layers on "
          f"{targets} target layers, window ±{window}, {gauss}² points per cell")
    for k in range(targets):
        s33, fixed = stress[:, :, k, 2] / 1e6, (stress[:, :, k, 2] + delta[:, :, k, 2]) / 1e6
        print(f"  layer {k} ({x3[k] * 1e6:.1f} um): s33 axis {s33[centre, centre]:.0f} -> "
              f"{fixed[centre, centre]:.0f} MPa, minimum {s33.min():.0f} -> {fixed.min():.0f} MPa")


def main(argv: list[str]) -> None:
    """Compare, print the reach of the correction (module notes)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("ratio", type=float, help="cell aspect ratio dx/dz")
    parser.add_argument("--layer", type=int, default=0, help="source layer (0: the top one)")
    parser.add_argument("--window", type=int, default=4, help="W: the box is (2W + 1)² cells")
    parser.add_argument("--layers", type=int, default=4, help="Z: layers of the box")
    parser.add_argument("--gauss", type=int, default=8, help="G: Gauss points per cell side")
    parser.add_argument("--press", type=Path, default=None,
                        help="RUN.npz of pipelines/press_run.py: apply Δ to its plastic strain")
    parser.add_argument("--sources", type=int, default=2, help="source layers of --press's Δ")
    args = parser.parse_args(argv)
    if args.window < 1 or args.gauss < 2 or args.layers < 1:
        parser.error("need --window >= 1, --gauss >= 2 and --layers >= 1")
    if args.press is not None:
        if not args.press.is_file():
            parser.error(f"{args.press} is not a file: run pipelines/press_run.py first")
        if args.sources < 1:
            parser.error("need --sources >= 1")
        try:
            press_check(args.press, args.sources, args.layers, args.window, args.gauss)
        except ValueError as exc:
            parser.error(str(exc))
        return
    if not args.ratio > 0 or not 0 <= args.layer < args.layers:
        parser.error("need RATIO > 0 and 0 <= --layer < --layers")
    n = 2 * args.window + 1
    shape, spacing = (n, n, args.layers), (args.ratio, args.ratio, 1.0)
    delta = quadrature_delta(shape, spacing, args.layer, args.gauss)
    again = quadrature_delta(shape, spacing, args.layer, 2 * args.gauss)
    coarse = operator_stress(shape, spacing, args.layer, 1)
    finer = {f: operator_stress(shape, spacing, args.layer, f) for f in FINER}
    for source in range(6):
        scale = np.abs(coarse[source, :, :, 0]).max()
        print(f"dx/dz = {args.ratio}, source {source} in layer {args.layer}: first-layer stress "
              f"up to {scale:.3g}; |Δ| up to {np.abs(delta[source]).max():.3g} (first layer "
              f"{np.abs(delta[source, :, :, 0]).max():.3g}); G -> 2G moves Δ by "
              f"{np.abs(again[source] - delta[source]).max():.1e}")
        for f, stress in finer.items():
            off = np.abs(stress[source] - coarse[source]).max()
            left = np.abs(stress[source] - coarse[source] - delta[source]).max()
            print(f"  {f} x finer surface: from the operator {off:.3g}, "
                  f"from the operator + Δ {left:.3g}")
        print("  largest |Δ| by lateral distance (cells 0, 1, ...):")
        print("\n".join(reach(delta[source], args.layers)))


if __name__ == "__main__":
    main(sys.argv[1:])
