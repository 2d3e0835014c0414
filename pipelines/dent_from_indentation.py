"""What the indentation history of a dent changes under rolling: a chained case against its twin.

    python pipelines/dent_from_indentation.py --out runs/dent-from-indentation [--set KEY=VALUE ...]
        [--press-set KEY=VALUE ...] [--overwrite]

1. runs ``dent-from-indentation-press.toml``: a rigid sphere pressed into the bearing steel and
   removed (the dent, with its plastic strain, hardening and residual stress);
2. writes the dent the rolling case starts on (the residual surface displacement of the press's
   plastic strain on the rolling body grid) as a text surface
   (``dent-from-indentation-surface.txt``: x1 x2 height, height positive outward);
3. runs ``dent-from-indentation-rolling.toml`` (starts from the press's state, ``initial_state``)
   and ``dent-from-indentation-geometric.toml`` (the same shape as a measured surface on a
   virgin body), both rolled at 2.5 GPa over the dent;
4. runs the fatigue stage on both and writes ``dent-from-indentation-comparison.nc`` and ``.png``:
   residual σ11 along the track at a depth, their minima, the largest equivalent plastic strain,
   the maximum Dang Van index (middle of the track) and where it sits from the dent.

``--set`` changes both rolling cases (``--set grid.nx=32 --set grid.ny=32``); ``--press-set``
the press. Finished runs are not run again. A run of another case under the same name (say a
press made before its config changed) is kept, and the script stops with a message, unless
``--overwrite`` is given: then the three runs are replaced by those of the cases asked for.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from sacflow.compare.fatigue_index import fatigue
from sacflow.compare.output import write
from sacflow.config.schema import Case
from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import SacflowError
from sacflow.runner import run_case
from sacflow.storage.atomic_file import write_atomically
from sacflow.storage.case_file import load_case
from sacflow.storage.initial_state_file import read_initial_state

HERE = Path(__file__).resolve().parent
PRESS, CHAINED, GEOMETRIC = (HERE / f"dent-from-indentation-{k}.toml"
                             for k in ("press", "rolling", "geometric"))
SURFACE = "dent-from-indentation-surface.txt"
#: Depth of the residual σ11 profiles along the track (the seed's Fig. 22 depth) [m].
PROFILE_DEPTH = 75e-6


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("runs/dent-from-indentation"))
    parser.add_argument("--set", dest="overrides", action="append", default=[])
    parser.add_argument("--press-set", dest="press_overrides", action="append", default=[])
    parser.add_argument("--no-progress", action="store_true")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace runs of other cases stored under the same names")
    args = parser.parse_args(argv)
    try:
        result = compare_histories(args.out.resolve(), args.overrides, args.press_overrides,
                                   progress=not args.no_progress, overwrite=args.overwrite)
    except SacflowError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for name, value in result.items():
        print(f"{name:44s} {value:.6g}")
    return 0


def compare_histories(out: Path, overrides: list[str], press_overrides: list[str],
                      progress: bool = True, overwrite: bool = False) -> dict[str, float]:
    """Run the three cases and the comparison (see the module docstring); return the numbers.

    ``overwrite`` replaces a stored run of another case under a run's name
    (:func:`sacflow.runner.run_case`); without it such a run is kept and the runner's
    :class:`SacflowError` says so.
    """
    press_case = load_case(PRESS, press_overrides)
    for rolling in (CHAINED, GEOMETRIC):  # every --set checked before the press runs
        load_case(rolling, overrides, check_files=False)  # the press run does not exist yet
    out.mkdir(parents=True, exist_ok=True)
    press = run_case(press_case, out, progress=progress, overwrite=overwrite).path
    chained_case = load_case(CHAINED, [*overrides, f"initial_state.run={press}"])
    surface = write_surface(chained_case, out / SURFACE)
    chained = run_case(chained_case, out, progress=progress, overwrite=overwrite).path
    geometric = run_case(load_case(GEOMETRIC, [*overrides, f"surface.path={surface}"]), out,
                         progress=progress, overwrite=overwrite).path
    result = comparison(chained, geometric)
    path = out / "dent-from-indentation-comparison.nc"
    write_atomically(path, result.to_netcdf)
    figure = plot(result)
    write_atomically(path.with_suffix(".png"), lambda tmp: figure.savefig(tmp, dpi=120))
    for run in (chained, geometric):
        write(fatigue(run), out / "fatigue", f"{run.stem}-fatigue")
    return {k: float(v) for k, v in result.data_vars.items() if v.ndim == 0}


def write_surface(chained: Case, target: Path) -> Path:
    """Write the dent the chained case starts on as a text surface on its body grid.

    The chained case's residual surface displacement at its start, from the press's plastic
    strain mapped onto its grid (``initial_state``), is the dented surface it rolls over; the
    geometric twin reads the same shape (height = −displacement, positive outward), so both
    start on one geometry and differ only by the indentation's plastic state.
    """
    sim = simulation_for(chained, initial=read_initial_state(chained))
    x1, x2 = np.meshgrid(sim.coords.x1, sim.coords.x2, indexing="ij")
    lines = [f"# dent of {Path(chained.initial_state.run).name} on the body grid of "  # type: ignore[union-attr]
             f"{chained.name}: height = -residual displacement, m",
             "# columns: x1 [m] x2 [m] height [m]"]
    lines += [f"{a!r} {b!r} {-h!r}" for a, b, h in  # full precision: the grid's own points
              zip(x1.ravel().tolist(), x2.ravel().tolist(),
                  sim.residual_displacement.ravel().tolist(), strict=True)]
    return write_atomically(target, lambda tmp: tmp.write_text("\n".join(lines) + "\n"))


def _after(run: xr.Dataset) -> xr.Dataset:
    """The run's last step: the load removed, the stored stress is the residual stress."""
    last = run.isel(step=-1)
    if float(last["load"]) != 0.0:
        raise SacflowError("the rolling cases must end unloaded (their last segment unloads)")
    return last


