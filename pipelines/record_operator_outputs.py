"""Record what the eigenstrain operator and one elastic-plastic step give on small grids.

Writes ``data/operator_outputs.npz``: for three small boxes (anisotropic, cubic and flat
cuboids) a fixed random plastic-strain field, the residual stress and residual surface
displacement the operator gives for it, and for one elastic-plastic load step the plastic
strain, residual stress, stress and contact pressure (with the step's case, as JSON).
``tests/test_operator_regression.py`` compares the current code with them to 1e-10 of each
field's largest value: a change of how the kernels are computed, stored or cached must not
change results. Re-record only after a deliberate change of the physics or of the
discretisation (and say so in the commit):

    python pipelines/record_operator_outputs.py

The step is solved with contact and plasticity tolerances of :data:`STEP_TOLERANCE`, far below
the comparison's 1e-10. An iterative solve stops somewhere within its tolerance, and where it
stops depends on round-off: the same code gives a step differing by about ten times the contact
tolerance on another CPU (numpy's AVX-512 or AVX2 loops for the transcendental functions,
OpenBLAS's dot-product kernels), 1e-9 of the plastic strain at the default 1e-10. At 1e-13 the
solvers' stopping points lie below round-off and two CPUs, or the code before and after the
kernels' rewrite, agree to about 1e-13, so the 1e-10 comparison tests the operators and the
solver, not the machine.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np

from sacflow.config.solver_inputs import simulation_for
from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.storage.case_file import case_from_dict

OUT = Path(__file__).resolve().parents[1] / "data" / "operator_outputs.npz"
E, NU = 210e9, 0.3
#: (shape, spacing [m]) of the operator boxes
BOXES = {
    "anisotropic": ((5, 4, 3), (1.0e-6, 1.3e-6, 0.7e-6)),
    "cubic": ((8, 8, 4), (1.0e-6, 1.0e-6, 1.0e-6)),
    "flat": ((12, 10, 6), (2.0e-6, 2.0e-6, 0.5e-6)),
}
#: Contact and plasticity tolerance of the recorded step: 1e-3 of the comparison's 1e-10, so
#: that the solvers' stopping points (about ten times their tolerance in the fields) lie below
#: it, not at it; the step still converges at 1e-14 (module docstring).
STEP_TOLERANCE = 1e-13
#: one load step of a rigid sphere on linear hardening (p0 = 2 σY), as benchmarks/scale.py
STEP_CASE = {
    "name": "operator-regression-step",
    "body": {"E": E, "nu": NU,
             "hardening": {"law": "linear", "yield_stress": 4.2348e9, "modulus": 0.05 * E}},
    "counterbody": {"kind": "rigid", "radius": 105e-6},
    "grid": {"nx": 16, "ny": 16, "nz": 8, "half_width": 1.5},
    "load_path": [{"kind": "load", "to": 0.65, "increments": 1}],
    "solver": {"contact_tolerance": STEP_TOLERANCE, "plasticity_tolerance": STEP_TOLERANCE},
}


def main() -> None:
    arrays: dict[str, np.ndarray] = {}
    for name, (shape, spacing) in BOXES.items():
        rng = np.random.default_rng(list(BOXES).index(name) + 1)
        eps = rng.standard_normal((*shape, 6)) * 1e-3
        op = HalfSpaceEigenstrain(shape, spacing, E, NU)
        stress, displacement = op.residual_stress(eps, with_displacement=True)
        arrays[f"{name}_eps"] = eps
        arrays[f"{name}_stress"] = stress
        arrays[f"{name}_displacement"] = displacement
    sim = simulation_for(case_from_dict(STEP_CASE))
    state = next(iter(sim.run()))
    for name in ("plastic_strain", "residual_stress", "stress"):
        arrays[f"step_{name}"] = np.asarray(state.volume[name])
    arrays["step_pressure"] = np.asarray(state.surface["pressure"])
    arrays["step_case"] = np.array(json.dumps(STEP_CASE, sort_keys=True))
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True, cwd=OUT.parent).stdout.strip()
    arrays["recorded_at_commit"] = np.array(commit)
    np.savez_compressed(OUT, **arrays)
    print(f"wrote {OUT} (commit {commit})")


if __name__ == "__main__":
    main()
