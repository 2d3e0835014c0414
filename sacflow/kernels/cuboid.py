r"""Stress of a cuboid of uniform eigenstrain in an infinite isotropic elastic space.

Conventions
-----------
* SI units; ``x3`` is depth (positive into the body), but nothing here depends on the direction
  of an axis: the space is infinite.  Stress is positive in tension.
* Field points ``(x1, x2, x3)`` are measured from the centre of the cuboid
  ``|ξ_i| <= half_i``.  Arguments are arrays of any broadcastable shapes.
* Tensor components are ordered ``(11, 22, 33, 12, 13, 23)``.  A *unit eigenstrain component*
  ``12`` is the symmetric tensor with ``ε*_12 = ε*_21 = 1`` (tensor, not engineering, shear).
  Output shear components are tensor stresses ``σ_12, σ_13, σ_23``.
* ``A[..., c, d]`` is stress component ``c`` produced by unit eigenstrain component ``d``.  The
  stress is ``σ = C:(ε − ε* H)`` with ``H = 1`` inside the cuboid: inside, it includes ``−C:ε*``.

Method (Chiu 1977, doi:10.1115/1.3424384; Mura 1987, *Micromechanics of Defects in Solids*, §11)
-----------------------------------------------------------------------------------------------
The displacement of an eigenstrain ``ε*`` uniform in a domain ``V`` follows from Kelvin's
solution ``G_ij = [(3 − 4ν) δ_ij / r + r_i r_j / r³] / (16 π μ (1 − ν))``:

.. math::

    u_i = -C_{jlmn} ε^*_{mn} \int_V G_{ij,l}(x - x')\, dV'
        = \frac{ψ_{,ijl} ε^*_{jl} - 2 ν ε^*_{mm} φ_{,i} - 4 (1 - ν) ε^*_{il} φ_{,l}}{8 π (1 - ν)},

with the potentials ``φ = ∫_V dV'/|x − x'|`` and ``ψ = ∫_V |x − x'| dV'`` (``∇²ψ = 2φ``,
``∇²φ = −4π H``).  The displacement gradient needs ``ψ_,ijkl`` and ``φ_,ij``.  Over a box each is
an alternating sum over the eight corners ``c`` (``y = x − c``, ``R = |y|``, sign
``s_c = +1`` when an even number of the corner coordinates are upper bounds, i.e.
``s_c = Π_i (−σ_i)`` for ``c = (σ_1 half_1, σ_2 half_2, σ_3 half_3)``):

=================  ==========================================================================
``φ_,11``          ``Σ s_c [−atan(y2 y3 / (y1 R))]``
``φ_,12``          ``Σ s_c asinh(y3 / ρ12)``,  ``ρ12² = y1² + y2²``
``ψ_,1111``        ``Σ s_c [−2 atan(y2 y3 / (y1 R)) + y1 y2 y3 / R · (1/ρ12² + 1/ρ13²)]``
``ψ_,1112``        ``Σ s_c [asinh(y3 / ρ12) − y1² y3 / (ρ12² R)]``
``ψ_,1122``        ``Σ s_c [−y1 y2 y3 / (ρ12² R)]``
``ψ_,1123``        ``Σ s_c y1 / R``
=================  ==========================================================================

and index permutations (``ψ_,ijkl`` depends only on how often each index occurs).  Each entry
was derived from the antiderivative conditions (e.g. ``∂2∂3 F = R_,111`` for ``ψ_,1111``,
``∂3 F = R_,11`` for ``ψ_,1112``) and verified symbolically; the tests compare the result with
quadrature of Kelvin's solution (:mod:`sacflow.kernels.quadrature_reference`).  The seed
paper's appendix 1 (garbled transcription) lists
``D = −π² ×`` these functions; its ``γ3 ln((R + |γ3|)/ρ)`` reads ``sign(γ3) ln(...) = asinh(γ3/ρ)``
up to a ``ln ρ`` that cancels in the corner sum.  Each corner term is smooth for ``y_i ≠ 0``, so
the sums are exact everywhere off the planes ``x_i = ±half_i``; the ``atan`` terms carry the jump
of the strain across the faces (``Σ_i φ_,ii = −4π`` inside, ``0`` outside), no case split needed.

Validity: points exactly on a face plane ``x_i = ±half_i`` are not supported: on a face a
one-sided value is returned, on an edge line or its extension (two coordinates at ``±half``)
NaN.  Cell-centre offsets ``x_i = k_i · 2 half_i`` never lie there (``y_i`` is an odd multiple
of ``half_i``), which is how the DC-FFT operators use this kernel.

Accuracy: ≤ 2e-12 relative to quadrature near the cuboid (tests).  Round-off in the 8-corner
cancellation grows like ``(r/half)³ · 1e-16`` relative to the local value: ≈ 1e-8 of the local
value at 250 cells, i.e. ≈ 1e-16 of the near-field coefficients, harmless in a convolution.

Performance: vectorised over points, processed in blocks of ``2**17`` points (8 corners and a
fixed set of sums per block).  Separable grids (each coordinate varying along its own axis, as
from ``np.meshgrid(..., sparse=True)``) are evaluated on ``|x_i|`` only and mirrored with the
reflection rule ``A_cd(R_i x) = s_c s_d A_cd(x)``, ``s = (−1)^(times i occurs in the component)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "COMPONENTS",
    "PARITY",
    "cuboid_stress",
    "cuboid_stress_component",
    "SHEAR_WEIGHTS",
    "lame_lambda",
    "unit_eigenstrain",
    "stiffness_matrix",
]

#: Tensor index pairs of the 6 components, in the order (11, 22, 33, 12, 13, 23).
COMPONENTS: tuple[tuple[int, int], ...] = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))

#: Sign of each component under the reflection of axis i, ``PARITY[i, c]``: −1 when the axis
#: occurs an odd number of times in the component (12 and 13 flip with x1, 12 and 23 with x2).
PARITY = np.array([[(-1.0) ** pair.count(axis) for pair in COMPONENTS] for axis in range(3)])
#: Weights of the components (11, 22, 33, 12, 13, 23) in ε*:σ with tensor shear components
#: (tensor shears count twice; also the reciprocity weights of the eigenstrain kernels).
SHEAR_WEIGHTS = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])
SHEAR_WEIGHTS.setflags(write=False)

_MAX_POINTS = 1 << 17  # points per block in the corner sums (bounded temporaries)
#: The corner sums ``(T, L, Q, M, N)`` of :func:`_corner_sums` (M keyed by an axis pair).
CornerSums = tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray],
                   dict[tuple[int, int], np.ndarray], list[np.ndarray]]


def lame_lambda(nu: float, mu: float) -> float:
    """Lamé's first parameter λ = 2 μ ν / (1 − 2 ν)."""
    return 2.0 * mu * nu / (1.0 - 2.0 * nu)


