"""The half-space correction of one cuboid by quadrature (``pipelines/traction_quadrature.py``).

The operator removes the surface traction of the cuboids sampled at the surface cells' centres;
the quadrature integrates Boussinesq's response to the traction's deviation from those values.
Two independent checks that it is the missing part: a grid 9 times finer laterally (the same
cuboid, the traction sampled at its finer centres) must be close to the operator plus the
quadrature and far from the operator alone, and the quadrature must hold when its points double.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pipelines"))
import traction_quadrature as tq  # noqa: E402

SHAPE, SPACING = (5, 5, 2), (1.0, 1.0, 1.0)  # a 5 x 5 x 2 box, cubic cells


@pytest.fixture(scope="module")
def fields() -> dict[str, np.ndarray]:
    """Operator, 9 times finer surface, quadrature at 8 and 16 points: a top-layer source."""
    return {"operator": tq.operator_stress(SHAPE, SPACING, 0, 1),
            "finer": tq.operator_stress(SHAPE, SPACING, 0, 9),
            "delta": tq.quadrature_delta(SHAPE, SPACING, 0, 8),
            "delta2": tq.quadrature_delta(SHAPE, SPACING, 0, 16)}


@pytest.mark.parametrize("source", range(6))
def test_quadrature_is_what_the_centre_sampling_misses(fields, source):
    """The finer grid minus the operator is the quadrature's Δ, to a tenth of Δ or better."""
    op, fine, delta = (fields[k][source] for k in ("operator", "finer", "delta"))
    missed = np.abs(fine - op).max()
    assert missed > 1e-3 * np.abs(op).max()  # the sampling does miss something
    assert np.abs(fine - op - delta).max() < 0.15 * missed


@pytest.mark.parametrize("source", range(6))
def test_quadrature_holds_when_its_points_double(fields, source):
    """Δ with 16 × 16 Gauss points per surface cell is Δ with 8 × 8 to 3 % of its size."""
    delta, again = fields["delta"][source], fields["delta2"][source]
    assert np.abs(again - delta).max() < 0.03 * np.abs(delta).max()


def test_shear_sources_carry_the_largest_part():
    """A top-layer ε13 cuboid's traction is odd about its centre: centre sampling drops it."""
    half = (0.5, 0.5, 0.5)
    centre = tq.surface_traction(np.zeros(1), np.zeros(1), 0.5, half, 4)
    beside = tq.surface_traction(np.array([0.3, -0.3]), np.zeros(2), 0.5, half, 4)
    assert abs(centre[0]) < 1e-9 * abs(beside[0])
    assert beside[0] == pytest.approx(-beside[1], rel=1e-9)
