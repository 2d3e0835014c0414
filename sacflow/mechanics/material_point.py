"""Material-point driver: uniaxial and shear cycles of a hardening law (strain or stress control).

Checks a parameter set (isotropic law, kinematic hardening) on the loops it gives before it goes
into a contact run: the same return mapping as the solver
(:func:`sacflow.mechanics.return_mapping.return_map`, with a backstress for kinematic hardening),
driven through a cyclic path of one controlled component, the other stress components held at
zero.

Control (tensor components, order 11, 22, 33, 12, 13, 23):

* ``mode = "uniaxial"``: the 11 component is driven; σ22 = σ33 = 0, shear strains 0.
* ``mode = "shear"``: the 12 component is driven (tensor shear strain ε12 = γ12/2, or σ12);
  σ11 = σ22 = σ33 = 0, ε13 = ε23 = 0.
* ``control = "strain"`` drives the strain, ``"stress"`` the stress of that component.

Path: from 0 to mean + amplitude, then between mean − amplitude and mean + amplitude for
``cycles`` full cycles, ``increments`` increments per half-cycle. Each increment solves the
stress-free (or stress-driven) components by Newton on the unknown strains with the consistent
tangent approximated by central differences of the return mapping (tolerance ``STRESS_TOL`` of
the initial yield stress).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sacflow.mechanics.hardening import HardeningLaw, KinematicLaw
from sacflow.mechanics.return_mapping import return_map

__all__ = ["MaterialHistory", "MaterialPointError", "cycle_path", "material_cycles"]

#: Newton tolerance on the held stress components, relative to the initial yield stress.
STRESS_TOL = 1e-10
#: Newton iterations per increment before :class:`MaterialPointError`.
MAX_NEWTON = 50
#: Relative strain step of the central differences of the tangent.
DIFF_STEP = 1e-7
#: Driven component and the components whose stress is held at zero, per mode.
MODES = {"uniaxial": (0, (1, 2)), "shear": (3, (0, 1, 2))}


class MaterialPointError(RuntimeError):
    """The held stress components could not be brought to their targets."""


@dataclass(frozen=True)
class MaterialHistory:
    """History of a material point over its increments (row 0 = the initial state).

    ``strain``, ``stress``, ``plastic_strain`` and ``backstress`` are (increments + 1, 6)
    tensors in the order of :data:`~sacflow.mechanics.stress_measures.COMPONENTS`,
    ``equivalent_plastic_strain`` is (increments + 1,); ``driven`` is the index of the driven
    component, ``mode`` and ``control`` as given to :func:`material_cycles`.
    """

    strain: np.ndarray
    stress: np.ndarray
    plastic_strain: np.ndarray
    backstress: np.ndarray
    equivalent_plastic_strain: np.ndarray
    driven: int
    mode: str
    control: str


def cycle_path(amplitude: float, cycles: int, increments: int, mean: float = 0.0) -> np.ndarray:
    """Targets of the driven component: 0 → mean + A, then cycles between mean ∓ A.

    ``increments`` increments per half-cycle (the first loading too); returns the targets of the
    increments after the initial state (length (2 cycles + 1) · increments).
    """
    if amplitude <= 0 or cycles < 0 or increments < 1:
        raise ValueError("amplitude > 0, cycles >= 0 and increments >= 1 are needed")
    ends = [mean + amplitude]
    for _ in range(cycles):
        ends += [mean - amplitude, mean + amplitude]
    out, start = [], 0.0
    for end in ends:
        out.append(start + (end - start) * np.arange(1, increments + 1) / increments)
        start = end
    return np.concatenate(out)


#: What one return gives the driver: stress, Δεp, Δp and the backstress after it.
Response = tuple[np.ndarray, np.ndarray, float, np.ndarray]


def material_cycles(law: HardeningLaw, E: float, nu: float, amplitude: float, cycles: int = 2,
                    increments: int = 50, mean: float = 0.0, mode: str = "uniaxial",
                    control: str = "strain", kinematic: KinematicLaw | None = None
                    ) -> MaterialHistory:
    """Drive one material point through a cyclic path (module docstring) and return its history.

    Parameters
    ----------
    law : HardeningLaw
        Isotropic law (:mod:`sacflow.mechanics.hardening`).
    E, nu : float
        Young's modulus [Pa] and Poisson's ratio.
    amplitude, mean : float
        Amplitude and mean of the driven strain (tensor component) or stress [Pa].
    cycles, increments : int
        Full cycles after the first loading; increments per half-cycle.
    mode : {"uniaxial", "shear"}
    control : {"strain", "stress"}
    kinematic : KinematicLaw, optional
        Armstrong–Frederick backstress law combined with ``law``.

    Returns
    -------
    MaterialHistory
        Strain, stress, plastic strain, backstress and equivalent plastic strain at every
        increment (0 = the initial state).

    Raises
    ------
    MaterialPointError
        When Newton on the held components does not converge.
    """
    if mode not in MODES or control not in ("strain", "stress"):
        raise ValueError(f"mode must be one of {list(MODES)} and control 'strain' or 'stress'")
    mu, lam = E / (2.0 * (1.0 + nu)), E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    driven, held = MODES[mode]
    unknown = list(held) + ([driven] if control == "stress" else [])
    scale = float(law.yield_stress(np.zeros(1))[0])
    targets = cycle_path(amplitude, cycles, increments, mean)
    n = targets.size + 1
    hist = {k: np.zeros((n, 6)) for k in ("strain", "stress", "plastic_strain", "backstress")}
    equivalent_plastic_strain = np.zeros(n)
    state = (np.zeros(6), 0.0, np.zeros(6))  # εp, p, X

    def respond(strain: np.ndarray) -> Response:
        ep, p, x = state
        elastic = strain - ep
        trial = 2.0 * mu * elastic
        trial[:3] += lam * elastic[:3].sum()
        ret = return_map(trial, p, law, mu, kinematic=kinematic, backstress=x)
        assert ret.stress is not None  # asked for (the default)
        x_new = x if ret.backstress is None else ret.backstress
        return (ret.stress, ret.plastic_strain_increment,
                float(ret.equivalent_plastic_strain_increment), x_new)

    strain = np.zeros(6)
    for i, target in enumerate(targets, start=1):
        wanted = np.zeros(6)
        if control == "strain":
            strain[driven] = target
        else:
            wanted[driven] = target
        strain = _solve(respond, strain, unknown, wanted, scale, i)
        stress, dep, dp, x_new = respond(strain)
        state = (state[0] + dep, state[1] + dp, x_new)
        hist["strain"][i], hist["stress"][i] = strain, stress
        hist["plastic_strain"][i], hist["backstress"][i] = state[0], x_new
        equivalent_plastic_strain[i] = state[1]
    return MaterialHistory(hist["strain"], hist["stress"], hist["plastic_strain"],
                           hist["backstress"], equivalent_plastic_strain, driven, mode, control)


def _solve(respond: Callable[[np.ndarray], Response], strain: np.ndarray, unknown: list[int],
           wanted: np.ndarray, scale: float,
           increment: int) -> np.ndarray:
    """Newton on the unknown strain components until their stresses equal ``wanted``."""
    strain = strain.copy()
    idx = np.array(unknown)
    for _ in range(MAX_NEWTON):
        residual = respond(strain)[0][idx] - wanted[idx]
        if np.abs(residual).max() <= STRESS_TOL * scale:
            return strain
        h = DIFF_STEP * max(np.abs(strain).max(), scale / 1e11)
        jac = np.empty((idx.size, idx.size))
        for col, k in enumerate(idx):
            plus, minus = strain.copy(), strain.copy()
            plus[k] += h
            minus[k] -= h
            jac[:, col] = (respond(plus)[0][idx] - respond(minus)[0][idx]) / (2.0 * h)
        strain[idx] -= np.linalg.solve(jac, residual)
    raise MaterialPointError(f"increment {increment}: held stresses not reached "
                             f"(residual {np.abs(residual).max():.3e} Pa)")
