"""Which cells carry the lateral cells' error of the press's residual σ11 on the axis.

``python pipelines/press_lateral_error_split.py COARSE.nc FINE.nc [--table CSV] [--plot PNG]
[--overwrite]``

COARSE.nc and FINE.nc are finished runs of one case whose lateral cells differ by a whole
ratio (FINE's cells divide each of COARSE's into r × r, r = 1 included) and whose increments may
differ too (their cases may differ in ``grid.nx``, ``grid.ny``, the load path's increments and
the output only, which is checked), each storing its last step's volume fields, e.g. the press
of the indentation-made dent run with ``--set grid.nx=48 --set grid.ny=48`` and with 96.
The difference of their residual σ11 on the load axis at the convergence study's profile depths
is split exactly (:mod:`sacflow.studies.lateral_error_split`) into a *flow* part (the coarse
operator applied to the fine run's plastic strain averaged over each coarse cell minus the
coarse run's own), itself a sum over regions of the body (radius and depth bands in Hertz
radii), and a *representation* part (the same strain on fine or coarse cuboids). Each region's
row also gives the change of its equivalent plastic strain summed over its volume, the change of
largest magnitude and the coarse run's εp in that cell. ``--table`` writes the rows, ``--plot``
the coarse run's εp and the change on the section through the axis (each refused if the file
exists, unless ``--overwrite``).
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from sacflow.config.case import Case
from sacflow.config.dotted import flatten
from sacflow.config.parsing import validate_case
from sacflow.errors import SacflowError
from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.storage.run_reader import open_run
from sacflow.studies.convergence import PROFILE_DEPTHS
from sacflow.studies.convergence_table import (
    add_table_arguments,
    refuse_existing_table,
    write_csv,
    write_figure,
)
from sacflow.studies.lateral_error_split import (
    Region,
    plot_strain_change,
    regions_of,
    split,
    strain_change_by_region,
)

#: Radius and depth bands of the regions, in Hertz radii (the press's contact edge lies near
#: 1.35 of them at the peak load).
RADII = (0.0, 0.5, 1.0, 1.25, 1.5, math.inf)
DEPTHS = (0.0, 0.25, 1.0, math.inf)
REGIONS = tuple(Region(r0, r1, z0, z1) for r0, r1 in zip(RADII, RADII[1:], strict=False)
                for z0, z1 in zip(DEPTHS, DEPTHS[1:], strict=False))
NEEDED = ("plastic_strain", "residual_stress", "equivalent_plastic_strain")
PROFILE = tuple(f"s11_at_{d:g}a" for d in PROFILE_DEPTHS)
COLUMNS = ("part", "r_from", "r_to", "z_from", "z_to", "strain_change_volume",
           "largest_strain_change", "strain_there", *PROFILE)
#: The case fields two runs may differ in (shell patterns): their lateral cells, the increments
#: of their load path and what they store.
FREE = ("grid.nx", "grid.ny", "load_path.*.increments", "output.*")
#: Largest relative miss of the rebuilt operator on the coarse run's own stress: above it the
#: operator is not the run's (other solver settings) and the split would be wrong.
OPERATOR_MISS = 1e-9


def read_run(path: Path) -> dict[str, Any]:
    """The last step's fields, the lattice and the case of the run file ``path``."""
    with open_run(path, lazy=True) as ds:
        missing = [name for name in NEEDED if name not in ds]
        if missing:
            raise SacflowError(f"{path} stores no {', '.join(missing)} at its last step: run "
                               "it with the press's shipped [output] fields")
        last = {name: np.asarray(ds[name].isel(step=-1).values, dtype=float) for name in NEEDED}
        coords = tuple(np.asarray(ds[c].values, dtype=float) for c in ("x1", "x2", "x3"))
        case = validate_case(json.loads(ds.attrs["case"]), str(path))
        area = float(ds["contact_area"].max()) if "contact_area" in ds else math.nan
    return {**last, "coords": coords, "case": case, "contact_radius": math.sqrt(area / math.pi)}


def operator_of(run: dict[str, Any]) -> HalfSpaceEigenstrain:
    """The run's plastic strain → residual stress operator, checked on its own stress."""
    x1, _, x3 = run["coords"]
    case = run["case"]
    op = HalfSpaceEigenstrain(run["plastic_strain"].shape[:3],
                              (float(x1[1] - x1[0]),) * 2 + (float(x3[1] - x3[0]),),
                              float(case.body.E), float(case.body.nu),
                              stress_sampling=case.solver.stress_sampling,
                              traction_beyond_box=case.solver.traction_beyond_box)
    stress = run["residual_stress"]
    miss = float(np.abs(op.residual_stress(run["plastic_strain"]) - stress).max()
                 / np.abs(stress).max())
    if miss > OPERATOR_MISS:
        raise SacflowError(f"the rebuilt operator misses the coarse run's residual stress by "
                           f"{miss:.2g} of its largest value: the run used solver settings this "
                           "script does not rebuild")
    return op