def stiffness_matrix(nu: float, mu: float) -> np.ndarray:
    """Isotropic stiffness acting on tensor components: ``σ[c] = Σ_d C[c, d] ε[d]``.

    The columns 12, 13, 23 act on *tensor* shear strains, so ``C[3, 3] = 2 μ`` (one entry of
    the symmetric pair; the contribution of ``ε_21`` is folded in).
    """
    lam = lame_lambda(nu, mu)
    c = np.zeros((6, 6))
    c[:3, :3] = lam
    c[[0, 1, 2], [0, 1, 2]] += 2.0 * mu
    c[[3, 4, 5], [3, 4, 5]] = 2.0 * mu
    return c


def unit_eigenstrain(source: int) -> np.ndarray:
    """3×3 symmetric unit eigenstrain for component ``source`` (tensor convention)."""
    if not 0 <= int(source) <= 5:
        raise ValueError(f"source must be an eigenstrain component index 0..5, got {source!r}")
    i, j = COMPONENTS[int(source)]
    e = np.zeros((3, 3))
    e[i, j] = e[j, i] = 1.0
    return e


# ---------------------------------------------------------------------------------------------
# corner sums of the potentials
# ---------------------------------------------------------------------------------------------


def _corner_sums(y0: np.ndarray, y1: np.ndarray, y2: np.ndarray, h: Sequence[float]
                 ) -> CornerSums:
    """Compute the 8-corner sums for field points ``y`` (dimensionless, broadcastable), box ``h``.

    Returns ``T[i] = Σ s atan(y_j y_k / (y_i R))``, ``L[k] = Σ s asinh(y_k / ρ_ij)``,
    ``Q[k] = Σ s y_1 y_2 y_3 / (ρ_ij² R)``, ``M[(i, j)] = Σ s y_i² y_k / (ρ_ij² R)`` and
    ``N[i] = Σ s y_i / R`` where ``(i, j, k)`` is a permutation of ``(0, 1, 2)``; Q and L are
    indexed by the missing axis ``k``.
    """
    x = (y0, y1, y2)
    shape = np.broadcast_shapes(*(np.shape(a) for a in x))
    T = [np.zeros(shape) for _ in range(3)]
    L = [np.zeros(shape) for _ in range(3)]
    Q = [np.zeros(shape) for _ in range(3)]
    N = [np.zeros(shape) for _ in range(3)]
    M = {(i, j): np.zeros(shape) for i in range(3) for j in range(3) if i != j}
    for s1 in (-1.0, 1.0):
        for s2 in (-1.0, 1.0):
            for s3 in (-1.0, 1.0):
                sign = -s1 * s2 * s3  # + for an even number of upper bounds
                y = (x[0] - s1 * h[0], x[1] - s2 * h[1], x[2] - s3 * h[2])
                sq = (y[0] * y[0], y[1] * y[1], y[2] * y[2])
                inv_r = 1.0 / np.sqrt(sq[0] + sq[1] + sq[2])
                add = np.add if sign > 0 else np.subtract
                prod = y[0] * y[1] * y[2]
                for i in range(3):
                    j, k = (i + 1) % 3, (i + 2) % 3
                    # atan(y_j y_k / (y_i R))
                    add(T[i], np.arctan((y[j] * y[k] / y[i]) * inv_r), out=T[i])
                    # pair (i, j) with third axis k
                    rho2 = sq[i] + sq[j]
                    add(L[k], np.arcsinh(y[k] / np.sqrt(rho2)), out=L[k])
                    yk_r = y[k] * inv_r
                    add(N[k], yk_r, out=N[k])
                    q = (prod / rho2) * inv_r
                    add(Q[k], q, out=Q[k])
                    mi = (sq[i] / rho2) * yk_r
                    add(M[(i, j)], mi, out=M[(i, j)])
                    add(M[(j, i)], yk_r - mi, out=M[(j, i)])
    return T, L, Q, M, N


