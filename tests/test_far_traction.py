"""The surface traction beyond the box (:mod:`sacflow.kernels.far_traction`).

The eigenstrain operator removes the traction its cuboids leave on the surface over the box's
footprint only; ``traction_beyond_box`` adds the stress of removing the rest, computed coarse.
The reference is independent of the coarse route: the same eigenstrain in a box four times as
wide, at the fine cells, with zero strain around it (the bare fine operator, whose own
truncation is then far away).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.kernels.far_traction import (
    MARGIN_SHARE,
    MAX_SUPER_CELL,
    MIN_SUPER_CELLS,
    FarTraction,
    coarse_layout,
    linear_weights,
    super_cell,
)
from sacflow.kernels.surface import rectangle_stress

E, NU = 210e9, 0.3
SPACING = (1e-6, 1e-6, 0.5e-6)
BOX = (32, 32, 8)
#: The reference box is this many times wider than the box (the correction reaches three).
REFERENCE_WIDTH = 4


def _blob() -> np.ndarray:
    """A plastic zone in the middle of the box, as under an indenter: a Gaussian of
    volume-free strain (ε33 = −2 e, ε11 = ε22 = e) over its central 16 × 16 × 6 cells, with a
    random part (all six components) a fifth as large."""
    rng = np.random.default_rng(11)
    i = np.arange(16) - 7.5
    bump = np.exp(-(i[:, None, None] ** 2 + i[None, :, None] ** 2) / 20.0
                  - (np.arange(6)[None, None, :] - 2.0) ** 2 / 8.0)
    zone = 0.2 * rng.uniform(-1e-3, 1e-3, (16, 16, 6, 6))
    zone[..., :3] += 1e-3 * bump[..., None] * np.array([1.0, 1.0, -2.0])
    eps = np.zeros((*BOX, 6))
    eps[8:24, 8:24, :6] = zone
    return eps


@pytest.fixture(scope="module")
def fields():
    """Stress of the blob: bare box, box with the correction, and the wide reference."""
    eps = _blob()
    bare = HalfSpaceEigenstrain(BOX, SPACING, E, NU)
    far = HalfSpaceEigenstrain(BOX, SPACING, E, NU, traction_beyond_box=True)
    n = BOX[0]
    margin = (REFERENCE_WIDTH - 1) * n // 2
    wide = np.zeros((n + 2 * margin, n + 2 * margin, BOX[2], 6))
    wide[margin:margin + n, margin:margin + n] = eps
    box = (slice(margin, margin + n), slice(margin, margin + n))
    reference = HalfSpaceEigenstrain(wide.shape[:3], SPACING, E, NU)
    return {
        "eps": eps,
        "bare": bare.residual_stress(eps, with_displacement=True),
        "far": far.residual_stress(eps, with_displacement=True),
        "reference": reference.residual_stress(wide)[box],
        "operator": far,
    }


def test_the_traction_beyond_the_box_is_what_a_wider_box_adds(fields):
    """Against the box four times as wide: over the plastic zone (where the yield condition
    reads the stress) the correction removes more than nine tenths of the bare box's error,
    and nowhere is the largest error larger. Near the box's sides, within a super-cell or two
    (here 4 cells of 1 µm) of the traction it adds, the linear interpolation of the coarse
    response is coarser: there the gain is smaller."""
    reference = fields["reference"]
    bare_error = np.abs(fields["bare"][0] - reference)
    far_error = np.abs(fields["far"][0] - reference)
    zone = (slice(8, 24), slice(8, 24))
    assert bare_error.max() > 1e-4 * np.abs(reference).max()  # far above rounding
    assert far_error[zone].max() < 0.1 * bare_error[zone].max()
    assert far_error.max() <= bare_error.max()


def test_the_correction_moves_no_residual_displacement(fields):
    """The residual surface displacement has no truncation (reciprocal theorem): the same."""
    assert_allclose(fields["far"][1], fields["bare"][1], rtol=0, atol=0)


def test_the_correction_is_linear_and_zero_without_strain(fields):
    """Δσ(a ε + b η) = a Δσ(ε) + b Δσ(η); no strain, no correction."""
    far = FarTraction(BOX, SPACING, E, NU)
    eps = fields["eps"]
    other = np.roll(eps, 3, axis=0)
    combined = far.stress(2.0 * eps - 0.5 * other)
    scale = np.abs(combined).max()
    assert scale > 0
    assert_allclose(combined, 2.0 * far.stress(eps) - 0.5 * far.stress(other),
                    rtol=0, atol=1e-9 * scale)
    assert not far.stress(np.zeros_like(eps)).any()


def test_traction_stress_is_loves_stress_of_the_traction_as_a_pressure():
    """The operator's ``traction_stress`` of a traction on one surface cell is Love's stress of
    a uniform pressure equal to it on that cell (:func:`rectangle_stress`), independently
    evaluated at a few cell centres."""
    op = HalfSpaceEigenstrain((16, 16, 6), SPACING, E, NU)
    traction = np.zeros((16, 16))
    traction[7, 9] = 1e8
    stress = op.traction_stress(traction)
    d1, d2, d3 = SPACING
    for i, j, k in ((7, 9, 0), (9, 6, 2), (3, 12, 5)):
        x1, x2, x3 = (i - 7) * d1, (j - 9) * d2, (k + 0.5) * d3
        expected = 1e8 * rectangle_stress(np.array(x1), np.array(x2), np.array(x3),
                                          d1 / 2, d2 / 2, NU)
        assert_allclose(stress[i, j, k], np.ravel(expected), rtol=1e-9,
                        atol=1e-9 * np.abs(stress).max())


@pytest.mark.parametrize(("n", "expected"), [
    (64, 8), (80, 8), (48, 8), (36, 6), (65, 5), (24, 4), (34, 2), (12, 2), (67, 1), (10, 1),
])
def test_the_super_cells_are_the_largest_divisors_that_leave_enough(n, expected):
    """Along each axis the largest divisor up to MAX_SUPER_CELL leaving MIN_SUPER_CELLS."""
    c = super_cell(n)
    assert c == expected
    assert n % c == 0 and c <= MAX_SUPER_CELL
    assert c == 1 or n // c >= MIN_SUPER_CELLS
    assert all(n % d or n // d < MIN_SUPER_CELLS for d in range(c + 1, MAX_SUPER_CELL + 1))


def test_the_margin_is_a_share_of_the_narrower_side_on_every_axis():
    """A rolled box of 65 × 24 cells (the seed's smooth rolling): super-cells of 5 × 4 cells,
    and a margin as wide as the 24 cells on both axes, not a share of the track's length;
    with cells twice as long along x1, half as many super-cells of margin along it."""
    factor, counts, margins = coarse_layout((65, 24))
    assert (factor, counts) == ((5, 4), (13, 6))
    assert margins == (math.ceil(MARGIN_SHARE * 24 / 5), math.ceil(MARGIN_SHARE * 24 / 4))
    _, _, stretched = coarse_layout((64, 64), (2.0, 1.0))
    assert stretched == (math.ceil(MARGIN_SHARE * 64 / 16), math.ceil(MARGIN_SHARE * 64 / 8))


@pytest.mark.parametrize(("n", "c"), [(32, 4), (24, 8), (10, 2), (7, 1)])
def test_the_interpolation_reproduces_linear_fields(n, c):
    """Rows sum to one and a field linear in x is interpolated exactly, extrapolated at the
    ends (cell centres (i + ½) h, super-cell centres (I + ½) c h)."""
    weights = linear_weights(n, c)
    assert weights.shape == (n, n // c)
    assert_allclose(weights.sum(axis=1), 1.0)
    coarse_x = (np.arange(n // c) + 0.5) * c
    fine_x = np.arange(n) + 0.5
    assert_allclose(weights @ (3.0 - 2.0 * coarse_x), 3.0 - 2.0 * fine_x, atol=1e-12)


def _press(nx: int, half_width: float, beyond: bool) -> tuple[np.ndarray, float]:
    """A sphere pressed into linear hardening and lifted off, the box ±``half_width`` a:
    σ11 on the axis (the four central columns' mean) per layer and the print depth."""
    from sacflow.config.solver_inputs import simulation_for
    from sacflow.storage.case_file import case_from_dict

    case = case_from_dict({
        "name": "far-traction-press",
        "body": {"E": E, "nu": NU, "hardening": {"law": "linear", "yield_stress": 4.2e9,
                                                   "modulus": 10.5e9}},
        "counterbody": {"kind": "rigid", "radius": 105e-6},
        "grid": {"nx": nx, "ny": nx, "nz": 12, "half_width": half_width},
        "load_path": [{"kind": "load", "to": 0.65, "increments": 2},
                      {"kind": "unload", "increments": 1}],
        "solver": {"traction_beyond_box": beyond},
    })
    sim = simulation_for(case)
    list(sim.run())
    c = nx // 2
    axis = (slice(c - 1, c + 1), slice(c - 1, c + 1))
    return (sim.residual_stress[axis].mean(axis=(0, 1))[:, 0],
            float(sim.residual_displacement[axis].mean()))


def test_a_run_with_the_traction_beyond_its_box_is_that_of_a_box_twice_as_wide():
    """``solver.traction_beyond_box``: a press in a window of ±1.5 a comes out as the same
    cells in ±3 a (which has the traction over its own footprint) an order of magnitude closer
    than without it, for σ11 on the axis and the print depth."""
    wide_stress, wide_print = _press(48, 3.0, False)
    bare_stress, bare_print = _press(24, 1.5, False)
    far_stress, far_print = _press(24, 1.5, True)
    assert np.abs(far_stress - wide_stress).max() < 0.1 * np.abs(bare_stress - wide_stress).max()
    assert abs(far_print - wide_print) < 0.1 * abs(bare_print - wide_print)


def indentation_case(grid: dict[str, int], beyond: bool):
    """A one-increment linear-hardening indentation on ``grid``, with or without the option."""
    from sacflow.storage.case_file import case_from_dict

    return case_from_dict({
        "name": "far-traction-memory",
        "body": {"E": E, "nu": NU, "hardening": {"law": "linear", "yield_stress": 4.2e9,
                                                   "modulus": 10.5e9}},
        "counterbody": {"kind": "rigid", "radius": 105e-6},
        "grid": grid,
        "load_path": [{"kind": "load", "to": 0.65, "increments": 1}],
        "solver": {"traction_beyond_box": beyond},
    })


def test_the_memory_estimate_counts_the_coarse_operator():
    """``sacflow validate`` and the run's memory check count the second operator: the estimate
    of a case with the option has its item, sized by the coarse operator's shape, and is larger
    by at least that operator's spectra."""
    from sacflow.config.solver_inputs import estimate_case_memory
    from sacflow.kernels.eigenstrain_memory import operator_bytes

    grid = {"nx": 64, "ny": 64, "nz": 32}
    bare = estimate_case_memory(indentation_case(grid, False))
    far = estimate_case_memory(indentation_case(grid, True))
    items = {item.name: item.nbytes for item in far.items}
    assert "far-traction operator" in items
    assert "far-traction operator" not in {item.name for item in bare.items}
    cell = indentation_case(grid, True).cell_size()
    spectra = operator_bytes(FarTraction.shape_for((64, 64, 32), cell))
    assert far.total - bare.total >= spectra


def test_the_memory_estimate_sizes_the_operator_the_run_builds_on_oblong_cells():
    """Cells twice as wide along x2 as along x1 (64 × 32 cells over a square window): the
    margins, a share of the narrower side in whole super-cells of each axis, differ from square
    cells', and the estimate must name the operator the run builds."""
    from sacflow.config.solver_inputs import estimate_case_memory, simulation_for

    case = indentation_case({"nx": 64, "ny": 32, "nz": 32}, True)
    built = simulation_for(case).operators.eigenstrain._far.operator.shape
    assert built != FarTraction.shape_for((64, 32, 32), (1.0, 1.0))  # square cells: another
    item = next(i for i in estimate_case_memory(case).items if i.name == "far-traction operator")
    assert f"{built[0]} × {built[1]} × {built[2]} super-cells" in item.what
