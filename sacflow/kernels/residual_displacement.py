r"""Surface normal displacement of a half-space due to a cuboid of uniform eigenstrain.

Conventions
-----------
* SI units; the half-space occupies x3 >= 0 (x3 is the depth, positive *into* the body).
* The normal surface displacement u3 is positive into the body (an indent is positive), as in
  :mod:`sacflow.kernels.surface`; stress is positive in tension.
* Tensor components are ordered (11, 22, 33, 12, 13, 23).  A *unit eigenstrain component* 12
  is the symmetric tensor with ε*_12 = ε*_21 = 1 (tensor, not engineering, shear).
* ``K[..., d]`` is u3 at the surface point (x1, x2, 0) produced by a unit eigenstrain
  component d filling the cuboid |ξ1| <= half1, |ξ2| <= half2, |ξ3 − c3| <= half3 of the
  traction-free half-space (c3 − half3 >= 0).  For an eigenstrain field constant per cuboid,
  ``u3(x) = Σ_cells Σ_d K_d(x − x_cell, c3_cell) ε*_d(cell)``, a 2-D convolution per layer
  (DC-FFT).

Method: reciprocal theorem with initial strains
-----------------------------------------------
State 1: the eigenstrain ε* in the traction-free half-space, displacement u, stress
σ = C:(ε(u) − ε*).  State 2: a unit compressive normal force at the surface point A (pushing in
+x3), Boussinesq's stress σ^B(x − A) and displacement u^B.  Betti's theorem on the half-space
(tractions of state 1 vanish on the whole surface, state 2 has only the point force at A):

.. math::

    \int_V σ^B : ε(u)\, dV = u_3(A), \qquad
    \int_V σ : ε(u^B)\, dV = 0
    \;\Rightarrow\; \int_V (ε(u) − ε^*) : σ^B\, dV = 0,

so :math:`u_3(A) = \int_V ε^*_{ij}\, σ^B_{ij}(x − A)\, dV` (each shear pair counted twice).  For
a deviatoric ε* (plastic strain) σ^B : ε* = 2μ ε^B : ε* (Chiu 1978, doi:10.1115/1.3424292;
Jacq et al. 2002, doi:10.1115/1.1467920, eqs. 2.2–2.3: u3r(A) = 2μ ∫ εp : ε*(A) dV; the seed's
closed forms of that paper are garbled and are not used here).

Closed form.  With the volume point measured from A, (X, Y, Z) = ξ − A (Z >= 0), R = |(X, Y, Z)|
and Love's potentials ψ = ln(R + Z), φ = ∂ψ/∂Z = 1/R of the unit point force
(:mod:`sacflow.kernels.surface`), σ^B is a combination of ψ_,αβ, φ_,ij and Z φ_,ij.  The box
integral of each is an alternating 8-corner sum of a triple antiderivative F (∂X ∂Y ∂Z F equals
the integrand; terms independent of one of X, Y, Z cancel in the sum and are dropped):

* ∫∫∫ φ_,3 → X L_Y + Y L_X − Z T (the Z-antiderivative is φ; then Love's ∫∫ dX dY / R),
* ∫∫∫ ψ_,11 → −X L_Y + Z S (∫ ψ_,1 dZ = −X / (R + Z), then ∫ dY),
* ∫∫∫ ψ_,12 → Z L_Z − R (∫ ψ dZ),
* ∫∫∫ Z φ_,11 → X L_Y,  Z φ_,12 → R,  Z φ_,13 → −Y L_Z − X S (by parts in Z),

with L_X = ln(X + R), L_Y = ln(Y + R), L_Z = ln(R + Z), T = atan(XY / (ZR)) and
S = atan(Y/X) − atan(ZY / (XR)); the 22 and 23 entries follow by X ↔ Y, and ψ_,33 = φ_,3 and
φ_,33 = −φ_,11 − φ_,22 (harmonic potentials).  Assembled with the stress formulas of
:mod:`sacflow.kernels.surface`, the corner functions of K (shear columns doubled) are, with
c = 1/(2π):

=====  ===================================================================
K_11   c [2ν Y L_X − 2ν Z T − (1 − 2ν) Z S(X, Y)]
K_22   c [2ν X L_Y − 2ν Z T − (1 − 2ν) Z S(Y, X)]
K_33   c [2X L_Y + 2Y L_X − Z T]
K_12   −2c [(1 − 2ν) Z L_Z + 2ν R]
K_13   2c [Y L_Z + X S(X, Y)]
K_23   2c [X L_Z + Y S(Y, X)]
=====  ===================================================================

Each entry was checked symbolically (∂X ∂Y ∂Z F − σ^B = 0, exact rational arithmetic at random
points) and the sums are checked against quadrature of Boussinesq's stresses in the tests
(:mod:`sacflow.kernels.quadrature_reference`).

Branches and singular lines.  S is evaluated as the single arctangent
``atan2(XY (X² + Y²) / (R + Z), X² R + Z Y²)``: the subtraction formula holds without a branch
correction (the product of the two arctangent arguments is >= 0), and the denominator is > 0 for
Z > 0 unless X = Y = 0, where S → 0; so S is continuous where X or Y changes sign, i.e. when the
surface point lies above the cuboid.  S(Y, X) = T − S(X, Y) (odd–odd identity of the three
arctangents), so two arctangents serve all components.  At Z = 0 (the top layer touches the
surface) T and S jump across X = 0 or Y = 0, but they only enter multiplied by Z or by the
coordinate that vanishes there; likewise X ln(Y + R) → 0 on the line X = Z = 0, Y < 0, and
R = 0 (a corner at A) gives 0 for every term.  All these limits are continuous, so the corner
sum is exact for every surface point, including points on the planes of the cuboid faces, on
corner lines and right above the centre.  ln(Y + R) is computed as ln((X² + Z²) / (R − Y)) for
Y < 0 (no cancellation).

Accuracy: ≲ 1e-12 of the column maximum against quadrature near the cuboid (tests).  The
8-corner cancellation leaves an absolute round-off of order 1e-16 · r ln r (r the distance):
measured ≲ 1e-12 of the near-field maximum at 500 cells for cubic cells, ≲ 5e-11 for flat
cells (half3 = half1 / 100), i.e. up to ~1e-4 of the (tiny) local value of a far flat cell.
Harmless in a convolution; sums of cells telescope (a uniform layer is exact to ~1e-11).

Layer limit.  A uniform ε33 = e in a wide layer 0 < x3 < t lifts the surface by e t
(u3 = −e t: ∫∫ σ^B_33 dA = −1 on every plane).  A uniform ε11 = ε22 = e in a wide *finite*
block gives u3 → −(1 + 2ν) e t at its centre (∫∫ (σ^B_11 + σ^B_22) dA = −(1 + 2ν)), not the
−2ν e t / (1 − ν) of the laterally infinite, laterally constrained layer: the block's edges
push outward with a line force E e t / (1 − ν) per unit length, whose Cerruti displacement at
the centre, −(1 − 2ν)(1 + ν) e t / (1 − ν), does not decay with the block size (the angle
subtended by the perimeter is 2π for any size); the two add up to −(1 + 2ν) e t.

Performance.  Inputs whose coordinates vary along disjoint axes (x1 with half1, x2 with
half2, c3 with half3, as from ``np.meshgrid(..., sparse=True)`` or ``x[:, None, None]``...)
are evaluated on the lattice of distinct corner coordinates (shared by neighbouring cells) one
depth plane at a time and differenced, after folding x1, x2 to >= 0 with the parities of K
(12, 13 odd in x1; 12, 23 odd in x2); other inputs by an 8-corner loop in blocks.  On large
grids writing the result costs about as much as the folded lattice (``docs/performance.md``).

References
----------
* Y. P. Chiu, "On the stress field and surface deformation in a half space with a cuboidal
  zone in which initial strains are uniform", J. Appl. Mech. 45 (1978) 302–306,
  doi:10.1115/1.3424292.
* C. Jacq, D. Nélias, G. Lormand, D. Girodin, "Development of a three-dimensional
  semi-analytical elastic-plastic contact code", ASME J. Tribol. 124 (2002) 653–667,
  doi:10.1115/1.1467920.
* K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985, §3.2 (Boussinesq),
  §3.5 (Cerruti).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: Float and index arrays of the corner lattices.
FloatArray = NDArray[np.float64]
IndexArray = NDArray[np.intp]

__all__ = ["cuboid_surface_displacement"]

_BLOCK = 1 << 16  # points per block in the 8-corner loop (bounded temporaries)
_SEPARABLE_MIN = 512  # below this many outputs the plain corner loop is used


# ---------------------------------------------------------------------------------------------
# corner functions
# ---------------------------------------------------------------------------------------------


def _ln_sum(a: FloatArray, r: FloatArray, rest2: FloatArray) -> FloatArray:
    """ln(a + r) with r = sqrt(a² + rest2) >= |a|, without cancellation for a < 0.

    Where the argument is 0 (only when its coefficient in the corner functions is 0 too)
    0 is returned instead of −inf.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        arg = np.where(a >= 0.0, a + r, rest2 / (r - a))
    logarithm: FloatArray = np.log(np.where(arg > 0.0, arg, 1.0))
    return logarithm