def differences(coarse: Case, fine: Case) -> list[str]:
    """The dotted fields in which two cases' identities differ, those of :data:`FREE` left out.

    The identity (:meth:`~sacflow.config.case.Case.identity`) leaves out what changes no number
    (the name, the threads); :func:`~sacflow.config.dotted.flatten` lists every field by path.
    """
    a, b = flatten(coarse.identity()), flatten(fine.identity())
    absent = object()
    return [path for path in sorted(a.keys() | b.keys())
            if a.get(path, absent) != b.get(path, absent)
            and not any(fnmatch.fnmatchcase(path, pattern) for pattern in FREE)]


def rows_of(coarse: dict[str, Any], fine: dict[str, Any]) -> list[dict[str, Any]]:
    """The table's rows for the two runs (as :func:`read_run` returns them)."""
    other = differences(coarse["case"], fine["case"])
    if other:
        raise SacflowError("the two runs differ in more than their lateral cells and "
                           f"increments: {', '.join(other)}; run the fine one with the coarse "
                           "one's case and only grid.nx, grid.ny or the increments changed")
    length = coarse["case"].hertz().a
    operator = operator_of(coarse).residual_stress
    result = split((coarse["plastic_strain"], coarse["residual_stress"]),
                   (fine["plastic_strain"], fine["residual_stress"]), operator,
                   (coarse["coords"], fine["coords"]), (0.0, 0.0), length, PROFILE_DEPTHS,
                   REGIONS)
    x1, _, x3 = coarse["coords"]
    masks = regions_of(coarse["coords"], (0.0, 0.0), length, REGIONS)
    stats = strain_change_by_region(coarse["equivalent_plastic_strain"],
                                    fine["equivalent_plastic_strain"], masks,
                                    float((x1[1] - x1[0]) ** 2 * (x3[1] - x3[0])))

    def row(part: str, values: dict[float, float], **extra: Any) -> dict[str, Any]:
        profile = {name: f"{values[d]:.10g}" for name, d in zip(PROFILE, PROFILE_DEPTHS,
                                                                 strict=True)}
        return {"part": part, **extra, **profile}

    rows = [row(name, getattr(result, name))
            for name in ("coarse", "fine", "flow", "representation")]
    for reg, values in result.by_region.items():
        volume, largest_change, there = stats[reg]
        rows.append(row("flow_region", values, r_from=reg.r_from, r_to=reg.r_to,
                        z_from=reg.z_from, z_to=reg.z_to,
                        strain_change_volume=f"{volume:.10g}",
                        largest_strain_change=f"{largest_change:.10g}",
                        strain_there=f"{there:.10g}"))
    return rows


def write_plot(coarse: dict[str, Any], fine: dict[str, Any], path: Path, overwrite: bool) -> None:
    """Draw :func:`~sacflow.studies.lateral_error_split.plot_strain_change` to ``path``."""
    if not math.isfinite(coarse["contact_radius"]):
        raise SacflowError("the coarse run stores no contact_area to mark the contact's edge: "
                           "run it with the press's shipped [output] fields")
    figure = plot_strain_change(coarse["equivalent_plastic_strain"],
                                fine["equivalent_plastic_strain"], coarse["coords"],
                                coarse["case"].hertz().a, coarse["contact_radius"],
                                PROFILE_DEPTHS)
    write_figure(figure, path, overwrite)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("coarse", type=Path, help="the run on the coarse lateral cells")
    parser.add_argument("fine", type=Path, help="the same case on r x r times the cells")
    add_table_arguments(parser)
    parser.add_argument("--plot", type=Path, help="write the section's εp and its change (PNG)")
    args = parser.parse_args(argv)
    try:
        refuse_existing_table(args.table, args.overwrite)
        refuse_existing_table(args.plot, args.overwrite)
        coarse, fine = read_run(args.coarse), read_run(args.fine)
        rows = rows_of(coarse, fine)
        if args.table is not None:
            write_csv(args.table, rows, COLUMNS, args.overwrite)
        if args.plot is not None:
            write_plot(coarse, fine, args.plot, args.overwrite)
    except (SacflowError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    print(f"{'part':14s} {'r [a]':>11s} {'z [a]':>11s} " + " ".join(f"{p:>13s}" for p in PROFILE))
    for r in rows:
        where = (f"{r['r_from']:>4g}-{r['r_to']:<6g} {r['z_from']:>4g}-{r['z_to']:<6g}"
                 if "r_from" in r else " " * 23)
        print(f"{r['part']:14s} {where} "
              + " ".join(f"{float(r[p]) / 1e6:13.2f}" for p in PROFILE))
    return 0


if __name__ == "__main__":
    sys.exit(main())