def _psi4(sums: CornerSums, idx: tuple[int, ...]) -> np.ndarray:
    """``ψ_,ijkl`` (dimensionless) from the corner sums, for the index multiset ``idx``."""
    T, L, Q, M, N = sums
    counts = [idx.count(a) for a in range(3)]
    if 4 in counts:  # ψ,iiii
        i = counts.index(4)
        j, k = (i + 1) % 3, (i + 2) % 3
        return -2.0 * T[i] + Q[k] + Q[j]
    if 3 in counts:  # ψ,iiij
        i, j = counts.index(3), counts.index(1)
        k = 3 - i - j
        return L[k] - M[(i, j)]
    if counts.count(2) == 2:  # ψ,iijj
        return -Q[counts.index(0)]
    return N[counts.index(2)]  # ψ,iijk


def _phi2(sums: CornerSums, i: int, j: int) -> np.ndarray:
    """``φ_,ij`` (dimensionless) from the corner sums."""
    T, L = sums[0], sums[1]
    if i == j:
        return -T[i]
    return L[3 - i - j]


def stress_from_sums(sums: CornerSums, inside: np.ndarray | float, sources: Sequence[int],
                     nu: float, mu: float) -> np.ndarray:
    """Stress columns ``(…, 6, len(sources))`` for unit eigenstrains from the corner sums.

    ``inside``: True (or 1.0) at the points inside the cuboid, where the eigenstrain's own
    stress-free part is taken off.
    """
    lam = lame_lambda(nu, mu)
    k = 1.0 / (8.0 * math.pi * (1.0 - nu))
    phi = {(i, j): _phi2(sums, i, j) for i in range(3) for j in range(i, 3)}

    def ph(i: int, j: int) -> np.ndarray:
        return phi[(min(i, j), max(i, j))]

    shape = sums[0][0].shape
    out = np.empty((*shape, 6, len(sources)))
    for col, d in enumerate(sources):
        m, n = COMPONENTS[d]
        e_star = unit_eigenstrain(d)
        theta = float(np.trace(e_star))
        weight = 1.0 if m == n else 2.0  # ψ,ijkl ε*_kl sums the pair (mn), (nm)
        strain: dict[tuple[int, int], np.ndarray] = {}
        for i, j in COMPONENTS:
            val = weight * _psi4(sums, (i, j, m, n))
            if theta:
                val = val - 2.0 * nu * theta * ph(i, j)
            # −4(1−ν) · ½ (ε*_ik φ,kj + ε*_jk φ,ki)
            sym = sum(e_star[i, a] * ph(a, j) + e_star[j, a] * ph(a, i) for a in range(3))
            strain[(i, j)] = k * (val - 2.0 * (1.0 - nu) * sym)
        trace = strain[(0, 0)] + strain[(1, 1)] + strain[(2, 2)]
        for c, (i, j) in enumerate(COMPONENTS):
            sig = 2.0 * mu * strain[(i, j)]
            free = 2.0 * mu * e_star[i, j]
            if i == j:
                sig = sig + lam * trace
                free += lam * theta
            if free:
                sig = sig - free * inside
            out[..., c, col] = sig
    return out