def _corner_functions(X: FloatArray, Y: FloatArray, Z: FloatArray | float,
                      nu: float) -> FloatArray:
    """Triple antiderivatives of the six columns of K at the corners (X, Y, Z), Z >= 0.

    Returns an array (..., 6) of the broadcast shape of X, Y, Z (module docstring table).
    """
    XX, YY, ZZ = X * X, Y * Y, Z * Z
    R = np.sqrt(XX + YY + ZZ)
    LX = _ln_sum(X, R, YY + ZZ)
    LY = _ln_sum(Y, R, XX + ZZ)
    RZ = R + Z
    LZ = np.log(np.where(RZ > 0.0, RZ, 1.0))
    XY = X * Y
    T = np.arctan2(XY, Z * R)
    S = np.arctan2(XY * (XX + YY) / np.where(RZ > 0.0, RZ, 1.0), XX * R + Z * YY)
    c = 1.0 / (2.0 * np.pi)
    k = 1.0 - 2.0 * nu
    ZT = Z * T
    ZS = Z * S
    shape = np.broadcast_shapes(np.shape(X), np.shape(Y), np.shape(Z))
    out = np.empty((*shape, 6))
    YLX = Y * LX
    XLY = X * LY
    out[..., 0] = c * (2.0 * nu * (YLX - ZT) - k * ZS)
    out[..., 1] = c * (2.0 * nu * (XLY - ZT) - k * (ZT - ZS))
    out[..., 2] = c * (2.0 * (XLY + YLX) - ZT)
    out[..., 3] = -2.0 * c * (k * Z * LZ + 2.0 * nu * R)
    out[..., 4] = 2.0 * c * (Y * LZ + X * S)
    out[..., 5] = 2.0 * c * (X * LZ + Y * (T - S))
    return out


