"""Every shipped case runs at a tiny grid and gives one sane number (STYLE 5)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sacflow.config import load_case
from sacflow.runner import run_case
from sacflow.store import open_run

CONFIGS = sorted(p for p in (Path(__file__).parent.parent / "configs").glob("*.toml")
                 if "campaign" not in p.name)


def tiny(path: Path):
    """The case at 16×16 cells (or the smallest grid its checks allow), 4 layers, few steps."""
    case = load_case(path)
    nx = max(16, int(np.ceil(16 * case.grid.half_width / 1.5)))
    return tiny_case(case, nx, 4)


def tiny_case(case, nx: int, nz: int):
    """``case`` on nx × nx cells and nz layers, one increment per load segment, 3 roll steps."""
    segments = []
    for seg in case.load_path:
        if seg.kind == "roll":
            seg = seg.model_copy(update={"steps": 3})
        elif seg.kind in ("load", "unload"):
            seg = seg.model_copy(update={"increments": 1})
        segments.append(seg)
    grid = case.grid.model_copy(update={"nx": nx, "ny": nx, "nz": nz})
    return case.model_copy(update={"grid": grid, "load_path": tuple(segments)})


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_shipped_config_runs_at_tiny_grid(path, tmp_path):
    case = tiny(path)
    summary = run_case(case, tmp_path, progress=False)
    ds = open_run(summary.path)
    loaded = int(np.argmax(ds["load"].values))  # ds.load is Dataset.load()
    hertz = case.hertz()
    p_max = float(ds["max_pressure"].values[loaded])
    # one number: the peak pressure at maximum load is of the Hertz order (elastic-plastic and
    # dented contacts differ from Hertz, but not by more than a factor of about two)
    assert 0.3 * hertz.p0 < p_max < 3.0 * hertz.p0, f"{path.stem}: p_max/p0 = {p_max / hertz.p0}"
    assert ds.sizes["step"] == summary.steps
