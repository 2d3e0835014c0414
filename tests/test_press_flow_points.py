"""``pipelines/press_flow_points.py``: points of flow that see their plastic strain through a block.

The script's ``points`` run computes the flow at the 2 × 2 cells of each block while the
eigenstrain operator sees the block's mean plastic strain; its ``averaged`` run gives each cell
its block's mean return. These tests check the wrappings themselves (exactly the operator of the
block means, the solver's own field untouched; the returns averaged in place), the mechanism
the documentation draws from the first (a point is relieved by about a third of the stress its
own cell removes, so it must flow further), and, slow, the script end to end.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np
import pytest

from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.mechanics.return_mapping import ReturnResult
from sacflow.studies.lateral_error_split import block_average

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pipelines"))
import press_flow_points as module  # noqa: E402  (a pipeline script; imports its sibling)

SHAPE = (8, 8, 4)
SPACING = (1e-6, 1e-6, 1e-6)
E, NU = 210e9, 0.3


def test_block_mean_keeps_each_blocks_total_and_refuses_odd_grids():
    rng = np.random.default_rng(3)
    field = rng.normal(size=(6, 4, 3, 6))
    spread = module.spread_block_mean(field)
    assert spread.shape == field.shape
    np.testing.assert_allclose(block_average(spread, 2), block_average(field, 2), rtol=1e-14)
    np.testing.assert_array_equal(spread[0, 0], spread[1, 1])
    assert spread.sum() == pytest.approx(field.sum(), rel=1e-12)
    with pytest.raises(ValueError, match="is not 2 x 2 cells per coarse cell"):
        module.spread_block_mean(np.zeros((5, 4, 2)))


@pytest.mark.parametrize("sampling", [1, 2])
def test_the_wrapped_operator_is_the_operator_of_the_block_means(sampling):
    plain = HalfSpaceEigenstrain(SHAPE, SPACING, E, NU, threads=1, stress_sampling=sampling)
    wrapped = HalfSpaceEigenstrain(SHAPE, SPACING, E, NU, threads=1, stress_sampling=sampling)
    module.see_block_means(wrapped)
    eps = np.random.default_rng(sampling).normal(scale=1e-3, size=(*SHAPE, 6))
    before = eps.copy()
    means = module.spread_block_mean(eps)
    np.testing.assert_array_equal(wrapped.residual_stress(eps), plain.residual_stress(means))
    np.testing.assert_array_equal(wrapped.residual_displacement(eps),
                                  plain.residual_displacement(means))
    stress, displacement = wrapped.residual_stress(eps, with_displacement=True)
    np.testing.assert_array_equal(displacement, plain.residual_displacement(means))
    np.testing.assert_array_equal(eps, before)  # the solver's field is not touched


@pytest.mark.parametrize("sampling", [1, 2])
def test_a_point_seen_through_its_block_is_relieved_by_about_a_third(sampling):
    """A lone ε11 in one cell: its own σ11 relief with the block mean is about a third of the
    plain operator's (a quarter of the strain, spread over the block), so the flow that balances
    a given stress excess must be about three times larger at such a point."""
    plain = HalfSpaceEigenstrain(SHAPE, SPACING, E, NU, threads=1, stress_sampling=sampling)
    wrapped = HalfSpaceEigenstrain(SHAPE, SPACING, E, NU, threads=1, stress_sampling=sampling)
    module.see_block_means(wrapped)
    eps = np.zeros((*SHAPE, 6))
    cell = (3, 4, 2)
    eps[(*cell, 0)] = 1e-3
    own = plain.residual_stress(eps)[(*cell, 0)]
    seen = wrapped.residual_stress(eps)[(*cell, 0)]
    assert own < 0.0 and seen < 0.0  # both relieve the compression the strain removes
    assert 0.25 < seen / own < 0.4


class _FixedPoint:
    """Stands in for the solver's fixed point: a return of given fields, counted."""

    def __init__(self, same: bool):
        rng = np.random.default_rng(7)
        self.results = [ReturnResult(None, rng.normal(size=(4, 6, 3, 6)), rng.random((4, 6, 3)),
                                     np.ones((4, 6, 3), dtype=bool), 1)
                        for _ in range(1 if same else 2)]
        self.calls: list[tuple] = []

    def _return(self, *args):
        self.calls.append(args)
        return self.results[0], self.results[-1]


@pytest.mark.parametrize("same", [True, False])
def test_the_averaged_return_gives_each_cell_its_blocks_mean(same):
    fixed_point = _FixedPoint(same)
    before = [(r.plastic_strain_increment.copy(), r.equivalent_plastic_strain_increment.copy())
              for r in fixed_point.results]
    module.average_the_return(fixed_point)
    ret, full = fixed_point._return("trial", "p", None, None)
    assert fixed_point.calls == [("trial", "p", None, None)]
    assert (ret is full) == same and ret is fixed_point.results[0]
    for result, (strain, equivalent) in zip(fixed_point.results, before, strict=True):
        np.testing.assert_allclose(result.plastic_strain_increment,
                                   module.spread_block_mean(strain), rtol=1e-14)
        np.testing.assert_allclose(result.equivalent_plastic_strain_increment,
                                   module.spread_block_mean(equivalent), rtol=1e-14)