# ---------------------------------------------------------------------------------------------
# evaluation strategies
# ---------------------------------------------------------------------------------------------


def _corner_loop(x1: FloatArray, x2: FloatArray, c3: FloatArray, h1: FloatArray, h2: FloatArray,
                 h3: FloatArray, nu: float, shape: tuple[int, ...]) -> FloatArray:
    """Plain 8-corner sums, point by point, in blocks of at most ``_BLOCK`` points."""
    flat = [np.broadcast_to(a, shape).ravel() for a in (x1, x2, c3, h1, h2, h3)]
    n = flat[0].size
    out = np.zeros((n, 6))
    for start in range(0, n, _BLOCK):
        sl = slice(start, start + _BLOCK)
        a1, a2, a3, b1, b2, b3 = (f[sl] for f in flat)
        acc = out[sl]
        for s1 in (-1.0, 1.0):
            X = s1 * b1 - a1
            for s2 in (-1.0, 1.0):
                Y = s2 * b2 - a2
                for s3 in (-1.0, 1.0):
                    Z = np.maximum(a3 + s3 * b3, 0.0)
                    F = _corner_functions(X, Y, Z, nu)
                    if s1 * s2 * s3 > 0:
                        acc += F
                    else:
                        acc -= F
    return out.reshape((*shape, 6))


def _varying_axes(nd: int, *shapes: tuple[int, ...]) -> tuple[int, ...]:
    """Axes (of an nd-dimensional broadcast) along which arrays of these shapes vary."""
    b = np.broadcast_shapes(*shapes)
    b = (1,) * (nd - len(b)) + tuple(b)
    return tuple(i for i, n in enumerate(b) if n > 1)


def _group(a: FloatArray, b: FloatArray, axes: tuple[int, ...], shape: tuple[int, ...]
           ) -> tuple[FloatArray, FloatArray]:
    """Values of (a, b) along their own axes, flattened in C order."""
    nd = len(shape)
    idx = tuple(slice(None) if i in axes else 0 for i in range(nd))
    sub = tuple(shape[i] if i in axes else 1 for i in range(nd))
    av = np.broadcast_to(a.reshape((1,) * (nd - a.ndim) + a.shape), sub)[idx]
    bv = np.broadcast_to(b.reshape((1,) * (nd - b.ndim) + b.shape), sub)[idx]
    return np.ravel(av), np.ravel(bv)


