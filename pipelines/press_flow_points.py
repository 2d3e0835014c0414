"""Points of flow without cells of their own: is the press's lateral error the flow's sampling?

``python pipelines/press_flow_points.py [--cells N] [--layers L] [--increments LOAD UNLOAD]
[--variants V,...] [--read-by-coarse-cells] [--table CSV [--overwrite]]``

The press's lateral error (docs/convergence.md, "What is left of the press's error") could be
that of computing the flow at one point per cell while the cell mean already spreads each cell's
plastic strain bilinearly over its neighbours; more points of flow per cell would then remove
it. This script tests that with three runs of the press
(``pipelines/dent-from-indentation-press.toml`` as its lateral tables were recorded: the
traction beyond the box left out, the study's box depth), all with the contact solved on the
same 2N × 2N surface cells:

* ``coarse``: N² cells with the contact on 2 × 2 sub-cells: one point of flow per cell;
* ``points``: (2N)² cells whose plastic strain the eigenstrain operator sees as its mean over
  blocks of 2 × 2 cells: the N² cells' plastic strain, with the flow computed at four points
  of each (the centres of its quarters, each with its own plastic strain and hardening);
* ``averaged``: (2N)² cells whose return, at each cell's own stress, is replaced by its mean
  over the cell's block of 2 × 2 (both Δεp and Δp): the N² cells' plastic strain and hardening,
  each cell's increment the mean of the flows at its four points; every point keeps the plastic
  strain the operators see;
* ``fine``: (2N)² cells, each with its own plastic strain.

If the flow's sampling carried the error, ``points`` or ``averaged`` would lie near ``fine``.
What ``points`` shows instead (docs/convergence.md, "What is left of the press's error") is that
a point whose plastic strain the operator only sees through its block's mean is relieved by
about a third of the stress its own plastic strain should remove, so it flows further: the
points' plastic strains part from each other with nothing to stop them. ``averaged`` is the
consistent form of more points of flow per cell unknown. ``--variants`` runs a subset. The
table gives each run's quantities (:func:`sacflow.studies.convergence.measure`), the largest
block mean of εp over 2 × 2 cells, the plastic iterations and the time.
``--read-by-coarse-cells`` adds, for the fine-lattice variants, the residual σ11 on the axis of
the run's plastic strain averaged over each block and read through the N² cells' operator: how
much of a difference from ``coarse`` is the fine cells' reading, and how much the strain.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

import numpy as np
from press_edge_position import case_for

from sacflow.config.case import Case
from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import SacflowError
from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.solver.history import light_history
from sacflow.studies.convergence_table import (
    add_table_arguments,
    refuse_existing_table,
    write_runs_table,
)
from sacflow.studies.lateral_error_split import axis_s11, block_average

#: The press's lateral window in Hertz radii (its config's ``grid.half_width``).
WINDOW = 3.0
#: Cells per block side: the ``points`` run's eigenstrain is the mean over BLOCK² cells.
BLOCK = 2
VARIANTS = ("coarse", "points", "averaged", "fine")
#: Quantities printed on each line (all of :func:`measure`'s go to the table).
SHOWN = ("print_depth_refined", "peak_pressure", "max_plastic_strain_refined",
         "max_plastic_strain_block_mean", "residual_s11_axis_refined_at_0.5a",
         "residual_s11_axis_refined_at_1.5a")


def spread_block_mean(field: np.ndarray, block: int = BLOCK) -> np.ndarray:
    """``field`` with each block of ``block`` × ``block`` cells replaced by its mean."""
    mean = block_average(field, block)
    return np.ascontiguousarray(np.repeat(np.repeat(mean, block, axis=0), block, axis=1))


def see_block_means(eigen: HalfSpaceEigenstrain, block: int = BLOCK) -> None:
    """Make ``eigen`` act on the block means of every plastic strain it is given.

    Its two entry points that take a plastic strain, :meth:`surface_fields` (through which
    :meth:`residual_stress` goes) and :meth:`residual_displacement`, are wrapped on this
    instance; the solver's own plastic strain, one per cell, is left as it is.
    """
    surface_fields, residual_displacement = eigen.surface_fields, eigen.residual_displacement

    def block_surface_fields(eps: np.ndarray, with_displacement: bool = True
                             ) -> tuple[np.ndarray, np.ndarray | None]:
        return surface_fields(spread_block_mean(eps, block), with_displacement)

    def block_residual_displacement(eps: np.ndarray) -> np.ndarray:
        return residual_displacement(spread_block_mean(eps, block))

    eigen.surface_fields = block_surface_fields  # type: ignore[method-assign]
    eigen.residual_displacement = block_residual_displacement  # type: ignore[method-assign]


def average_the_return(fixed_point: Any, block: int = BLOCK) -> None:
    """Make ``fixed_point``'s return give every cell its block's mean Δεp and Δp (in place).

    ``fixed_point`` is the solver's :class:`~sacflow.solver.fixed_point.PlasticFixedPoint`; its
    return (``_return``: the one the fixed point iterates and the one its Jacobian is built on)
    is wrapped on this instance. Each cell still returns at its own trial stress; the means make
    the plastic strain uniform over each block, as the coarse cells' unknowns are.
    """
    original = fixed_point._return

    def averaged(*args: Any) -> Any:
        returns = original(*args)
        for result in {id(r): r for r in returns}.values():  # once if they are one object
            for field in (result.plastic_strain_increment,
                          result.equivalent_plastic_strain_increment):
                field[...] = spread_block_mean(field, block)
        return returns

    fixed_point._return = averaged


def variant_case(variant: str, cells: int, layers: int, increments: tuple[int, int]) -> Case:
    """Return the press of ``variant`` (module doc) for the coarse grid of ``cells`` per side."""
    if variant == "coarse":
        return case_for(cells, layers, increments, WINDOW, subcells=BLOCK)
    return case_for(BLOCK * cells, layers, increments, WINDOW)


def read_by_coarse_cells(sim: Any, coarse: Any, axis: tuple[float, float],
                         contact_radius: float) -> dict[str, float]:
    """σ11 on the axis of ``sim``'s plastic strain averaged over blocks, through ``coarse``.

    ``coarse`` is the ``coarse`` variant's simulation (set up, not run): its eigenstrain
    operator turns the 2 × 2 block means of ``sim``'s final plastic strain into residual stress,
    read on the axis as the study reads it (:func:`sacflow.studies.lateral_error_split.axis_s11`)
    at :data:`~sacflow.studies.convergence.PROFILE_DEPTHS`. Against the run's own values it
    separates how the fine cells read a plastic strain from what that strain is.
    """
    from sacflow.studies.convergence import PROFILE_DEPTHS

    blocks = block_average(np.asarray(sim.plastic_strain, dtype=float), BLOCK)
    stress = coarse.operators.eigenstrain.residual_stress(blocks)
    coords = (coarse.coords.x1, coarse.coords.x2, coarse.coords.x3)
    values = axis_s11(stress, coords, axis, [d * contact_radius for d in PROFILE_DEPTHS])
    return {f"coarse_read_s11_axis_refined_at_{d:g}a": value
            for d, value in zip(PROFILE_DEPTHS, values.values(), strict=True)}


def run_variant(variant: str, case: Case, coarse: Any = None) -> dict[str, Any]:
    """Run ``case`` as ``variant`` and return its row of the table.

    With ``coarse`` (the ``coarse`` variant's simulation, set up) a run on the fine lattice
    also gets :func:`read_by_coarse_cells`'s columns.
    """
    from sacflow.studies.convergence import measure

    start = time.perf_counter()
    sim = simulation_for(case)
    if variant == "points":
        see_block_means(sim.operators.eigenstrain)
    elif variant == "averaged":
        average_the_return(sim.increments.fixed_point)
    states = light_history(sim.run(), fields_of=lambda s: s.load)
    quantities, _ = measure(sim, states, case.hertz().a)
    strain = np.asarray(sim.equivalent_plastic_strain, dtype=float)
    even = strain.shape[0] % BLOCK == 0 and strain.shape[1] % BLOCK == 0
    seconds = time.perf_counter() - start
    read = {}
    if coarse is not None and variant != "coarse":
        top = max(states, key=lambda s: s.load)
        read = read_by_coarse_cells(sim, coarse, (top.load_x1, top.load_x2), case.hertz().a)
    return {"variant": variant, "nx": case.grid.nx, "layers": case.grid.nz,
            "subcells": case.solver.contact_subcells,
            "max_plastic_strain_block_mean": (float(block_average(strain, BLOCK).max()) if even
                                              else float("nan")),
            "plasticity_iterations": sum(s.plasticity_iterations for s in states),
            "seconds": seconds, **quantities, **read}


def parse(argv: list[str]) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=48,
                        help="cells per side of the coarse grid (48); the others have twice")
    parser.add_argument("--layers", type=int, default=64, help="layers over the box (64)")
    parser.add_argument("--increments", type=int, nargs=2, default=(20, 6),
                        metavar=("LOAD", "UNLOAD"), help="load and unload increments (20 6)")
    parser.add_argument("--variants", default=",".join(VARIANTS),
                        help=f"comma-separated, of {', '.join(VARIANTS)} (all)")
    parser.add_argument("--read-by-coarse-cells", action="store_true",
                        help="also read each fine run's block-mean plastic strain through the "
                             "coarse cells' operator (columns coarse_read_s11_...; a table "
                             "only of fine-lattice variants)")
    add_table_arguments(parser)
    args = parser.parse_args(argv)
    args.variants = [v.strip() for v in args.variants.split(",") if v.strip()]
    unknown = sorted(set(args.variants) - set(VARIANTS))
    if unknown or not args.variants:
        parser.error(f"--variants: {', '.join(unknown) or 'none given'}: choose from "
                     f"{', '.join(VARIANTS)}")
    return args


def main(argv: list[str]) -> None:
    """Run the variants, print a line each, write the table."""
    args = parse(argv)
    refuse_existing_table(args.table, args.overwrite)
    increments = (args.increments[0], args.increments[1])
    try:  # every case first: a grid the press cannot run stops before any run
        cases = [variant_case(v, args.cells, args.layers, increments) for v in args.variants]
    except SacflowError as exc:
        raise SystemExit(f"error: {exc}") from None
    if args.read_by_coarse_cells and "coarse" in args.variants:
        raise SystemExit("error: --read-by-coarse-cells reads the fine-lattice variants: "
                         "leave coarse out of --variants")
    coarse = (simulation_for(variant_case("coarse", args.cells, args.layers, increments))
              if args.read_by_coarse_cells else None)
    rows = []
    for variant, case in zip(args.variants, cases, strict=True):
        row = run_variant(variant, case, coarse)
        rows.append(row)
        shown = ", ".join(f"{name} {row[name]:.6g}" for name in SHOWN)
        print(f"{variant}: {row['nx']}² × {row['layers']}, {row['plasticity_iterations']} "
              f"plastic iterations, {row['seconds']:.0f} s; {shown}", flush=True)
    write_runs_table(args.table, rows, args.overwrite)


if __name__ == "__main__":
    main(sys.argv[1:])
