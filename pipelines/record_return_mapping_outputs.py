"""Record what the return mapping gives on a fixed set of trial states.

Writes ``data/return_mapping_outputs.npz``: for isotropic hardening (Swift, linear, perfectly
plastic, tabular with both ends, depth-scaled Swift and tabular) and for isotropic +
Armstrong–Frederick kinematic hardening (several C, γ and backstresses), on random and
structured trial stresses (elastic points, points just past the yield surface, large
increments, shear, pure pressure), the returned stress, plastic strain increment, equivalent
plastic strain increment, plastic flags, backstress and the tangent applied to a fixed stress
perturbation. ``tests/test_return_mapping_regression.py`` compares the current code with them
to 1e-10 of each array's largest value. The outputs were recorded from the two return mappings
(isotropic ``radial_return``, kinematic ``kinematic_return``) before they were merged into
:func:`sacflow.mechanics.return_mapping.return_map` (issue #29); the commit is stored in the
file. Re-record only after a deliberate change
of the model (and say so in the commit):

    python pipelines/record_return_mapping_outputs.py
"""

from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Any

import numpy as np

from sacflow.config.hardening_laws import hardening_from_schema
from sacflow.mechanics.hardening import KinematicLaw
from sacflow.mechanics.return_mapping import return_map
from sacflow.mechanics.return_tangent import ReturnTangent
from sacflow.mechanics.stress_measures import deviator

OUT = Path(__file__).resolve().parents[1] / "data" / "return_mapping_outputs.npz"
E, NU = 210e9, 0.3
MU = E / (2.0 * (1.0 + NU))
#: Trial states per case.
POINTS = 24
SWIFT = {"law": "swift", "B": 1240e6, "C": 30.0, "n": 0.085, "strain_unit": "microstrain"}
TABULAR = {"law": "tabular", "plastic_strain": [0.0, 1e-3, 4e-3, 1e-2],
           "stress": [1.6e9, 1.75e9, 1.8e9, 1.82e9]}
PROFILE = {"depth": [0.0, 50e-6, 150e-6], "factor": [1.3, 1.1, 1.0]}
#: Hardening laws (schema form) by name.
LAWS: dict[str, dict[str, Any]] = {
    "swift": SWIFT,
    "linear": {"law": "linear", "yield_stress": 1.6e9, "modulus": 0.05 * E},
    "perfect": {"law": "perfectly_plastic", "yield_stress": 1.6e9},
    "tabular_constant": TABULAR,
    "tabular_extrapolate": {**TABULAR, "beyond_last": "extrapolate"},
    "swift_depth": {**SWIFT, "depth_profile": PROFILE},
    "tabular_depth": {**TABULAR, "depth_profile": PROFILE},
}
#: Kinematic hardening (C [Pa], γ) by name.
KINEMATIC = {"prager": (50e9, 0.0), "af_mild": (50e9, 200.0), "af_strong": (200e9, 2000.0),
             "none": (0.0, 0.0)}
#: Trial-stress sets: (kind, scale of the trial stress over the initial yield stress).
SETS = {"random": ("random", 1.3), "large": ("random", 8.0), "elastic": ("random", 0.15),
        "structured": ("structured", 1.0)}


def trial_states(kind: str, ratio: float, seed: int) -> tuple[np.ndarray, ...]:
    """Return ``(trial, p, depth, backstress, direction)`` of one set (fixed seed).

    ``random``: Gaussian tensors scaled to ``ratio`` times 1.6 GPa, p in [0, 0.01), depths in
    [0, 200 µm). ``structured``: uniaxial, shear and mixed states at 0.5 to 10 times 1.6 GPa
    (from elastic to just past yield to large increments) and pure pressures.
    """
    rng = np.random.default_rng(seed)
    if kind == "random":
        trial = rng.standard_normal((POINTS, 6)) * ratio * 1.6e9
    else:
        factors = np.geomspace(0.5, 10.0, POINTS // 4)
        axes = np.zeros((4, 6))
        axes[0, 0], axes[1, 3], axes[2, :3] = 1.0, 1.0, [1.0, -0.5, 0.2]
        axes[2, 4] = 0.4
        axes[3, :3] = -1.0  # pure pressure: never yields
        trial = (factors[None, :, None] * axes[:, None, :]).reshape(-1, 6) * 1.6e9
    p = rng.uniform(0.0, 0.01, POINTS)
    p[:4] = 0.0
    depth = rng.uniform(0.0, 200e-6, POINTS)
    backstress = deviator(rng.standard_normal((POINTS, 6))) * 0.2e9
    direction = rng.standard_normal((POINTS, 6)) * 1e8
    return trial, p, depth, backstress, direction


def isotropic_cases() -> dict[str, tuple[str, str]]:
    """Name -> (law, trial set) of the isotropic cases."""
    return {f"iso_{law}_{s}": (law, s) for law in LAWS for s in SETS}


def kinematic_cases() -> dict[str, tuple[str, str, str]]:
    """Name -> (law, kinematic, trial set) of the kinematic cases."""
    return {f"kin_{law}_{kin}_{s}": (law, kin, s)
            for law in ("swift", "perfect", "tabular_depth") for kin in KINEMATIC
            for s in SETS}


def inputs(set_name: str) -> tuple[np.ndarray, ...]:
    """Trial states of ``set_name`` (see :func:`trial_states`)."""
    kind, ratio = SETS[set_name]
    return trial_states(kind, ratio, list(SETS).index(set_name) + 1)


def outputs(law_name: str, kin_name: str | None, set_name: str,
            with_stress: bool = True) -> dict[str, np.ndarray | None]:
    """What the return mapping and its tangent give on one case (names as in the file)."""
    law = hardening_from_schema(LAWS[law_name])
    kin = None if kin_name is None else KinematicLaw(*KINEMATIC[kin_name])
    trial, p, depth, x, direction = inputs(set_name)
    x = None if kin is None else x
    res = return_map(trial, p, law, MU, depth, kinematic=kin, backstress=x,
                     with_stress=with_stress)
    tangent = ReturnTangent(trial, res, p, law, MU, depth, kinematic=kin, backstress=x)
    return {"stress": res.stress, "dep": res.plastic_strain_increment,
            "dp": res.equivalent_plastic_strain_increment, "plastic": res.plastic,
            "backstress": res.backstress, "tangent": tangent.apply(direction)}


def main() -> None:
    arrays: dict[str, np.ndarray] = {}
    cases: dict[str, tuple[str, str | None, str]] = {
        name: (law, None, s) for name, (law, s) in isotropic_cases().items()}
    cases.update(kinematic_cases())
    for name, case in cases.items():
        arrays.update({f"{name}_{key}": value for key, value in outputs(*case).items()
                       if value is not None})
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=OUT.parent).stdout.strip()
    arrays["recorded_at_commit"] = np.array(commit)
    np.savez_compressed(OUT, **arrays)
    print(f"wrote {OUT} (commit {commit}, {len(arrays) - 1} arrays)")


if __name__ == "__main__":
    main()
