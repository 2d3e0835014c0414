r"""Closed-form fields of a normal load on the surface of an elastic half-space.

Conventions
-----------
* SI units; the half-space occupies x3 >= 0 (x3 is the depth, positive *into* the body).
* A compressive contact pressure ``p`` (and a compressive point force ``P``) is positive: it
  pushes the surface in the +x3 direction.
* Stress is positive in tension; a (..., 6) array holds the components in the order
  (11, 22, 33, 12, 13, 23) on its last axis.
* The normal surface displacement u3 is positive into the body (an indentation is positive).

Method
------
Boussinesq's solution written with Love's potentials (Johnson, *Contact Mechanics*, CUP 1985,
§3.2, eqs. 3.7–3.12): for a pressure p(ξ1, ξ2) on the surface, with
ρ = |x − ξ| the distance from the load point,

.. math::

    \psi_1 = \iint p \ln(\rho + x_3)\, d\xi, \qquad
    \varphi_1 = \partial_3 \psi_1 = \iint \frac{p}{\rho}\, d\xi,

the displacements are (G the shear modulus)

.. math::

    u_\alpha = -\frac{(1-2\nu)\psi_{1,\alpha} + x_3 \varphi_{1,\alpha}}{4\pi G}, \qquad
    u_3 = \frac{2(1-\nu)\varphi_1 - x_3 \varphi_{1,3}}{4\pi G},

and Hooke's law (using that ψ1 and φ1 are harmonic) gives, for α, β ∈ {1, 2},

.. math::

    \sigma_{\alpha\beta} &= \frac{\nu}{\pi}\varphi_{1,3}\delta_{\alpha\beta}
        - \frac{1}{2\pi}\left[(1-2\nu)\psi_{1,\alpha\beta} + x_3\varphi_{1,\alpha\beta}\right], \\
    \sigma_{33} &= \frac{1}{2\pi}\left[\varphi_{1,3} - x_3\varphi_{1,33}\right], \qquad
    \sigma_{\alpha 3} = -\frac{x_3}{2\pi}\varphi_{1,\alpha 3}.

(derived here and checked symbolically; the transcription of the seed paper's appendix 2 is not
used).  For a uniform pressure on the rectangle |ξ1| <= h1, |ξ2| <= h2 every second derivative
is a *corner sum*: with X = x1 − ξ1, Y = x2 − ξ2 and a function F(X, Y) such that
∂²F/∂X∂Y equals the integrand,

.. math::

    \iint g\, d\xi = F(x_1+h_1, x_2+h_2) - F(x_1+h_1, x_2-h_2)
                   - F(x_1-h_1, x_2+h_2) + F(x_1-h_1, x_2-h_2).

The corner functions used (terms depending on X alone or Y alone cancel in the sum and are
dropped) are, with ρ = (X² + Y² + x3²)^½ and z = x3:

=============  ==========================================================
quantity       corner function F(X, Y)
=============  ==========================================================
φ1 (z = 0)     X asinh(Y/|X|) + Y asinh(X/|Y|)   (Love 1929)
φ1,3           −atan(XY / (zρ))
φ1,33          XY/ρ · [1/(X² + z²) + 1/(Y² + z²)]
φ1,11          −XY / ((X² + z²) ρ)
φ1,22          −XY / ((Y² + z²) ρ)
φ1,12          1/ρ
φ1,13          −zY / ((X² + z²) ρ)
φ1,23          −zX / ((Y² + z²) ρ)
ψ1,11          atan2(XY(X² + Y²)/(ρ + z), X²ρ + zY²)  (= atan(Y/X) − atan(zY/(Xρ)))
ψ1,22          atan2(XY(X² + Y²)/(ρ + z), Y²ρ + zX²)
ψ1,12          ln(ρ + z)
=============  ==========================================================

The ψ1,11 form combines the two arctangents into one whose denominator never vanishes for
z > 0, so it is continuous where X changes sign: the corner sum is right under the loaded
rectangle, under its edges and outside it.

References
----------
* J. Boussinesq, *Application des potentiels à l'étude de l'équilibre et du mouvement des
  solides élastiques*, Gauthier-Villars, Paris, 1885.
* A. E. H. Love, "The stress produced in a semi-infinite solid by pressure on part of the
  boundary", Phil. Trans. R. Soc. A 228 (1929) 377–420.
* K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985, §3.2–3.3.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sacflow.kernels.lattice import FoldedAxis, SampledAxis
from sacflow.kernels.load_geometry import CORNERS, as_float, point_force, rectangle_points, safe_div

__all__ = [
    "boussinesq_displacement",
    "boussinesq_stress",
    "rectangle_displacement",
    "rectangle_stress",
]

def _x_asinh(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    """Return x asinh(y/|x|), continuous with value 0 at x = 0."""
    ax = np.abs(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        val = x * np.arcsinh(y / np.where(ax == 0.0, 1.0, ax))
    return np.where(ax == 0.0, 0.0, val)


def rectangle_displacement(
    x1: ArrayLike, x2: ArrayLike, half1: ArrayLike, half2: ArrayLike
) -> NDArray[np.float64]:
    r"""Geometric factor of the surface normal displacement under a uniformly loaded rectangle.

    The normal displacement of the surface point (x1, x2, 0) of a half-space (E, ν) under a
    uniform pressure p on |ξ1| <= half1, |ξ2| <= half2 is

    .. math:: u_3 = \frac{1-\nu^2}{\pi E}\, p\, f(x_1, x_2),

    with :math:`f = \iint d\xi / \rho` the corner sum of
    X asinh(Y/|X|) + Y asinh(X/|Y|) (Love 1929; Johnson 1985, §3.3), which equals the
    classic X ln(Y + ρ) + Y ln(X + ρ) up to terms that cancel in the sum.  For two bodies,
    replace (1 − ν²)/E by 1/E*.

    Parameters
    ----------
    x1, x2 : array_like
        Surface coordinates of the field points relative to the rectangle centre [m].
    half1, half2 : array_like
        Half-widths of the rectangle along x1 and x2 [m] (> 0). All inputs broadcast.

    Returns
    -------
    ndarray
        f [m], broadcast shape of the inputs, float64.  Finite everywhere, including on the
        rectangle's edges and corners (f is continuous there).
    """
    x1, x2, h1, h2 = as_float(x1, x2, half1, half2)
    f = np.zeros(np.broadcast_shapes(x1.shape, x2.shape, h1.shape, h2.shape))
    for s1, s2, w in CORNERS:
        X = x1 + s1 * h1
        Y = x2 + s2 * h2
        f = f + w * (_x_asinh(X, Y) + _x_asinh(Y, X))
    return f


def rectangle_stress(
    x1: ArrayLike,
    x2: ArrayLike,
    x3: ArrayLike,
    half1: ArrayLike,
    half2: ArrayLike,
    nu: float,
) -> NDArray[np.float64]:
    r"""Stresses in a half-space per unit uniform pressure on a rectangle (Love 1929).

    Closed form of the superposition of Boussinesq's point-load stresses over
    |ξ1| <= half1, |ξ2| <= half2 (see the module docstring for the corner functions).

    Parameters
    ----------
    x1, x2 : array_like
        Lateral coordinates of the field points relative to the rectangle centre [m].
    x3 : array_like
        Depth of the field points [m], >= 0.  At x3 = 0 the surface limit is returned
        (σ33 = −1 inside, 0 outside); values exactly on the edges at x3 = 0 are singular.
    half1, half2 : array_like
        Half-widths of the rectangle [m] (> 0).  All inputs broadcast.
    nu : float
        Poisson's ratio.

    Returns
    -------
    ndarray, shape (..., 6)
        σ11, σ22, σ33, σ12, σ13, σ23 per unit pressure (dimensionless; multiply by p [Pa]),
        tension positive, compressive pressure positive.

    Raises
    ------
    ValueError
        If any x3 < 0.
    """
    x1, x2, z, h1, h2, shape = rectangle_points(x1, x2, x3, half1, half2)
    # second derivatives of ψ1 and φ1 (corner sums)
    d = {k: np.zeros(shape) for k in _RECTANGLE_TERMS}
    for s1, s2, w in CORNERS:
        for key, term in _rectangle_corner_terms(x1 + s1 * h1, x2 + s2 * h2, z).items():
            d[key] += w * term
    d["p33"] = -(d["p11"] + d["p22"])  # φ1 is harmonic
    return _stress_from_potentials(d, z, nu)


#: Corner functions of Love's rectangle (second derivatives of ψ1 and φ1 but p33).
_RECTANGLE_TERMS = ("p3", "p11", "p22", "p12", "p13", "p23", "s11", "s22", "s12")


def _rectangle_corner_terms(X: NDArray[np.float64], Y: NDArray[np.float64],
                            z: NDArray[np.float64] | np.float64
                            ) -> dict[str, NDArray[np.float64]]:
    """Corner functions of :func:`rectangle_stress` at one corner (``X, Y``: offsets from it)."""
    z2 = z * z
    XX, YY, XY = X * X, Y * Y, X * Y
    rho = np.sqrt(XX + YY + z2)
    a1 = XX + z2
    a2 = YY + z2
    with np.errstate(divide="ignore", invalid="ignore"):
        num = safe_div(XY * (XX + YY), rho + z)
        return {
            "p3": -np.arctan2(XY, z * rho),
            "p11": -safe_div(XY, a1 * rho),
            "p22": -safe_div(XY, a2 * rho),
            "p12": safe_div(np.ones_like(rho), rho),
            "p13": -safe_div(z * Y, a1 * rho),
            "p23": -safe_div(z * X, a2 * rho),
            "s11": np.arctan2(num, XX * rho + z * YY),
            "s22": np.arctan2(num, YY * rho + z * XX),
            "s12": np.log(rho + z),
        }


def rectangle_stress_grid(x1: ArrayLike, x2: ArrayLike, x3: float, half1: float,
                          half2: float, nu: float) -> NDArray[np.float64]:
    """:func:`rectangle_stress` on the grid ``x1 × x2`` at one depth, from the corner lattice.

    For offsets of whole cells (``x = o · 2 half``) the corners of neighbouring offsets
    coincide: the corner functions are evaluated once per lattice point on ``|x1| × |x2|`` and
    differenced (:mod:`sacflow.kernels.lattice`), then mirrored with the parities of the
    components. Equal to :func:`rectangle_stress` to rounding (tests).

    Parameters
    ----------
    x1, x2 : array_like, 1-D
        Lateral offsets of the field points from the rectangle centre [m].
    x3 : float
        Depth [m], > 0.
    half1, half2 : float
        Half-widths of the rectangle [m].
    nu : float
        Poisson's ratio.

    Returns
    -------
    ndarray, shape (len(x1), len(x2), 6)
        As :func:`rectangle_stress`.
    """
    from sacflow.kernels.cuboid import PARITY

    a1, a2 = FoldedAxis(np.ravel(x1), float(half1)), FoldedAxis(np.ravel(x2), float(half2))
    folded = _folded_rectangle_stress(a1, a2, x3, nu)
    out = a2.unfold(a1.unfold(folded, 0), 1)
    for c in range(6):  # a stress component's parity along x1 and x2 (12, 13, 23 odd)
        if PARITY[0, c] < 0:
            out[..., c] *= a1.sign[:, None]
        if PARITY[1, c] < 0:
            out[..., c] *= a2.sign[None, :]
    return out


def rectangle_stress_sampled(x1: ArrayLike, x2: ArrayLike, x3: ArrayLike,
                             sub: tuple[ArrayLike, ArrayLike], half1: float, half2: float,
                             nu: float) -> NDArray[np.float64]:
    """Mean of :func:`rectangle_stress` over sub-points, on the grid ``x1 × x2``.

    The mean over the points ``(x1 + q1, x2 + q2, z)`` for every ``q1`` in ``sub[0]``, ``q2`` in
    ``sub[1]`` and depth ``z`` in ``x3`` (all [m]): a cell-averaged coefficient
    (:mod:`sacflow.kernels.cell_average`). The sub-points of all targets share one corner
    lattice (:class:`~sacflow.kernels.lattice.SampledAxis`), evaluated once per depth; the
    mean is taken on the folded values, each component with its parity. A single point at the
    centre (the centre values) is :func:`rectangle_stress_grid`, whose values it returns.

    Returns
    -------
    ndarray, shape (len(x1), len(x2), 6)
        As :func:`rectangle_stress`.
    """
    from sacflow.kernels.cuboid import PARITY

    depths = np.ravel(x3)
    if depths.size == 1 and not np.any(sub[0]) and not np.any(sub[1]):
        return rectangle_stress_grid(x1, x2, float(depths[0]), half1, half2, nu)
    s1 = SampledAxis(np.ravel(x1), np.ravel(sub[0]), float(half1))
    s2 = SampledAxis(np.ravel(x2), np.ravel(sub[1]), float(half2))
    folded = _folded_rectangle_stress(s1.axis, s2.axis, float(depths[0]), nu)
    for z in depths[1:]:
        folded += _folded_rectangle_stress(s1.axis, s2.axis, float(z), nu)
    folded /= depths.size
    along1 = s1.mean(folded, 0, PARITY[0] < 0)
    return s2.mean(along1, 1, PARITY[1] < 0)


def _folded_rectangle_stress(a1: FoldedAxis, a2: FoldedAxis, x3: float,
                             nu: float) -> NDArray[np.float64]:
    """:func:`rectangle_stress` at the folded offsets ``a1.folded × a2.folded``, depth ``x3``."""
    z = float(x3)
    if not z > 0.0:
        raise ValueError(f"Love's rectangle on a lattice needs a depth > 0, got {z}")
    terms = _rectangle_corner_terms(a1.lattice[:, None], a2.lattice[None, :], np.float64(z))
    d = {key: a2.difference(a1.difference(term, 0), 1) for key, term in terms.items()}
    d["p33"] = -(d["p11"] + d["p22"])  # φ1 is harmonic
    return _stress_from_potentials(d, np.asarray(z), nu)


def _stress_from_potentials(
    d: dict[str, NDArray[np.float64]], z: NDArray[np.float64], nu: float
) -> NDArray[np.float64]:
    """Assemble σ from the second derivatives of Love's potentials ψ1, φ1 (module docstring)."""
    c = 1.0 / (2.0 * np.pi)
    k = 1.0 - 2.0 * nu
    iso = nu / np.pi * d["p3"]
    shape = np.broadcast_shapes(d["p3"].shape, z.shape)
    out = np.empty((*shape, 6))
    out[..., 0] = iso - c * (k * d["s11"] + z * d["p11"])
    out[..., 1] = iso - c * (k * d["s22"] + z * d["p22"])
    out[..., 2] = c * (d["p3"] - z * d["p33"])
    out[..., 3] = -c * (k * d["s12"] + z * d["p12"])
    out[..., 4] = -c * z * d["p13"]
    out[..., 5] = -c * z * d["p23"]
    return out