def comparison(chained: Path, geometric: Path) -> xr.Dataset:
    """Residual σ11 along the track at PROFILE_DEPTH, εp and fatigue maxima of both runs."""
    data: dict[str, object] = {}
    coords = {}
    for label, path in (("chained", chained), ("geometric", geometric)):
        with xr.open_dataset(path) as run:
            last = _after(run)
            s11 = last["stress"].sel(component="11").sel(x2=0.0, x3=PROFILE_DEPTH,
                                                         method="nearest")
            coords[f"x1_{label}"] = s11["x1"].values
            data[f"residual_stress_11_{label}"] = (f"x1_{label}", s11.values)
            k = int(np.argmin(s11.values))
            data[f"residual_stress_11_min_{label}"] = float(s11.values[k])
            data[f"residual_stress_11_min_x1_{label}"] = float(s11["x1"].values[k])
            data[f"max_plastic_strain_{label}"] = float(last["equivalent_plastic_strain"].max())
        index = fatigue(path)
        data[f"dang_van_max_{label}"] = float(index["dang_van_track_max"])
        data[f"dang_van_max_x1_{label}"] = float(index["dang_van_track_max_x1"])
        data[f"dang_van_max_depth_{label}"] = float(index["dang_van_track_max_depth"])
    data["dang_van_ratio"] = data["dang_van_max_chained"] / data["dang_van_max_geometric"]
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update(Conventions="CF-1.10", profile_depth=PROFILE_DEPTH, chained=str(chained),
                    geometric=str(geometric),
                    title="rolling over a dent made by an indentation vs over its shape only")
    for name in ds.variables:
        ds[name].attrs["units"] = _units(str(name))
    return ds


def _units(name: str) -> str:
    if name.startswith("residual_stress"):
        return "Pa"
    if "_x1" in name or name.startswith("x1") or "depth" in name:
        return "m"
    return "1"


def plot(result: xr.Dataset) -> Figure:
    """Residual σ11 along the track at the profile depth, both runs."""
    fig = Figure(figsize=(7.5, 4.5), layout="constrained")
    ax = fig.subplots()
    names = {"chained": "dent made by the indentation", "geometric": "same shape, no history"}
    for label, name in names.items():
        x = result[f"x1_{label}"].values * 1e6
        ax.plot(x, result[f"residual_stress_11_{label}"].values * 1e-6, label=name)
    depth = result.attrs["profile_depth"] * 1e6
    ax.set(xlabel="x1 [µm] (rolling along +x1, dent at 0)",
           ylabel="residual σ11 [MPa]", title=f"after rolling, x2 = 0, x3 = {depth:.0f} µm")
    ax.set_xlim(-800, 800)
    ax.grid(True, alpha=0.3)
    ax.legend()
    return fig


if __name__ == "__main__":
    sys.exit(main())