def _merged_unique(lo: FloatArray, hi: FloatArray) -> tuple[FloatArray, IndexArray, IndexArray]:
    """Distinct values of lo ∪ hi (values within a few ulp merged) and the indices of lo, hi."""
    v = np.concatenate([lo, hi])
    order = np.argsort(v, kind="stable")
    sv = v[order]
    tol = 8.0 * np.finfo(float).eps * max(float(np.max(np.abs(sv))), np.finfo(float).tiny)
    new = np.empty(sv.size, dtype=bool)
    new[0] = True
    new[1:] = np.diff(sv) > tol
    inv = np.empty(v.size, dtype=np.intp)
    inv[order] = np.cumsum(new) - 1
    return sv[new], inv[: lo.size], inv[lo.size :]


def _fold(a: FloatArray, b: FloatArray
          ) -> tuple[FloatArray, FloatArray, IndexArray, NDArray[np.bool_]]:
    """Distinct (|a|, b) pairs, the index of each entry among them, and whether a < 0.

    K is even or odd in x1 (and in x2), so entries at −a reuse the value at +a.
    """
    pairs, inv = np.unique(np.stack([np.abs(a), b], axis=1), axis=0, return_inverse=True)
    return pairs[:, 0], pairs[:, 1], inv.ravel(), a < 0.0