def boussinesq_stress(
    x1: ArrayLike, x2: ArrayLike, x3: ArrayLike, nu: float
) -> NDArray[np.float64]:
    r"""Stresses of a unit compressive point force at the origin of a half-space (Boussinesq).

    Obtained from the potentials ψ1 = ln(R + x3), φ1 = 1/R, R = |x| (Johnson 1985, eq. 3.20
    in Cartesian form):

    .. math::

        \sigma_{\alpha\beta} &= -\frac{\nu x_3}{\pi R^3}\delta_{\alpha\beta}
           - \frac{1}{2\pi}\Big[(1-2\nu)\Big(\frac{\delta_{\alpha\beta}}{R(R+x_3)}
             - \frac{x_\alpha x_\beta (2R + x_3)}{R^3 (R+x_3)^2}\Big)
             + x_3\Big(\frac{3 x_\alpha x_\beta}{R^5} - \frac{\delta_{\alpha\beta}}{R^3}\Big)
             \Big], \\
        \sigma_{33} &= -\frac{3 x_3^3}{2\pi R^5}, \qquad
        \sigma_{\alpha 3} = -\frac{3 x_\alpha x_3^2}{2\pi R^5}.

    Parameters
    ----------
    x1, x2, x3 : array_like
        Field point relative to the load point [m]; x3 >= 0, not all zero.
    nu : float
        Poisson's ratio.

    Returns
    -------
    ndarray, shape (..., 6)
        Stress per unit force [1/m²] (multiply by P [N]), order (11, 22, 33, 12, 13, 23).
    """
    x1, x2, z, shape, R, R3, R5, Rz = point_force(x1, x2, x3)
    k = 1.0 - 2.0 * nu
    c = 1.0 / (2.0 * np.pi)
    a = 1.0 / (R * Rz)  # diagonal part of ψ1,αβ
    b = (2.0 * R + z) / (R3 * Rz * Rz)  # x_α x_β part of ψ1,αβ
    iso = -nu * z / (np.pi * R3)

    def s_ab(xa: NDArray[np.float64], xb: NDArray[np.float64], delta: float
             ) -> NDArray[np.float64]:
        psi = delta * a - xa * xb * b
        phi = 3.0 * xa * xb / R5 - delta / R3
        stress: NDArray[np.float64] = delta * iso - c * (k * psi + z * phi)
        return stress

    out = np.empty((*shape, 6))
    out[..., 0] = s_ab(x1, x1, 1.0)
    out[..., 1] = s_ab(x2, x2, 1.0)
    out[..., 2] = -3.0 * c * z**3 / R5
    out[..., 3] = s_ab(x1, x2, 0.0)
    out[..., 4] = -3.0 * c * x1 * z * z / R5
    out[..., 5] = -3.0 * c * x2 * z * z / R5
    return out


