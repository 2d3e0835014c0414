r"""Closed-form fields of a tangential (shear) load on the surface of an elastic half-space.

Conventions are those of :mod:`sacflow.kernels.surface`: SI units, x3 the depth (positive into
the body), tension positive, (..., 6) arrays in the order (11, 22, 33, 12, 13, 23). A shear
traction q1 > 0 acts on the body's surface along +x1: with the outward normal −e3 the surface
traction is t_i = −σ_i3, so σ13 = −q1 at the surface under the load.

Method
------
Cerruti's solution for a unit tangential point force along +x1 at the origin (Cerruti 1882; in
Cartesian form as in Johnson, *Contact Mechanics*, CUP 1985, ch. 3), with ρ = |x| and G the
shear modulus:

.. math::

    u_1 &= \frac{1}{4\pi G}\Big[\frac{1}{\rho} + \frac{x_1^2}{\rho^3}
          + (1-2\nu)\Big(\frac{1}{\rho + x_3} - \frac{x_1^2}{\rho(\rho + x_3)^2}\Big)\Big], \\
    u_2 &= \frac{1}{4\pi G}\Big[\frac{x_1 x_2}{\rho^3}
          - (1-2\nu)\frac{x_1 x_2}{\rho(\rho + x_3)^2}\Big], \qquad
    u_3 = \frac{1}{4\pi G}\Big[\frac{x_1 x_3}{\rho^3}
          + (1-2\nu)\frac{x_1}{\rho(\rho + x_3)}\Big].

With A = 1/ρ, B = ln(ρ + x3), C = x3 B − ρ (C,3 = B, B,3 = A; A, B, C harmonic, ∇²ρ = 2A)
and D = ρ + (1 − 2ν) C these are u1 = k(2A − D,11), u2 = −k D,12,
u3 = k(−x3 A,1 + (1 − 2ν) B,1), k = 1/(4πG). Their divergence is 2k(1 − 2ν) A,1, and Hooke's
law gives (derived here; ``tests/test_traction_kernels.py`` checks them against Johnson's
Cartesian stresses written out separately, equilibrium and compatibility, the free surface, and
the force and moment balance):

.. math::

    2\pi\sigma_{11} &= 2(1+\nu) A_{,1} - D_{,111}, \qquad
    2\pi\sigma_{22} = 2\nu A_{,1} - D_{,122}, \qquad
    2\pi\sigma_{33} = -x_3 A_{,13}, \\
    2\pi\sigma_{12} &= A_{,2} - D_{,112}, \qquad
    2\pi\sigma_{13} = A_{,3} - x_3 A_{,11}, \qquad
    2\pi\sigma_{23} = -x_3 A_{,12}.

For a uniform traction on the rectangle |ξ1| <= h1, |ξ2| <= h2 every potential is replaced by its
integral over the rectangle, and each derivative is a corner sum (the corner sum and the sign
convention of :mod:`sacflow.kernels.surface`) of a function F(X, Y) with ∂²F/∂X∂Y equal to the
point kernel (X = x1 − ξ1, Y = x2 − ξ2, z = x3, ρ = (X² + Y² + z²)^½; terms depending on X or Y
alone cancel in the sum and are dropped):

==========  ==================================================================================
kernel      corner function F(X, Y)
==========  ==================================================================================
A,1         asinh(Y / (X² + z²)^½)                  (= ln(Y + ρ) up to a function of X)
A,2         asinh(X / (Y² + z²)^½)
A,3         −atan(XY / (zρ))                        (φ1,3 of the normal load)
A,11        −XY / ((X² + z²) ρ)
A,12        1/ρ
A,13        −zY / ((X² + z²) ρ)
D,111       2ν asinh(Y / (X² + z²)^½) − X²Y / ((X² + z²) ρ) + (1 − 2ν) Y / (ρ + z)
D,122       Y/ρ − (1 − 2ν) Y / (ρ + z)
D,112       X/ρ − (1 − 2ν) X / (ρ + z)
==========  ==================================================================================

D,111 follows from ∫ D,11 dY with ρ,11 = 2A − ρ,22 − ρ,33 and C,11 = −C,22 − A. The asinh forms
avoid the cancellation of ln(Y + ρ) for Y ≪ 0. A traction along x2 is the same field with the
axes exchanged (:func:`traction_stress`). Published closed forms of this problem (e.g. Lee, Gu &
Jo 2000) are not used.

References
----------
* V. Cerruti, "Ricerche intorno all'equilibrio de' corpi elastici isotropi", Atti R. Accad.
  Lincei, Mem. Cl. Sci. Fis. Mat. Nat. 13 (1882) 81–123.
* K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985, ch. 3.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sacflow.kernels.load_geometry import CORNERS, point_force, rectangle_points, safe_div

__all__ = ["cerruti_stress", "rectangle_shear_stress", "subcell_load_stress_coefficients",
           "surface_load_stress_coefficients", "traction_stress"]

#: Component order after exchanging x1 and x2: (11, 22, 33, 12, 13, 23) -> (22, 11, 33, 12, 23,
#: 13).
_SWAP_AXES = (1, 0, 2, 3, 5, 4)


def cerruti_stress(x1: ArrayLike, x2: ArrayLike, x3: ArrayLike, nu: float) -> NDArray[np.float64]:
    r"""Stresses of a unit tangential point force along +x1 at the origin (Cerruti).

    The point form of the module docstring's stresses, with ρ = |x|, z = x3:
    A,1 = −x1/ρ³, A,3 = −z/ρ³, A,11 = 3x1²/ρ⁵ − 1/ρ³, A,12 = 3x1x2/ρ⁵, A,13 = 3x1z/ρ⁵, and the
    third derivatives of ρ and C = z ln(ρ + z) − ρ.

    Parameters
    ----------
    x1, x2, x3 : array_like
        Field point relative to the load point [m]; x3 >= 0, not all zero.
    nu : float
        Poisson's ratio.

    Returns
    -------
    ndarray, shape (..., 6)
        Stress per unit force [1/m²] (multiply by Q [N]), order (11, 22, 33, 12, 13, 23).
    """
    x, y, z, shape, r, r3, r5, rz = point_force(x1, x2, x3)
    k = 1.0 - 2.0 * nu
    a1, a2, a3 = -x / r3, -y / r3, -z / r3
    a11 = 3.0 * x * x / r5 - 1.0 / r3
    a12 = 3.0 * x * y / r5
    a13 = 3.0 * x * z / r5
    g = 1.0 / (r * rz * rz)  # ρ⁻¹ (ρ + z)⁻²
    h = (3.0 * r + z) / (r3 * rz**3)
    d111 = (-3.0 * x / r3 + 3.0 * x**3 / r5) + k * (3.0 * x * g - x**3 * h)
    d122 = (-x / r3 + 3.0 * x * y * y / r5) + k * (x * g - x * y * y * h)
    d112 = (-y / r3 + 3.0 * x * x * y / r5) + k * (y * g - x * x * y * h)
    d = {"a1": a1, "a2": a2, "a3": a3, "a11": a11, "a12": a12, "a13": a13, "d111": d111,
         "d122": d122, "d112": d112}
    return _stress_from_potentials(d, z, shape, nu)


def _stress_from_potentials(d: dict[str, NDArray[np.float64]], z: NDArray[np.float64],
                            shape: tuple[int, ...], nu: float) -> NDArray[np.float64]:
    """Assemble σ from the derivatives of the potentials A and D (module docstring).

    ``d`` holds A,1 A,2 A,3 A,11 A,12 A,13 D,111 D,122 D,112 (keys ``a1`` … ``d112``) of a
    point force or their corner sums over a rectangle; ``shape``: that of the field points.
    """
    c = 1.0 / (2.0 * np.pi)
    out = np.empty((*shape, 6))
    out[..., 0] = c * (2.0 * (1.0 + nu) * d["a1"] - d["d111"])
    out[..., 1] = c * (2.0 * nu * d["a1"] - d["d122"])
    out[..., 2] = -c * z * d["a13"]
    out[..., 3] = c * (d["a2"] - d["d112"])
    out[..., 4] = c * (d["a3"] - z * d["a11"])
    out[..., 5] = -c * z * d["a12"]
    return out


def _asinh_ratio(num: NDArray[np.float64], other: NDArray[np.float64],
                 z: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return asinh(num / (other² + z²)^½), and its finite part where other = z = 0.

    At the surface on a line through an edge (other = z = 0) the function diverges as
    sign(num) (ln 2|num| − ln |other|); the divergent part cancels between the two corners on
    that line when the field point is outside the rectangle, and the finite part
    sign(num) ln 2|num| is what the corner sum needs (0 at num = 0).
    """
    base = np.sqrt(other * other + z * z)
    size = np.abs(num)
    limit = np.where(size == 0.0, 0.0,
                     np.sign(num) * np.log(2.0 * np.where(size == 0.0, 1.0, size)))
    return np.where(base == 0.0, limit, np.arcsinh(safe_div(num, base)))


