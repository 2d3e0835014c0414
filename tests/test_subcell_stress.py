"""The sub-cells' pressure → stress operator with its kernels folded by mirror symmetry.

:class:`~sacflow.kernels.subcell_stress.MirroredSubcellStress` keeps the kernels of a quarter of
the sub-cells and reads the others' as mirror images. Against the unfolded DC-FFT operator,
which evaluates every sub-cell's Love rectangles itself, on odd and even grids (odd padded
lengths included), two to four sub-cells, centre values and cell means; the solver's operators
fold only without friction; the memory estimate counts the kept spectra.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow.config.solver_inputs import estimate_case_memory
from sacflow.kernels.convolution import Convolution, padded_length
from sacflow.kernels.shear import subcell_load_stress_coefficients
from sacflow.kernels.subcell_stress import MirroredSubcellStress, representative
from sacflow.solver.operators import Operators
from sacflow.storage.case_file import load_case

CELL, NU, DZ = (1.0e-5, 1.3e-5), 0.3, 0.6e-5
NANO = Path(__file__).resolve().parents[1] / "configs" / "nanoindentation-650mN.toml"


def item(estimate, name: str) -> int:
    """Bytes of the estimate's item ``name``."""
    return next(i.nbytes for i in estimate.items if i.name == name)


def depths(nz: int) -> np.ndarray:
    return (np.arange(nz) + 0.5) * DZ


@pytest.mark.parametrize(("subcells", "sampling", "shape", "nz"), [
    (2, 1, (9, 7), 3), (2, 2, (10, 11), 2), (3, 2, (8, 6), 2), (4, 1, (6, 7), 2),
])
def test_the_folded_operator_is_the_unfolded_one(subcells, sampling, shape, nz):
    """Every sub-cell's stress, kept or mirrored, equals the unfolded operator's to round-off."""
    z = depths(nz)
    full = Convolution(subcell_load_stress_coefficients(CELL, subcells, z, NU, None, sampling,
                                                        DZ), shape, shape, block=6)
    folded = MirroredSubcellStress(
        subcell_load_stress_coefficients(CELL, subcells, z, NU, None, sampling, DZ,
                                         only=MirroredSubcellStress.kept(subcells)),
        shape, subcells, block=6)
    assert folded.spectra.shape[1] == ((subcells + 1) // 2) ** 2
    rng = np.random.default_rng(subcells)
    pressure = rng.uniform(-1e9, 1e9, (subcells * subcells, *shape))
    expected = full(pressure)
    assert_allclose(folded(pressure), expected, rtol=0, atol=1e-13 * np.abs(expected).max())
    for channel in range(subcells * subcells):  # each sub-cell alone, mirrored or not
        one = np.zeros_like(pressure)
        one[channel] = pressure[channel]
        alone = full(one)
        assert_allclose(folded(one), alone, rtol=0, atol=1e-13 * np.abs(alone).max())


def test_an_odd_padded_length_is_exercised():
    """The odd grid above pads to an odd length: the mirrored row of k1 is L1 − k1, no Nyquist."""
    assert padded_length(7, 7) % 2 == 1


@pytest.mark.parametrize(("subcells", "expected"), [
    (2, [(0, False), (0, True)]),
    (3, [(0, False), (1, False), (0, True)]),
    (4, [(0, False), (1, False), (1, True), (0, True)]),
])
def test_each_sub_cell_maps_to_its_mirror_on_the_cell_s_low_side(subcells, expected):
    assert [representative(o, subcells) for o in range(subcells)] == expected


def test_a_wrong_number_of_kernels_is_refused():
    coefficients = subcell_load_stress_coefficients(CELL, 2, depths(1), NU)  # all four kept
    with pytest.raises(ValueError, match="coefficients for 2 × 2 sub-cells"):
        MirroredSubcellStress(coefficients, (4, 4), 2, block=6)


@pytest.mark.parametrize(("traction", "folded"), [(None, True), ((0.2, 0.0), False)])
def test_the_solver_folds_only_without_a_shear_traction(traction, folded):
    """A shear traction breaks the mirror symmetry: the operator then keeps every kernel, and
    it still gives the stress of the sub-cells' pressure with its traction."""
    ops = Operators((4, 4), (6, 6), CELL, 2, DZ, 2e11, NU, 1e11, traction, False, 1,
                    contact_subcells=2)
    assert isinstance(ops.subcell_stress_op, MirroredSubcellStress) == folded
    assert ops.subcell_stress_op is not None
    assert ops.subcell_stress_op.spectra.shape[1] == (1 if folded else 4)


def test_the_estimate_counts_a_quarter_of_the_kernels_without_friction():
    """Deep enough for the spectra to outweigh the transform buffers (four inputs, not one)."""
    grid = ["grid.nx=32", "grid.ny=32", "grid.nz=64", "solver.contact_subcells=2"]
    plain = estimate_case_memory(load_case(NANO, grid))
    rubbing = estimate_case_memory(load_case(NANO, [*grid, "friction.coefficient=0.2"]))
    name = "sub-cell pressure-stress operator"
    cells = item(plain, "pressure-stress operator")  # one kernel per depth and component
    assert cells < item(plain, name) < 1.1 * cells
    assert item(rubbing, name) > 3.5 * item(plain, name)
