"""Cell-averaged stress of the eigenstrain operator (``stress_sampling``), and why it exists.

Centre-sampled (collocated) stresses make the operator ``ε* → −σ`` indefinite: the 3-D
checkerboard of an axial compression (plastic strain ∝ (1, 1, −2), the flow of the plastic core
under an indenter) has a negative energy at cell aspect ratios dx/dz ≈ 1.1 … 1.6, so a plastic
problem with little hardening has a spurious checkerboard solution (the 72² × 64 press of the
indentation-made dent, notes/press-near-surface.md). The cell mean restores the sign of the
elastic energy. Independent checks: the closed form of the cuboid (Chiu) averaged by hand, and
Love's rectangle averaged by hand.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from sacflow.kernels.cell_average import check_sampling, sub_offsets, sub_points
from sacflow.kernels.cuboid import SHEAR_WEIGHTS, cuboid_stress
from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.kernels.shear import (
    subcell_load_stress_coefficients,
    surface_load_stress_coefficients,
    traction_stress,
)
from sacflow.kernels.surface import rectangle_stress

E, NU = 219e9, 0.3
MU = E / (2 * (1 + NU))
#: Axial compression of a plastic core, unit norm in ε:ε.
COMPRESSION = np.array([1.0, 1.0, -2.0, 0.0, 0.0, 0.0]) / np.sqrt(6.0)


def checkerboard_energy(dx_over_dz: float, sampling: int, direction: np.ndarray = COMPRESSION,
                        alternate_in_depth: bool = True) -> float:
    """``−Σ ε:σ / (2 μ Σ ε:ε)`` of a checkerboard of ``direction`` in a deep block of 12³ cells.

    The checkerboard alternates from cell to cell along x1 and x2, and along x3 too unless
    ``alternate_in_depth`` is False (then it is smooth in depth). It is windowed by a half sine
    along each axis (a sharp-edged block adds the positive energy of its faces to the mode's
    own).
    """
    block, pad, top = 12, 4, 10
    shape = (block + 2 * pad, block + 2 * pad, top + block + pad)
    op = HalfSpaceEigenstrain(shape, (dx_over_dz, dx_over_dz, 1.0), E, NU, threads=1,
                              stress_sampling=sampling)
    cells = np.arange(block)
    window = np.sin(np.pi * (cells + 0.5) / block)
    line = (-1.0) ** cells * window
    depth = line if alternate_in_depth else window
    mode = line[:, None, None] * line[None, :, None] * depth[None, None, :]
    eps = np.zeros((*shape, 6))
    lateral = slice(pad, pad + block)
    eps[lateral, lateral, top:top + block] = mode[..., None] * direction
    stress = op.residual_stress(eps)
    energy = -np.sum(eps * stress * SHEAR_WEIGHTS)
    return float(energy / (2 * MU * np.sum(eps * eps * SHEAR_WEIGHTS)))


def test_centre_sampling_gives_the_compression_checkerboard_a_negative_energy():
    # the cause: at dx/dz = 1.25 (the band of the oscillating press grids) the collocated
    # operator has a negative energy for this mode; the continuum (and the cell mean) cannot
    assert checkerboard_energy(1.25, 1) < -0.02
    assert checkerboard_energy(1.25, 2) > 0.1


def test_centre_sampling_is_indefinite_beyond_the_compression_band():
    # a lateral checkerboard of ε11 − ε22, smooth in depth: negative energy with centre values
    # at cubic cells too (where the compression checkerboard's is positive), positive with the
    # cell mean; the spurious modes of collocation are not the compression's alone
    in_plane = np.array([1.0, -1.0, 0.0, 0.0, 0.0, 0.0]) / np.sqrt(2.0)
    assert checkerboard_energy(1.0, 1, COMPRESSION) > 0.05
    assert checkerboard_energy(1.0, 1, in_plane, alternate_in_depth=False) < -0.2
    assert checkerboard_energy(1.0, 2, in_plane, alternate_in_depth=False) > 0.01


@pytest.mark.parametrize("ratio", [0.44, 1.17, 1.77])
def test_cell_mean_keeps_the_checkerboard_energy_positive(ratio):
    assert checkerboard_energy(ratio, 2) > 0.1


@pytest.mark.parametrize("sampling", [1, 2, 3])
def test_cell_mean_equals_the_closed_form_averaged_by_hand(sampling):
    # a source cuboid deep below the surface (its image and traction correction are below 1e-5
    # of its own stress): the operator's cell mean is the mean of Chiu's closed form at the
    # sub-points (the centre value for sampling 1)
    shape, spacing = (7, 7, 40), (1.3e-6, 1.1e-6, 1.0e-6)
    op = HalfSpaceEigenstrain(shape, spacing, E, NU, threads=1, stress_sampling=sampling)
    centre = (3, 3, 30)
    half = [d / 2 for d in spacing]
    for source in (2, 4):
        eps = np.zeros((*shape, 6))
        eps[(*centre, source)] = 1.0
        got = op.residual_stress(eps)
        scale = np.abs(got[centre]).max()
        for offset in ((0, 0, 0), (1, 0, 0), (1, 1, -1), (2, 1, 1)):
            rel = np.array(offset, dtype=float) * spacing
            want = np.mean([cuboid_stress(*(rel + np.array(p)), *half, NU, MU).reshape(6, 6)
                            for p in sub_points(sampling, spacing)], axis=0)[:, source]
            target = tuple(c + o for c, o in zip(centre, offset, strict=True))
            assert_allclose(got[target], want, rtol=0, atol=1e-5 * scale)


def test_default_sampling_is_the_centre_value():
    shape, spacing = (6, 5, 4), (1.2e-6, 1.0e-6, 0.8e-6)
    rng = np.random.default_rng(3)
    eps = rng.standard_normal((*shape, 6)) * 1e-3
    centre = HalfSpaceEigenstrain(shape, spacing, E, NU, threads=1)
    one = HalfSpaceEigenstrain(shape, spacing, E, NU, threads=1, stress_sampling=1)
    assert_allclose(one.residual_stress(eps), centre.residual_stress(eps), rtol=0, atol=0)
    assert "stress_sampling" not in centre.cache_parameters()
    averaged = HalfSpaceEigenstrain(shape, spacing, E, NU, threads=1, stress_sampling=3)
    assert averaged.cache_parameters()["stress_sampling"] == 3


def test_contact_stress_cell_mean_equals_love_averaged_by_hand():
    cell, dz, nu, sampling = (1.5e-6, 1.2e-6), 1.0e-6, 0.3, 2
    depths = np.array([0.5, 1.5]) * dz
    coefficients = surface_load_stress_coefficients(cell, depths, nu, sampling=sampling,
                                                    thickness=dz)
    d1, d2 = np.array([0, 1, 3])[:, None], np.array([0, 2])[None, :]
    got = coefficients(d1, d2).reshape(2, 6, 3, 2)
    for k, z in enumerate(depths):
        for a, b in ((0, 0), (1, 1), (2, 0)):
            x = np.array([d1[a, 0] * cell[0], d2[0, b] * cell[1], z])
            want = np.mean([rectangle_stress(*(x + np.array(p)), cell[0] / 2, cell[1] / 2, nu)
                            for p in sub_points(sampling, (*cell, dz))], axis=0)
            assert_allclose(got[k, :, a, b], want, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("sampling", [1, 2, 3])
@pytest.mark.parametrize("traction", [None, (0.25, -0.1)])
def test_sub_cell_and_cell_contact_coefficients_equal_love_averaged_by_hand(sampling, traction):
    """The lattice of the sub-points (sacflow.kernels.surface.rectangle_stress_sampled) against
    Love's rectangle and the traction's stresses point by point, at offsets of both signs."""
    cell, dz, nu, subcells = (1.5e-6, 1.2e-6), 1.0e-6, 0.3, 2
    depths = np.array([0.5, 2.5]) * dz
    d1, d2 = np.array([0, -1, 3])[:, None], np.array([0, 2, -2])[None, :]
    centres = (np.arange(subcells) + 0.5) / subcells - 0.5
    sub = subcell_load_stress_coefficients(cell, subcells, depths, nu, traction, sampling, dz)
    whole = surface_load_stress_coefficients(cell, depths, nu, traction, sampling, dz)
    got_sub = sub(d1, d2).reshape(2, 6, subcells**2, 3, 3)
    got_whole = whole(d1, d2).reshape(2, 6, 3, 3)
    points = list(sub_points(sampling, (*cell, dz)))

    def by_hand(x, half):
        fields = [rectangle_stress(*(x + np.array(p)), *half, nu)
                  + (0.0 if traction is None
                     else traction_stress(*(x + np.array(p)), *half, nu, traction))
                  for p in points]
        return np.mean(fields, axis=0)

    scale = np.abs(got_whole).max()
    for k, z in enumerate(depths):
        for a, b in ((0, 0), (1, 2), (2, 1)):
            x = np.array([d1[a, 0] * cell[0], d2[0, b] * cell[1], z])
            assert_allclose(got_whole[k, :, a, b], by_hand(x, (cell[0] / 2, cell[1] / 2)),
                            rtol=0, atol=1e-12 * scale)
            for channel in range(subcells**2):
                o1, o2 = divmod(channel, subcells)
                xs = x - np.array([centres[o1] * cell[0], centres[o2] * cell[1], 0.0])
                want = by_hand(xs, (cell[0] / 4, cell[1] / 4))
                assert_allclose(got_sub[k, :, channel, a, b], want, rtol=0, atol=1e-12 * scale)


def test_sub_offsets_and_their_check():
    assert_allclose(sub_offsets(2), [-0.25, 0.25])
    assert_allclose(sub_offsets(3), [-1 / 3, 0.0, 1 / 3])
    for bad in (0, 1.5, 9):
        with pytest.raises(ValueError, match="points per axis"):
            check_sampling(bad)


def axis_plastic_strain(sampling: int, layers: int) -> np.ndarray:
    """Equivalent plastic strain on the axis after a 650 mN indentation of soft-hardening steel.

    Linear hardening of 1 GPa (well below the checkerboard's energy deficit of centre sampling
    at these cells), 32² cells and ``layers`` layers (dx/dz ≈ 1.03 at 20).
    """
    from pathlib import Path

    from sacflow.config.solver_inputs import solver_inputs
    from sacflow.solver.simulation import Simulation
    from sacflow.storage.case_file import load_case

    config = Path(__file__).resolve().parent.parent / "configs/nanoindentation-linear-650mN.toml"
    case = load_case(config, ["body.hardening.modulus=1e9", "grid.nx=32", "grid.ny=32",
                              f"grid.nz={layers}", "load_path.0.increments=20",
                              "load_path.1.increments=10", "solver.fft_threads=1",
                              f"solver.stress_sampling={sampling}"])
    sim = Simulation(solver_inputs(case))
    states = list(sim.run())
    assert all(state.scalars()["converged"] for state in states)
    centre = int(np.argmin(np.abs(sim.coords.x1)))
    axis: np.ndarray = sim.equivalent_plastic_strain[centre, centre]
    return axis


def extrema(profile: np.ndarray) -> int:
    """Local extrema of a profile where it exceeds 5 % of its maximum (one: a single peak)."""
    steps = np.diff(profile[profile > 0.05 * profile.max()])
    return int(np.sum(np.sign(steps[1:]) != np.sign(steps[:-1])))


@pytest.mark.slow  # three presses; the closed-form cell means above stay in the default run
def test_cell_mean_removes_the_layer_to_layer_oscillation_of_the_plastic_strain():
    # centre sampling: εp on the axis alternates from layer to layer (five extrema, largest
    # εp 2.84 %); the cell mean: one peak, its value that of 16 layers within 0.5 %
    averaged = axis_plastic_strain(2, 20)
    assert extrema(averaged) == 1
    assert extrema(axis_plastic_strain(1, 20)) > 2
    assert averaged.max() == pytest.approx(axis_plastic_strain(2, 16).max(), rel=5e-3)



def test_the_case_option_reaches_the_solver_and_enters_the_id_only_when_not_the_centre():
    """``solver.stress_sampling``: absent or 1 keeps the case id of the centre-sampled runs
    stored before it existed; 2 is another case, whose solver and inclusion operators average;
    a value out of range is a one-line message naming the field."""
    from pathlib import Path

    from sacflow.config.solver_inputs import solver_inputs
    from sacflow.errors import ConfigError
    from sacflow.storage.case_file import load_case

    config = Path(__file__).resolve().parent.parent / "configs/nanoindentation-650mN.toml"
    shipped = load_case(config)
    assert load_case(config, ["solver.stress_sampling=1"]).case_id == shipped.case_id
    averaged = load_case(config, ["solver.stress_sampling=2"])
    assert averaged.case_id != shipped.case_id
    assert solver_inputs(averaged).settings.stress_sampling == 2
    assert solver_inputs(shipped).settings.stress_sampling == 1
    for wrong in ("0", "9", "1.5"):
        with pytest.raises(ConfigError) as info:
            load_case(config, [f"solver.stress_sampling={wrong}"])
        assert "solver.stress_sampling" in str(info.value)