# ---------------------------------------------------------------------------------------------
# blocking and the reflection-symmetry fast path
# ---------------------------------------------------------------------------------------------


def _aligned(xs: Sequence[ArrayLike]) -> tuple[list[np.ndarray], tuple[int, ...]]:
    """Arrays broadcast-aligned to a common ndim (at least 1) and the broadcast shape."""
    arrays = [np.asarray(a, dtype=float) for a in xs]
    shape = np.broadcast_shapes(*(a.shape for a in arrays))
    nd = max(1, len(shape))
    arrays = [a.reshape((1,) * (nd - a.ndim) + a.shape) for a in arrays]
    return arrays, np.broadcast_shapes(*(a.shape for a in arrays))


def _blocked(xs: Sequence[np.ndarray], shape: tuple[int, ...], half: Sequence[float],
             sources: Sequence[int], nu: float, mu: float) -> np.ndarray:
    """Evaluate on broadcast-aligned ``xs`` in blocks of at most ~``_MAX_POINTS`` points."""
    out = np.empty((*shape, 6, len(sources)))
    scale = max(half)
    h = tuple(hh / scale for hh in half)
    # split along the first axis whose trailing block fits
    ax = 0
    while ax < len(shape) - 1 and math.prod(shape[ax + 1 :]) > _MAX_POINTS:
        ax += 1
    step = max(1, _MAX_POINTS // max(1, math.prod(shape[ax + 1 :])))
    for lead in np.ndindex(*shape[:ax]):
        for start in range(0, shape[ax], step):
            sl = (*lead, slice(start, start + step))
            part = []
            for a in xs:
                idx = tuple(
                    0 if a.shape[d] == 1 and d < ax else (s if a.shape[d] > 1 else slice(None))
                    for d, s in enumerate(sl)
                )
                part.append(a[idx] / scale)
            y0, y1, y2 = part
            inside = (np.abs(y0) < h[0]) & (np.abs(y1) < h[1]) & (np.abs(y2) < h[2])
            with np.errstate(divide="ignore", invalid="ignore"):
                sums = _corner_sums(y0, y1, y2, h)
                out[sl] = stress_from_sums(sums, inside, sources, nu, mu)
    return out


def _odd_count(c: int, axis: int) -> int:
    """How many times ``axis`` appears in component ``c`` (parity under reflecting ``axis``)."""
    return COMPONENTS[c].count(axis)


def _evaluate(x1: ArrayLike, x2: ArrayLike, x3: ArrayLike, half: Sequence[float],
              sources: Sequence[int], nu: float, mu: float) -> np.ndarray:
    """Stress columns ``(…, 6, len(sources))``; uses reflection symmetry on separable grids."""
    halves = checked_half_sizes(half, nu)
    xs, shape = _aligned((x1, x2, x3))
    axes = [[d for d, n in enumerate(a.shape) if n > 1] for a in xs]
    varying = [a[0] for a in axes if a]
    separable = all(len(a) <= 1 for a in axes) and len(varying) == len(set(varying))
    if not separable:
        return _blocked(xs, shape, halves, sources, nu, mu)
    # A(R_i x) = S_i A(x) S_i for the reflection R_i of axis i: evaluate on |x_i| only.
    reduced, inverse, signs = [], [], []
    for a in xs:
        u, inv = np.unique(np.abs(a.ravel()), return_inverse=True)
        reduced.append(u.reshape([len(u) if n > 1 else 1 for n in a.shape]))
        inverse.append(inv.reshape(-1))
        signs.append(np.where(a < 0.0, -1.0, 1.0))
    red_shape = np.broadcast_shapes(*(r.shape for r in reduced))
    if math.prod(red_shape) > 0.7 * math.prod(shape):
        return _blocked(xs, shape, halves, sources, nu, mu)
    out = _blocked(reduced, red_shape, halves, sources, nu, mu)
    for varied, inv in zip(axes, inverse, strict=True):
        if varied:
            out = np.take(out, inv, axis=varied[0])
    _mirror_signs(out, sources, signs)
    return out


def checked_half_sizes(half: Sequence[float], nu: float) -> tuple[float, float, float]:
    """Return the half sizes as floats after checking them and the Poisson ratio."""
    halves = tuple(float(h) for h in half)
    if any(not (h > 0.0 and math.isfinite(h)) for h in halves):
        raise ValueError(f"cuboid half sizes must be positive and finite, got {halves}")
    if not (-1.0 < nu < 0.5):
        raise ValueError(f"Poisson ratio must lie in (-1, 0.5), got {nu}")
    h1, h2, h3 = halves
    return h1, h2, h3


def _mirror_signs(out: np.ndarray, sources: Sequence[int], signs: list[np.ndarray]) -> None:
    """Apply in place the sign ``S_i A S_i`` of each reflected axis to the mirrored columns.

    Entry ``(c, d)`` changes sign under the reflection of an axis when that axis appears an odd
    number of times in ``c`` and ``d`` together; ``signs[axis]`` is −1 where ``x_axis < 0``.
    """
    for col, d in enumerate(sources):
        for c in range(6):
            factor = None
            for axis in range(3):
                if (_odd_count(c, axis) + _odd_count(d, axis)) % 2:
                    factor = signs[axis] if factor is None else factor * signs[axis]
            if factor is not None:
                out[..., c, col] *= factor


def cuboid_stress(x1: ArrayLike, x2: ArrayLike, x3: ArrayLike, half1: float, half2: float,
                  half3: float, nu: float, mu: float) -> np.ndarray:
    """Influence matrix of a cuboid of uniform eigenstrain in an infinite elastic space.

    Chiu, J. Appl. Mech. 44 (1977) 587, doi:10.1115/1.3424384; Mura (1987) §11.  See the
    module docstring for the formulas and their range of validity.

    Parameters
    ----------
    x1, x2, x3 : array_like
        Field point relative to the cuboid centre [m], broadcastable shapes.
    half1, half2, half3 : float
        Half sizes of the cuboid ``|ξ_i| <= half_i`` [m].
    nu : float
        Poisson ratio.
    mu : float
        Shear modulus [Pa].

    Returns
    -------
    ndarray, shape ``(..., 6, 6)``
        ``A[..., c, d]``: stress component ``c`` [Pa] produced by the unit eigenstrain component
        ``d`` (order 11, 22, 33, 12, 13, 23; tensor shear).  Inside, ``A`` includes ``−C:ε*``.

    Notes
    -----
    Memory: the result takes 288 bytes a point; prefer :func:`cuboid_stress_component` on large
    grids.  Separable grids (each coordinate varying along one distinct axis, e.g. from
    ``np.meshgrid(..., sparse=True)``) are evaluated on ``|x_i|`` only and mirrored.
    """
    return _evaluate(x1, x2, x3, (half1, half2, half3), tuple(range(6)), nu, mu)


def cuboid_stress_component(x1: ArrayLike, x2: ArrayLike, x3: ArrayLike, half1: float,
                            half2: float, half3: float, nu: float, mu: float,
                            source: int) -> np.ndarray:
    """Stress of a cuboid of unit eigenstrain component ``source`` in an infinite space.

    Column ``source`` of :func:`cuboid_stress` (same parameters), computed without the other
    five: ``σ = C:(ε − ε* H)`` with ``ε`` from the Eshelby/Mura potentials (doi:10.1115/1.3424384).

    Parameters
    ----------
    x1, x2, x3, half1, half2, half3, nu, mu
        As in :func:`cuboid_stress`.
    source : int
        Eigenstrain component 0..5 (11, 22, 33, 12, 13, 23; unit *tensor* value, so ``3`` means
        ``ε*_12 = ε*_21 = 1``).

    Returns
    -------
    ndarray, shape ``(..., 6)``
        Stress components (11, 22, 33, 12, 13, 23) [Pa].
    """
    unit_eigenstrain(source)
    return _evaluate(x1, x2, x3, (half1, half2, half3), (int(source),), nu, mu)[..., 0]
