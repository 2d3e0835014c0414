"""The split of a lateral refinement's σ11 change on the axis (sacflow.studies.lateral_error_split)
and the script that reads it from two runs (pipelines/press_lateral_error_split.py)."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from sacflow.config.inclusion_checks import box_depth
from sacflow.config.parsing import apply_overrides, validate_case
from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.studies.lateral_error_split import Region, block_average, regions_of, split

ROOT = Path(__file__).resolve().parents[1]
E, NU = 219e9, 0.3
#: Coarse cells of 45 µm across ±180 µm, eight layers of 30 µm; the fine lattice halves the
#: lateral cells. The unit length of the profile and regions: 100 µm.
DX, DZ, N, NZ, LENGTH = 45e-6, 30e-6, 8, 8, 100e-6
DEPTHS = (0.5, 1.0, 2.5)
#: The press's coarsest lattice its schema accepts (8 cells across the Hertz contact).
PRESS_N = 24
REGIONS = (Region(0.0, 1.0, 0.0, 1.0), Region(0.0, 1.0, 1.0, math.inf),
           Region(1.0, math.inf, 0.0, math.inf))


def centres(n: int, d: float, *, surface: bool = False) -> np.ndarray:
    """Cell centres of ``n`` cells of size ``d``: from the surface down, else about 0."""
    return (np.arange(n) + 0.5) * d if surface else (np.arange(n) - (n - 1) / 2) * d


def coords(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return centres(n, DX * N / n), centres(n, DX * N / n), centres(NZ, DZ, surface=True)


def strain(n: int, lattice: tuple[np.ndarray, ...] | None = None) -> np.ndarray:
    """A smooth plastic strain on ``n × n`` cells (``lattice``, default :func:`coords`),
    deviatoric, largest under the axis."""
    x1, x2, x3 = np.meshgrid(*(lattice or coords(n)), indexing="ij")
    bump = 0.01 * np.exp(-(x1**2 + x2**2) / (150e-6) ** 2 - (x3 - 90e-6) ** 2 / (80e-6) ** 2)
    return np.stack([-bump / 2, -bump / 2, bump, 0.3 * bump, 0.2 * bump, 0.1 * bump], axis=-1)


@pytest.fixture(scope="module")
def operators() -> dict[int, HalfSpaceEigenstrain]:
    return {n: HalfSpaceEigenstrain((n, n, NZ), (DX * N / n, DX * N / n, DZ), E, NU, threads=1)
            for n in (N, 2 * N)}


def test_block_average_keeps_each_coarse_cells_mean() -> None:
    coarse = np.arange(2 * 3 * 4, dtype=float).reshape(2, 3, 4)
    wiggle = np.array([[1.0, -1.0], [-2.0, 2.0]])[None, :, None, :, None]
    fine = (np.repeat(np.repeat(coarse, 2, axis=0), 2, axis=1)
            + np.tile(wiggle, (2, 1, 3, 1, 4)).reshape(4, 6, 4))
    assert np.array_equal(block_average(fine, 2), coarse)
    with pytest.raises(ValueError, match="not 4 x 4"):
        block_average(fine, 4)


def test_a_change_in_one_region_is_attributed_to_it_alone(operators) -> None:
    eps_c = strain(N)
    eps_f = np.repeat(np.repeat(eps_c, 2, axis=0), 2, axis=1)
    # A change of the fine strain in the cells of the core under the axis, near the surface,
    # with a nonzero mean over each coarse cell.
    x1, x2, x3 = np.meshgrid(*coords(2 * N), indexing="ij")
    core = (np.hypot(x1, x2) < 60e-6) & (x3 < 100e-6)
    eps_f[core] *= 1.2
    result = split((eps_c, operators[N].residual_stress(eps_c)),
                   (eps_f, operators[2 * N].residual_stress(eps_f)),
                   operators[N].residual_stress, (coords(N), coords(2 * N)), (0.0, 0.0),
                   LENGTH, DEPTHS, REGIONS)
    scale = max(abs(v) for v in result.coarse.values() if not math.isnan(v))
    inside, *others = REGIONS
    for depth in DEPTHS[:2]:
        assert abs(result.by_region[inside][depth]) > 1e-3 * scale
        for region in others:
            assert abs(result.by_region[region][depth]) < 1e-12 * scale
        assert sum(part[depth] for part in result.by_region.values()) == pytest.approx(
            result.flow[depth], rel=1e-12, abs=1e-12 * scale)
        assert result.flow[depth] + result.representation[depth] == pytest.approx(
            result.fine[depth] - result.coarse[depth], rel=1e-12, abs=1e-12 * scale)
    assert math.isnan(result.coarse[2.5])  # below the deepest layer centre
    with pytest.raises(ValueError, match="give the coarse run first"):  # the runs swapped
        split((eps_f, eps_f), (eps_c, eps_c), operators[N].residual_stress,
              (coords(2 * N), coords(N)), (0.0, 0.0), LENGTH, DEPTHS, REGIONS)


def test_regions_must_cover_every_cell_once() -> None:
    with pytest.raises(ValueError, match="every cell once"):
        regions_of(coords(N), (0.0, 0.0), LENGTH, REGIONS[:2])
    with pytest.raises(ValueError, match="every cell once"):
        regions_of(coords(N), (0.0, 0.0), LENGTH, (*REGIONS, Region(0.0, 0.5, 0.0, 1.0)))


def press(n: int, overrides: tuple[str, ...] = ()):
    """The press's case on ``n × n × NZ`` cells, and its lattice (x1, x2, x3)."""
    text = (ROOT / "pipelines" / "dent-from-indentation-press.toml").read_text()
    case = validate_case(apply_overrides(tomllib.loads(text), [
        f"grid.nx={n}", f"grid.ny={n}", f"grid.nz={NZ}", "solver.traction_beyond_box=false",
        *overrides]))
    dx, dz = case.cell_size()[0], box_depth(case) / NZ
    return case, (centres(n, dx), centres(n, dx), centres(NZ, dz, surface=True))


