"""``pipelines/pressure_profile.py``: the pressure at the largest load along x1 through the axis."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
LINEAR = ROOT / "configs" / "nanoindentation-linear-650mN.toml"
TINY = ["grid.nx=16", "grid.ny=16", "grid.nz=6", "load_path.0.increments=2",
        "load_path.1.increments=1", "solver.fft_threads=1"]


def pipeline():
    spec = importlib.util.spec_from_file_location("pressure_profile",
                                                  ROOT / "pipelines" / "pressure_profile.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_profile_runs_out_to_the_contact_edge_and_holds_the_peak(capsys):
    assert pipeline().main([str(LINEAR), *TINY]) == 0
    out = json.loads(capsys.readouterr().out)
    profile, x1 = out["pressure_GPa"], out["x1_um"]
    assert out["step"] == 1  # the second load increment: the largest load
    assert len(profile) == len(x1) >= 2 and all(p > 0.0 for p in profile)
    assert all(b > a for a, b in zip(x1, x1[1:], strict=False)) and x1[0] > 0.0
    # the row is one of the surface's: its values cannot exceed the peak of the whole surface
    assert max(profile) <= out["peak_pressure_GPa"] + 1e-4


@pytest.mark.parametrize("argv, words", [
    ([str(LINEAR), "--cells", "-1"], "--cells must be 0"),
    ([str(ROOT / "configs" / "absent.toml")], "cannot read the file"),
    ([str(LINEAR), "grid.nx=-3"], "grid.nx"),
])
def test_a_bad_input_ends_in_a_message(argv, words, capsys):
    assert pipeline().main(argv) == 2
    assert words in capsys.readouterr().err