def rectangle_shear_stress(
    x1: ArrayLike,
    x2: ArrayLike,
    x3: ArrayLike,
    half1: ArrayLike,
    half2: ArrayLike,
    nu: float,
) -> NDArray[np.float64]:
    r"""Stresses in a half-space per unit uniform shear traction along +x1 on a rectangle.

    Closed form of the superposition of Cerruti's point-force stresses over |ξ1| <= half1,
    |ξ2| <= half2 (corner functions in the module docstring).

    Parameters
    ----------
    x1, x2 : array_like
        Lateral coordinates of the field points relative to the rectangle centre [m].
    x3 : array_like
        Depth of the field points [m], >= 0. At x3 = 0 the surface limit is returned (σ13 = −1
        inside the rectangle, 0 outside); values exactly on the edges at x3 = 0 are singular.
    half1, half2 : array_like
        Half-widths of the rectangle [m] (> 0). All inputs broadcast.
    nu : float
        Poisson's ratio.

    Returns
    -------
    ndarray, shape (..., 6)
        σ11, σ22, σ33, σ12, σ13, σ23 per unit traction (dimensionless; multiply by q1 [Pa]).

    Raises
    ------
    ValueError
        If any x3 < 0.
    """
    x1, x2, z, h1, h2, shape = rectangle_points(x1, x2, x3, half1, half2)
    k = 1.0 - 2.0 * nu
    names = ("a1", "a2", "a3", "a11", "a12", "a13", "d111", "d122", "d112")
    d = {name: np.zeros(shape) for name in names}
    with np.errstate(divide="ignore", invalid="ignore"):
        for s1, s2, w in CORNERS:
            X = x1 + s1 * h1
            Y = x2 + s2 * h2
            XX = X * X
            rho = np.sqrt(XX + Y * Y + z * z)
            ax = XX + z * z
            ln_y = _asinh_ratio(Y, X, z)
            d["a1"] += w * ln_y
            d["a2"] += w * _asinh_ratio(X, Y, z)
            d["a3"] += w * -np.arctan2(X * Y, z * rho)
            d["a11"] += w * -safe_div(X * Y, ax * rho)
            d["a12"] += w * safe_div(np.ones_like(rho), rho)
            d["a13"] += w * -safe_div(z * Y, ax * rho)
            y_rz = safe_div(Y, rho + z)
            d["d111"] += w * (2.0 * nu * ln_y - safe_div(XX * Y, ax * rho) + k * y_rz)
            d["d122"] += w * (safe_div(Y, rho) - k * y_rz)
            d["d112"] += w * (safe_div(X, rho) - k * safe_div(X, rho + z))
    return _stress_from_potentials(d, z, shape, nu)