def operator_for(n: int, sampling: int = 2) -> HalfSpaceEigenstrain:
    """The press's plastic strain → residual stress operator on ``n × n × NZ`` cells."""
    _, (x1, _, x3) = press(n)
    spacing = (x1[1] - x1[0], x1[1] - x1[0], x3[1] - x3[0])
    return HalfSpaceEigenstrain((n, n, NZ), spacing, E, NU, threads=1, stress_sampling=sampling)


def run_file(path: Path, n: int, operator: HalfSpaceEigenstrain, area: bool = True,
             overrides: tuple[str, ...] = ()) -> None:
    """A run file of the press on ``n × n × NZ`` cells: a plastic strain at its last step,
    ``operator``'s stress of it and (``area``) the contact area of a radius of 150 µm; its case
    with ``overrides``."""
    import xarray as xr

    case, lattice = press(n, overrides)
    eps = strain(n, lattice)
    stress = operator.residual_stress(eps)
    dims = ("step", "x1", "x2", "x3", "component")
    extra = {"contact_area": (("step",), [math.pi * (150e-6) ** 2])} if area else {}
    xr.Dataset({"plastic_strain": (dims, eps[None]), "residual_stress": (dims, stress[None]),
                "equivalent_plastic_strain": (dims[:4], eps[None, ..., 2]), **extra},
               coords={"step": [0], "x1": lattice[0], "x2": lattice[1], "x3": lattice[2]},
               attrs={"case": case.model_dump_json(), "case_id": "test", "complete": 1}
               ).to_netcdf(path)


def _script():
    """``pipelines/press_lateral_error_split.py`` as a module."""
    import importlib.util

    script = ROOT / "pipelines" / "press_lateral_error_split.py"
    spec = importlib.util.spec_from_file_location("press_lateral_error_split", script)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_script_splits_two_runs_and_never_replaces_a_table(tmp_path) -> None:
    module = _script()
    coarse, fine, table = tmp_path / "c.nc", tmp_path / "f.nc", tmp_path / "split.csv"
    run_file(coarse, PRESS_N, operator_for(PRESS_N))
    run_file(fine, 2 * PRESS_N, operator_for(2 * PRESS_N))
    assert module.main([str(coarse), str(fine), "--table", str(table)]) == 0
    import csv

    rows = list(csv.DictReader(table.open()))
    assert [r["part"] for r in rows[:4]] == ["coarse", "fine", "flow", "representation"]
    assert len(rows) == 4 + len(module.REGIONS)
    column = "s11_at_0.5a"
    flow = float(rows[2][column])
    digits = 1e-9 * abs(float(rows[0][column]))  # the table keeps ten significant digits
    assert sum(float(r[column]) for r in rows[4:]) == pytest.approx(flow, abs=digits)
    assert float(rows[1][column]) - float(rows[0][column]) == pytest.approx(
        flow + float(rows[3][column]), abs=digits)
    before = table.read_text()
    with pytest.raises(SystemExit, match="exists; nothing was changed"):
        module.main([str(coarse), str(fine), "--table", str(table)])
    assert table.read_text() == before
    plot = tmp_path / "split.png"
    assert module.main([str(coarse), str(fine), "--plot", str(plot)]) == 0
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_script_refuses_runs_it_cannot_split(tmp_path, capsys) -> None:
    module = _script()
    other, fine = tmp_path / "other.nc", tmp_path / "f.nc"
    run_file(other, PRESS_N, operator_for(PRESS_N, sampling=1))  # the case says 2
    run_file(fine, 2 * PRESS_N, operator_for(2 * PRESS_N))
    assert module.main([str(other), str(fine)]) == 1
    assert "rebuilt operator misses" in capsys.readouterr().err
    assert module.main([str(tmp_path / "missing.nc"), str(fine)]) == 1
    assert "no run at" in capsys.readouterr().err
    coarse, other_case = tmp_path / "c.nc", tmp_path / "other-case.nc"
    run_file(coarse, PRESS_N, operator_for(PRESS_N))
    run_file(other_case, 2 * PRESS_N, operator_for(2 * PRESS_N),
             overrides=("solver.contact_subcells=4",))
    assert module.main([str(coarse), str(other_case)]) == 1
    assert "lateral cells and increments: solver.contact_subcells;" in capsys.readouterr().err
    # Runs that differ in their increments (and what they store) only are split on one lattice.
    more_increments = tmp_path / "more-increments.nc"
    run_file(more_increments, PRESS_N, operator_for(PRESS_N),
             overrides=("load_path.0.increments=40", "output.volume_every=52"))
    assert module.main([str(coarse), str(more_increments)]) == 0
    no_area = tmp_path / "no-area.nc"
    run_file(no_area, PRESS_N, operator_for(PRESS_N), area=False)
    assert module.main([str(no_area), str(fine), "--plot", str(tmp_path / "p.png")]) == 1
    assert "no contact_area" in capsys.readouterr().err
    assert not (tmp_path / "p.png").exists()