def _lattice_plane(X: FloatArray, Y: FloatArray, z: float, nu: float, buf: FloatArray
                   ) -> FloatArray:
    """Corner functions on the lattice X × Y at depth z, in row blocks, into ``buf``."""
    rows = max(1, _BLOCK // max(1, Y.size))
    for start in range(0, X.size, rows):
        sl = slice(start, start + rows)
        buf[sl] = _corner_functions(X[sl, None], Y[None, :], z, nu)
    return buf


def _separable(x1: FloatArray, x2: FloatArray, c3: FloatArray, h1: FloatArray, h2: FloatArray,
               h3: FloatArray, nu: float, shape: tuple[int, ...],
               axes: tuple[tuple[int, ...], ...]) -> FloatArray:
    """Corner sums on the lattice of distinct corner coordinates, one depth plane at a time.

    Lateral offsets are folded to x1, x2 >= 0 by the parities of K (components 12, 13 odd in
    x1; 12, 23 odd in x2), the lattice function is differenced in x1 and x2 per plane, then in
    depth between the two planes of each cuboid.
    """
    a1, b1 = _group(x1, h1, axes[0], shape)
    a2, b2 = _group(x2, h2, axes[1], shape)
    a3, b3 = _group(c3, h3, axes[2], shape)
    f1, g1, inv1, neg1 = _fold(a1, b1)
    f2, g2, inv2, neg2 = _fold(a2, b2)
    U1, lo1, hi1 = _merged_unique(-f1 - g1, -f1 + g1)
    U2, lo2, hi2 = _merged_unique(-f2 - g2, -f2 + g2)
    U3, lo3, hi3 = _merged_unique(np.maximum(a3 - b3, 0.0), a3 + b3)
    uses = np.bincount(np.concatenate([lo3, hi3]), minlength=U3.size)
    buf = np.empty((U1.size, U2.size, 6))
    planes: dict[int, NDArray[np.float64]] = {}

    def plane(i: int) -> NDArray[np.float64]:
        if i not in planes:
            F = _lattice_plane(U1, U2, float(U3[i]), nu, buf)
            G = np.take(F, hi1, axis=0)
            G -= np.take(F, lo1, axis=0)
            H = np.take(G, hi2, axis=1)
            H -= np.take(G, lo2, axis=1)
            planes[i] = H
        p = planes[i]
        uses[i] -= 1
        if uses[i] == 0:
            del planes[i]
        return p

    # unfold: gather from [red, -red] so that the parity signs come with the gather
    n_red = f1.size * f2.size
    idx = (inv1[:, None] * f2.size + inv2[None, :]).ravel()
    odd1 = n_red * neg1[:, None]
    odd2 = n_red * neg2[None, :]
    gather = {
        0: idx,
        1: idx,
        2: idx,
        3: idx + ((odd1 + odd2) % (2 * n_red)).ravel(),
        4: idx + np.broadcast_to(odd1, (a1.size, a2.size)).ravel(),
        5: idx + np.broadcast_to(odd2, (a1.size, a2.size)).ravel(),
    }
    out = np.empty((a3.size, 6, a1.size, a2.size))  # each (x1, x2) plane contiguous
    ext = np.empty(2 * n_red)
    for k in range(a3.size):
        red = plane(hi3[k]) - plane(lo3[k])
        for d in range(6):
            ext[:n_red] = red[..., d].ravel()
            np.negative(ext[:n_red], out=ext[n_red:])
            np.take(ext, gather[d], out=out[k, d].reshape(-1), mode="clip")
    # back to the broadcast layout
    sizes = [shape[i] for i in axes[2]] + [6]
    sizes += [shape[i] for i in axes[0]] + [shape[i] for i in axes[1]]
    labels = [*axes[2], -1, *axes[0], *axes[1]]
    rest = [i for i in range(len(shape)) if i not in labels]
    out = out.reshape(sizes + [1] * len(rest))
    labels += rest
    return np.transpose(out, [labels.index(i) for i in range(len(shape))] + [labels.index(-1)])


def cuboid_surface_displacement(
    x1: ArrayLike,
    x2: ArrayLike,
    c3: ArrayLike,
    half1: ArrayLike,
    half2: ArrayLike,
    half3: ArrayLike,
    nu: float,
) -> NDArray[np.float64]:
    r"""Surface normal displacement per unit eigenstrain component of a buried cuboid.

    .. math::

        K_d(x_1, x_2) = w_d \int_{\text{cuboid}} σ^B_d(ξ_1 - x_1, ξ_2 - x_2, ξ_3)\, dξ,
        \qquad w = (1, 1, 1, 2, 2, 2),

    the reciprocal-theorem integral of Boussinesq's stress (unit compressive force at the
    surface point) over the cuboid |ξ1| <= half1, |ξ2| <= half2, |ξ3 − c3| <= half3, in
    closed form (8-corner sums; module docstring; Chiu 1978, doi:10.1115/1.3424292; Jacq et
    al. 2002, doi:10.1115/1.1467920, eqs. 2.3–2.7).

    Parameters
    ----------
    x1, x2 : array_like
        Surface point relative to the lateral centre of the cuboid [m].  Any value, including
        points on the planes of the faces, on corner lines, and right above the centre.
    c3 : array_like
        Depth of the cuboid centre [m]; c3 − half3 >= 0 (c3 = half3: the top layer of cells,
        touching the surface).
    half1, half2, half3 : array_like
        Half sizes of the cuboid [m] (>= 0).  All inputs broadcast.
    nu : float
        Poisson's ratio.

    Returns
    -------
    ndarray, shape (..., 6)
        u3 [m] per unit eigenstrain (dimensionless) for each component
        (11, 22, 33, 12, 13, 23) on the last axis, positive into the body; a unit shear
        component d means ε*_ij = ε*_ji = 1.  Independent of the elastic modulus.  For
        separable inputs (Notes) the result is a transposed view of an array stored depth
        first, then component, each (x1, x2) plane contiguous (the layout per-layer FFTs
        want); ``np.ascontiguousarray`` gives a C-ordered copy.

    Raises
    ------
    ValueError
        If the cuboid reaches above the surface (c3 − half3 < 0) or a half size is negative.

    Notes
    -----
    Separable inputs (x1/half1, x2/half2, c3/half3 varying along disjoint axes, e.g.
    ``x1[:, None, None], x2[None, :, None], c3[None, None, :]``) are evaluated on the shared
    corner lattice: 1000 × 1000 lateral offsets × 64 depths take a few seconds.
    """
    x1, x2, c3, h1, h2, h3 = (
        np.asarray(a, dtype=np.float64) for a in (x1, x2, c3, half1, half2, half3)
    )
    if np.any(h1 < 0.0) or np.any(h2 < 0.0) or np.any(h3 < 0.0):
        raise ValueError("half1, half2, half3 are half sizes and must be >= 0")
    top = c3 - h3
    tol = 1e-12 * np.maximum(np.abs(c3), h3)
    if np.any(top < -tol):
        raise ValueError(
            "the cuboid must lie in the half-space: c3 - half3 >= 0 (c3 is the depth of its "
            "centre, x3 positive into the body)"
        )
    shape = np.broadcast_shapes(x1.shape, x2.shape, c3.shape, h1.shape, h2.shape, h3.shape)
    nd = len(shape)
    axes = (
        _varying_axes(nd, x1.shape, h1.shape),
        _varying_axes(nd, x2.shape, h2.shape),
        _varying_axes(nd, c3.shape, h3.shape),
    )
    disjoint = len(set(axes[0]) | set(axes[1]) | set(axes[2])) == sum(map(len, axes))
    if disjoint and int(np.prod(shape)) >= _SEPARABLE_MIN:
        return _separable(x1, x2, c3, h1, h2, h3, float(nu), shape, axes)
    return _corner_loop(x1, x2, c3, h1, h2, h3, float(nu), shape)
