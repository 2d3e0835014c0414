"""Cells files of inhomogeneities: the cell centres of ``shape = "cells"`` regions (issue #33).

A cells file is text: three columns x1 x2 x3 [m] (body frame, x3 the depth, positive), one point
per line, separated by spaces, tabs or commas; lines starting with ``#`` are comments. Each point
marks the body cell that contains it. The file is read where the case enters
(:func:`check_inclusion_cells`, from :func:`sacflow.storage.case_file.check_case_files`) and
again when the run starts (:func:`read_inclusion_cells`); its contents, not its path, enter the
case id (:mod:`sacflow.storage.fingerprints`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from sacflow.config.inclusion_checks import cells_problem
from sacflow.config.problems import report
from sacflow.errors import ConfigError

if TYPE_CHECKING:
    from sacflow.config.case import Case

__all__ = ["check_inclusion_cells", "read_cells_file", "read_inclusion_cells"]


def read_cells_file(path: Path) -> np.ndarray:
    """Read the points of a cells file: a (k, 3) float array [m], k >= 1.

    Raises
    ------
    ValueError
        When the file holds no point, a line without three numbers, or a non-finite value.
    OSError
        When the file cannot be read.
    """
    text = Path(path).read_text(encoding="utf-8")
    rows = []
    for number, line in enumerate(text.splitlines(), 1):
        line = line.split("#", 1)[0].replace(",", " ").strip()
        if not line:
            continue
        words = line.split()
        try:
            values = [float(word) for word in words]
        except ValueError:
            raise ValueError(f"line {number}: expected three numbers x1 x2 x3, got "
                             f"{line[:60]!r}") from None
        if len(values) != 3:
            raise ValueError(f"line {number}: expected three numbers x1 x2 x3, got "
                             f"{len(values)}")
        rows.append(values)
    if not rows:
        raise ValueError("no point in the file (three columns x1 x2 x3 [m] expected)")
    points = np.array(rows, dtype=float)
    if not np.isfinite(points).all():
        raise ValueError("non-finite coordinates (nan or inf)")
    return points


def read_inclusion_cells(case: Case) -> tuple[np.ndarray | None, ...]:
    """Return the points of each inhomogeneity of ``case``: (k, 3) for cells, None otherwise.

    Empty for a body without inhomogeneities; what
    :func:`sacflow.config.solver_inputs.simulation_for` takes as ``cells``.
    """
    return tuple(None if item.cells is None else read_cells_file(item.cells)
                 for item in case.body.inhomogeneity)


def check_inclusion_cells(case: Case, source: str) -> None:
    """Check the cells files of ``case``: readable, points in the cuboid box, no overlap.

    Raises
    ------
    ConfigError
        ``source: invalid case (1 problem)`` naming ``body.inhomogeneity.<i>.cells``.
    """
    for index, item in enumerate(case.body.inhomogeneity):
        if item.cells is None:
            continue
        where = f"body.inhomogeneity.{index}.cells"
        try:
            points = read_cells_file(item.cells)
        except (OSError, ValueError, UnicodeDecodeError) as exc:
            reason = getattr(exc, "strerror", None) or exc
            raise ConfigError(report(source, [f"{where}: cannot read the cells file "
                                              f"{str(item.cells)!r}: {reason}"])) from None
        problem = cells_problem(case, index, points)
        if problem is not None:
            raise ConfigError(report(source, [problem]))
