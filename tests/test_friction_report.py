"""Where ``pipelines/friction_report.py`` reads the largest von Mises stress.

At μ = 0 the field is symmetric about the load's axis, which lies on a cell face: the largest
value is shared by mirror cells that differ only by rounding, and which of them rounding made
the larger differed from one processor to another (x1 = +0.0098 a on one, −0.0098 a on another).
The script reads such a maximum on the mirror plane between the cells.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).resolve().parents[1] / "pipelines" / "friction_report.py"


def _script():
    spec = importlib.util.spec_from_file_location("friction_report", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _symmetric_field(x1, x2, x3):
    """A smooth field symmetric about x1 = 0 and x2 = 0, largest at depth 0.5."""
    return np.exp(-(x1[:, None, None] ** 2 + x2[None, :, None] ** 2)
                  - 4.0 * (x3[None, None, :] - 0.5) ** 2)


def test_a_maximum_shared_by_mirror_cells_is_read_on_the_mirror_plane():
    report = _script()
    x1 = x2 = np.arange(-3.5, 4.0)  # the axis on a cell face
    x3 = np.linspace(0.1, 1.0, 10)
    field = _symmetric_field(x1, x2, x3)
    for sign in (1.0, -1.0):  # rounding favours either mirror cell
        rounded = field.copy()
        rounded[x1 > 0] *= 1.0 + sign * 1e-15
        where = report.where_largest(rounded, x1, x2, x3)
        assert where == (0.0, 0.0, 0.5)


def test_a_maximum_in_one_cell_is_read_in_that_cell():
    report = _script()
    x1 = x2 = np.arange(-3.5, 4.0)
    x3 = np.linspace(0.1, 1.0, 10)
    field = _symmetric_field(x1 - 1.0, x2, x3)  # shifted by a cell: one largest column pair
    field[x1 == 0.5] *= 1.0 + 1e-6  # a real difference, far above rounding
    assert report.where_largest(field, x1, x2, x3) == (0.5, 0.0, 0.5)
