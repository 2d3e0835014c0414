"""The press made elastic, refined laterally: σ11 on the axis against Hertz's closed form.

``python pipelines/press_elastic_lateral.py [NX ...]`` (default 48 72 96 144)

The indentation press's σ11 at 0.5 a converges below first order under lateral refinement
(``data/convergence-press-grid.csv``). This script asks whether the elastic contact and its
stress already do: it runs ``pipelines/dent-from-indentation-press.toml`` with an elastic body
(one load increment, 128 layers over the press's box) on nx² cells and prints the stress σ11 on
the axis at the peak load, interpolated to the axis and to the depths 0.25, 0.5 and 1 a as the
convergence study reads its profile, with its error against Hertz's σr on the axis
(Johnson, *Contact Mechanics*, 1985, eq. 3.45; rigid sphere, composite modulus of the case).
"""

from __future__ import annotations

import argparse
import math
import sys
import time

from sacflow.compare.fields import quadratic_at
from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import SacflowError
from sacflow.studies.convergence import STUDY_CASES, base_case, shipped_discretisation

CASE = STUDY_CASES["dent-from-indentation-press"]
#: Depths of the profile, in Hertz radii (those of the convergence study).
DEPTHS = (0.25, 0.5, 1.0)
#: Layers over the press's box depth (its shipped 128).
LAYERS = 128


def hertz_radial_stress(z_over_a: float, nu: float) -> float:
    """σr / p0 on the axis of a Hertz contact at depth z (Johnson eq. 3.45)."""
    z = z_over_a
    return -(1.0 + nu) * (1.0 - z * math.atan(1.0 / z)) + 1.0 / (2.0 * (1.0 + z * z))


def main(argv: list[str]) -> None:
    """Run each lateral grid and print σ11 on the axis with its error against Hertz."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("grids", nargs="*", type=int, default=[48, 72, 96, 144], metavar="NX",
                        help="surface cells per side (default 48 72 96 144)")
    grids = parser.parse_args(argv).grids
    depth = shipped_discretisation(base_case(CASE)).depth
    for nx in grids:
        try:
            case = base_case(CASE, ['body.hardening={law = "elastic"}', f"grid.nx={nx}",
                                    f"grid.ny={nx}", f"grid.nz={LAYERS}",
                                    f"grid.depth={depth!r}", "load_path.0.increments=1",
                                    "load_path.1.increments=1", "output.volume_every=1"])
        except SacflowError as exc:  # a grid the case cannot run: the message, no traceback
            raise SystemExit(f"error: {exc}") from None
        hertz = case.hertz()
        start = time.time()
        sim = simulation_for(case)
        top = max(sim.run(), key=lambda s: s.load)
        x1, x2, x3 = sim.coords.x1, sim.coords.x2, sim.coords.x3
        on_axis = quadratic_at(top.volume["stress"][..., 0], (x1, x2), (0.0, 0.0))
        parts = []
        for f in DEPTHS:
            value = float(quadratic_at(on_axis, (x3,), (f * hertz.a,)))
            exact = hertz_radial_stress(f, case.body.nu) * hertz.p0
            parts.append(f"{f:g} a: {value / 1e6:.2f} MPa ({(value - exact) / abs(exact):+.3%})")
        print(f"{nx}² × {LAYERS}: {time.time() - start:.0f} s; σ11 on the axis " + ", ".join(parts),
              flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