def test_the_coarse_reading_sees_each_blocks_mean():
    """read_by_coarse_cells reads the block means: a strain that varies inside the blocks reads
    as its blocks' uniform spread does, and the columns name the study's profile depths."""
    from types import SimpleNamespace

    from sacflow.studies.convergence import PROFILE_DEPTHS

    coarse_shape = (4, 4, 8)
    eigen = HalfSpaceEigenstrain(coarse_shape, (2e-6, 2e-6, 1e-6), E, NU, threads=1)
    coords = SimpleNamespace(x1=(np.arange(4) - 1.5) * 2e-6, x2=(np.arange(4) - 1.5) * 2e-6,
                             x3=(np.arange(8) + 0.5) * 1e-6)
    coarse = SimpleNamespace(operators=SimpleNamespace(eigenstrain=eigen), coords=coords)
    strain = np.random.default_rng(5).standard_normal((8, 8, 8, 6)) * 1e-3
    spread = module.spread_block_mean(strain)
    radius = 2e-6
    got = module.read_by_coarse_cells(SimpleNamespace(plastic_strain=strain), coarse, (0.0, 0.0),
                                      radius)
    want = module.read_by_coarse_cells(SimpleNamespace(plastic_strain=spread), coarse,
                                       (0.0, 0.0), radius)
    assert list(got) == [f"coarse_read_s11_axis_refined_at_{d:g}a" for d in PROFILE_DEPTHS]
    inside = [k for k, d in zip(got, PROFILE_DEPTHS, strict=True) if 0.5e-6 <= d * radius <= 7.5e-6]
    assert inside and all(np.isfinite(got[k]) and got[k] == pytest.approx(want[k], rel=1e-12)
                          for k in inside)
    assert not np.allclose(strain, spread)  # the strain did vary inside the blocks


def test_the_coarse_reading_refuses_the_coarse_variant():
    with pytest.raises(SystemExit, match="leave coarse out of --variants"):
        module.main(["--variants", "coarse,averaged", "--read-by-coarse-cells"])


def test_the_script_refuses_unknown_variants(capsys):
    with pytest.raises(SystemExit):
        module.main(["--variants", "coarse,finer"])
    message = "--variants: finer: choose from coarse, points, averaged, fine"
    assert message in capsys.readouterr().err


@pytest.mark.slow
def test_the_script_runs_the_four_variants_and_keeps_its_table(tmp_path, capsys):
    table = tmp_path / "points.csv"
    argv = ["--cells", "24", "--layers", "8", "--increments", "4", "2", "--table", str(table)]
    module.main(argv)
    rows = {row["variant"]: row for row in csv.DictReader(table.open())}
    assert list(rows) == ["coarse", "points", "averaged", "fine"]
    assert [int(rows[v]["nx"]) for v in rows] == [24, 48, 48, 48]
    assert [int(rows[v]["subcells"]) for v in rows] == [2, 1, 1, 1]
    averaged = rows["averaged"]  # one plastic strain per block: its largest is a block's
    assert float(averaged["max_plastic_strain"]) == pytest.approx(
        float(averaged["max_plastic_strain_block_mean"]), rel=1e-12)
    points, fine = rows["points"], rows["fine"]
    # the points part: their largest εp far above their block means' and the fine cells'
    assert float(points["max_plastic_strain"]) > 2 * float(points["max_plastic_strain_block_mean"])
    assert float(points["max_plastic_strain"]) > 2 * float(fine["max_plastic_strain"])
    assert int(points["plasticity_iterations"]) > int(fine["plasticity_iterations"])
    before = table.read_bytes()
    with pytest.raises(SystemExit, match="exists; nothing was changed"):
        module.main(argv)
    assert table.read_bytes() == before
    assert "points: 48²" in capsys.readouterr().out


@pytest.mark.slow
def test_the_script_reads_a_fine_run_through_the_coarse_cells(tmp_path):
    table = tmp_path / "read.csv"
    module.main(["--cells", "24", "--layers", "8", "--increments", "4", "2", "--variants",
                 "averaged", "--read-by-coarse-cells", "--table", str(table)])
    (row,) = csv.DictReader(table.open())
    own, read = (float(row[f"{name}_at_1.5a"]) for name in
                 ("residual_s11_axis_refined", "coarse_read_s11_axis_refined"))
    # the same plastic strain read on coarser cells: near, not the same
    assert own != read and read == pytest.approx(own, rel=0.1)