def boussinesq_displacement(
    x1: ArrayLike, x2: ArrayLike, x3: ArrayLike, nu: float, E: float
) -> NDArray[np.float64]:
    r"""Displacements of a unit compressive point force at the origin of a half-space.

    Johnson (1985) eq. 3.19, with G = E / (2(1+ν)) and R = |x|:

    .. math::

        u_\alpha = \frac{1}{4\pi G}\left[\frac{x_\alpha x_3}{R^3}
                   - \frac{(1-2\nu) x_\alpha}{R (R + x_3)}\right], \qquad
        u_3 = \frac{1}{4\pi G}\left[\frac{2(1-\nu)}{R} + \frac{x_3^2}{R^3}\right].

    On the surface u3 = (1 − ν²)/(π E r).

    Parameters
    ----------
    x1, x2, x3 : array_like
        Field point relative to the load point [m]; x3 >= 0, not all zero.
    nu : float
        Poisson's ratio.
    E : float
        Young's modulus [Pa].

    Returns
    -------
    ndarray, shape (..., 3)
        (u1, u2, u3) per unit force [m/N]; u3 positive into the body.
    """
    x1, x2, z, shape, R, R3, _, Rz = point_force(x1, x2, x3)
    G = E / (2.0 * (1.0 + nu))
    c = 1.0 / (4.0 * np.pi * G)
    lateral = z / R3 - (1.0 - 2.0 * nu) / (R * Rz)
    out = np.empty((*shape, 3))
    out[..., 0] = c * x1 * lateral
    out[..., 1] = c * x2 * lateral
    out[..., 2] = c * (2.0 * (1.0 - nu) / R + z * z / R3)
    return out
