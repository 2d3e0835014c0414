"""The return mapping against recorded outputs of the two return mappings it merges.

``data/return_mapping_outputs.npz`` holds what the isotropic radial return and the kinematic
(Armstrong–Frederick) return gave, with their tangents, on fixed trial states (random and
structured; elastic points, points just past yield, large increments; Swift, linear, perfectly
plastic, tabular and depth-scaled laws; several C and γ), recorded by
``pipelines/record_return_mapping_outputs.py`` before they were merged into one
(:func:`sacflow.mechanics.return_mapping.return_map`, issue #29). The merged routine must give
the same to 1e-10 of each array's largest value, and the same plastic points. The tangent with
a backstress is a central difference of two returns (relative step 1e-6), each converged to
1e-12 of σ_Y by its Newton iteration: its own uncertainty is some 1e-10 of its size (doubling
the step changes it by up to 4e-10), so it is compared to :data:`CENTRAL_DIFFERENCE_RELATIVE`.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "pipelines"))
import record_return_mapping_outputs as recorded  # noqa: E402

RELATIVE = 1e-10
#: Tolerance of the central-difference tangent (module docstring).
CENTRAL_DIFFERENCE_RELATIVE = 2e-9
CASES = {**{name: (law, None, s) for name, (law, s) in recorded.isotropic_cases().items()},
         **recorded.kinematic_cases()}


@pytest.fixture(scope="module")
def reference():
    with np.load(ROOT / "data" / "return_mapping_outputs.npz") as data:
        return {k: data[k] for k in data.files}


def assert_close_to_recorded(actual, expected, what, relative=RELATIVE):
    scale = float(np.abs(expected).max())
    error = float(np.abs(actual - expected).max())
    assert error <= relative * scale, f"{what}: {error:.3e} > {relative:g} × {scale:.3e}"


@pytest.mark.parametrize("name", sorted(CASES))
def test_return_mapping_equals_recorded(reference, name):
    got = recorded.outputs(*CASES[name])
    np.testing.assert_array_equal(got["plastic"], reference[f"{name}_plastic"],
                                  err_msg=f"{name}: other plastic points")
    for key in ("stress", "dep", "dp", "backstress", "tangent"):
        if got[key] is None:
            assert f"{name}_{key}" not in reference, f"{name}: {key} missing"
            continue
        relative = (CENTRAL_DIFFERENCE_RELATIVE if key == "tangent" and CASES[name][1]
                    else RELATIVE)
        assert_close_to_recorded(got[key], reference[f"{name}_{key}"], f"{name} {key}",
                                 relative)


@pytest.mark.parametrize("name", [n for n in sorted(CASES) if "structured" in n])
def test_increments_without_stress_are_those_with_it(name):
    full = recorded.outputs(*CASES[name])
    lean = recorded.outputs(*CASES[name], with_stress=False)
    assert lean["stress"] is None
    for key in ("dep", "dp", "plastic", "backstress"):
        np.testing.assert_array_equal(lean[key], full[key], err_msg=f"{name} {key}")