def traction_stress(
    x1: ArrayLike,
    x2: ArrayLike,
    x3: ArrayLike,
    half1: ArrayLike,
    half2: ArrayLike,
    nu: float,
    traction: tuple[float, float],
) -> NDArray[np.float64]:
    """Stresses per unit pressure of a shear traction (t1, t2) · p on a rectangle.

    ``traction = (t1, t2)``: the shear traction per unit pressure along x1 and x2 (μ d for full
    sliding along the unit direction d). The x2 part is :func:`rectangle_shear_stress` with the
    axes exchanged (field point, half-widths and tensor components).

    Returns
    -------
    ndarray, shape (..., 6)
        Stress per unit pressure, order (11, 22, 33, 12, 13, 23).
    """
    t1, t2 = traction
    out = np.zeros(())
    if t1 != 0.0:
        out = t1 * rectangle_shear_stress(x1, x2, x3, half1, half2, nu)
    if t2 != 0.0:
        swapped = rectangle_shear_stress(x2, x1, x3, half2, half1, nu)[..., _SWAP_AXES]
        out = out + t2 * swapped
    return out


def surface_load_stress_coefficients(
    cell: tuple[float, float], depths: NDArray[np.float64], nu: float,
    traction: tuple[float, float] | None = None, sampling: int = 1, thickness: float = 0.0,
) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Influence coefficients of a cell's unit pressure on the stress at a set of depths.

    For :class:`sacflow.kernels.convolution.Convolution`: ``coefficients(d1, d2)`` at integer cell
    offsets (sparse grids) returns ``(6 · len(depths), 1, *shape)``, layer-major, six
    components per layer: Love's rectangle (:func:`sacflow.kernels.surface.rectangle_stress_grid`)
    and, with a ``traction`` (t1, t2) per unit pressure, its shear traction's stresses
    (:func:`traction_stress`). One layer at a time, so the closed form's temporaries stay small.
    With ``sampling`` > 1 each coefficient is the mean over the ``sampling³`` sub-cell centres
    of the target cell (layers ``thickness`` [m] thick, :mod:`sacflow.kernels.cell_average`),
    to pair with the cell-averaged residual stress.
    """
    from sacflow.kernels.cell_average import cell_mean, sub_offsets
    from sacflow.kernels.surface import rectangle_stress_sampled

    dx1, dx2 = cell
    h1, h2 = dx1 / 2, dx2 / 2
    depths = np.asarray(depths, dtype=float)
    q = sub_offsets(sampling)

    def coefficients(d1: np.ndarray, d2: np.ndarray) -> np.ndarray:
        out = np.empty((depths.size, 6, *np.broadcast_shapes(d1.shape, d2.shape)))
        for k, depth in enumerate(depths):
            # Love's rectangle at the sub-points of every target cell, on one corner lattice
            s = rectangle_stress_sampled(d1.ravel() * dx1, d2.ravel() * dx2,
                                         depth + q * thickness, (q * dx1, q * dx2), h1, h2, nu)
            if traction is not None:
                s = s + cell_mean(lambda p1, p2, p3, depth=float(depth):
                                  traction_stress(d1 * dx1 + p1, d2 * dx2 + p2, depth + p3,
                                                  h1, h2, nu, traction),
                                  sampling, (dx1, dx2, thickness))
            out[k] = np.moveaxis(s, -1, 0)
        return out.reshape(6 * depths.size, 1, *out.shape[2:])

    return coefficients


def subcell_load_stress_coefficients(
    cell: tuple[float, float], subcells: int, depths: NDArray[np.float64], nu: float,
    traction: tuple[float, float] | None = None, sampling: int = 1, thickness: float = 0.0,
    only: Sequence[tuple[int, int]] | None = None,
) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """Influence coefficients of a unit pressure on each sub-cell of a cell on the body's stress.

    As :func:`surface_load_stress_coefficients`, for a cell cut into ``subcells`` ×
    ``subcells`` sub-cells: ``coefficients(d1, d2)`` returns ``(6 · len(depths), s², *shape)``,
    input channel ``o1 · s + o2`` the stress at the centre of the cell ``(d1, d2)`` cells away
    (or its mean over the ``sampling³`` points) of a unit pressure on sub-cell ``(o1, o2)``:
    Love's rectangle of the sub-cell's size (:func:`sacflow.kernels.surface.rectangle_stress`,
    point by point: the sub-cells' offsets are not whole cells) and, with a ``traction``, its
    shear traction's stresses. The sum over the sub-cells is the cell's own coefficient.
    With ``only``, the sub-cells (o1, o2) listed, in that order, as the input channels
    (:class:`sacflow.kernels.subcell_stress.MirroredSubcellStress` keeps a quarter of them).
    """
    from sacflow.kernels.cell_average import cell_mean, sub_offsets
    from sacflow.kernels.surface import rectangle_stress_sampled

    dx1, dx2 = cell
    half1, half2 = dx1 / (2 * subcells), dx2 / (2 * subcells)
    centres = (np.arange(subcells) + 0.5) / subcells - 0.5  # in cells, from the cell's centre
    depths = np.asarray(depths, dtype=float)
    chosen = list(only) if only is not None else [(o1, o2) for o1 in range(subcells)
                                                  for o2 in range(subcells)]
    q = sub_offsets(sampling)

    def coefficients(d1: np.ndarray, d2: np.ndarray) -> np.ndarray:
        shape = np.broadcast_shapes(d1.shape, d2.shape)
        out = np.empty((depths.size, 6, len(chosen), *shape))
        for k, depth in enumerate(depths):
            for channel, (o1, o2) in enumerate(chosen):
                x1, x2 = (d1 - centres[o1]) * dx1, (d2 - centres[o2]) * dx2
                # the sub-cell's rectangle at the target cells' sub-points, on one lattice
                s = rectangle_stress_sampled(x1.ravel(), x2.ravel(), depth + q * thickness,
                                             (q * dx1, q * dx2), half1, half2, nu)
                if traction is not None:
                    s = s + cell_mean(lambda p1, p2, p3, x1=x1, x2=x2, depth=float(depth):
                                      traction_stress(x1 + p1, x2 + p2, depth + p3, half1,
                                                      half2, nu, traction),
                                      sampling, (dx1, dx2, thickness))
                out[k, :, channel] = np.moveaxis(s, -1, 0)
        return out.reshape(6 * depths.size, len(chosen), *shape)

    return coefficients
