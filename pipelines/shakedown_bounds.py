"""Shakedown limits of free rolling, bracketed: certified Melan floor, kinematic ceiling.

    python pipelines/shakedown_bounds.py [--out DIR] [--quick]

Prints one JSON line per contact and residual field class
(``sacflow.mechanics.shakedown_bracket.rolling_bracket``), all peak pressures in units of
k = σ_Y/√3 (von Mises), ν = 0.3, with the settings used:

* ``first_yield_p0_over_k``: first yield;
* ``melan_at_samples_p0_over_k``: the optimiser's Melan factor with yield checked at its
  samples only (not a bound);
* ``lower_p0_over_k``: the certified lower bound (yield checked everywhere between the samples
  and beyond the box: ``sacflow.mechanics.shakedown_certificate``);
* ``ceiling_p0_over_k``: the kinematic-hardening ceiling, an upper bound of the perfectly
  plastic shakedown limit (``sacflow.mechanics.shakedown_ceiling``);
* ``gap``: ceiling / lower − 1.

Cases: line contact, ρ11(x3), ρ22(x3) (the classical case, answer 4.0 k); point contact with
the depth-only field; point contact with the whole steady class (three stress functions on a
box of ±3 a × 3 a). With ``--out`` it also writes ``shakedown_bounds.json`` and
``shakedown_bounds.png`` (the point contact's residual stresses on the axis, and where the von
Mises stress of the safe state is highest). ``--quick`` uses coarse samples and knots (the
tests run it). The whole class takes minutes at the default settings.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from sacflow.errors import SacflowError
from sacflow.mechanics.shakedown import MelanBound
from sacflow.mechanics.shakedown_bracket import rolling_bracket
from sacflow.storage.atomic_file import write_atomically
from sacflow.storage.output_dir import check_output_dir

SQRT3 = float(np.sqrt(3.0))
#: (contact, class, settings) of the report; lengths in contact radii (half-widths).
CASES: list[tuple[str, str, dict[str, float]]] = [
    ("line", "depth", {"depth": 2.0, "sample_step": 1 / 48, "knot_step": 1 / 16,
                       "ceiling_step": 1 / 96}),
    ("point", "depth", {"half_width": 1.5, "depth": 2.0, "sample_step": 1 / 24,
                        "knot_step": 1 / 8, "ceiling_step": 1 / 48}),
    ("point", "full", {"half_width": 3.0, "depth": 3.0, "sample_step": 1 / 12,
                       "knot_step": 1 / 4, "ceiling_step": 1 / 24}),
]
#: Coarser settings of ``--quick`` (and a smaller box for the whole class).
QUICK: dict[str, float] = {"sample_step": 1 / 6, "knot_step": 1 / 2, "ceiling_step": 1 / 6}
QUICK_BOX: dict[str, float] = {"half_width": 1.5, "depth": 1.5}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=None, help="folder for the JSON and plot")
    parser.add_argument("--quick", action="store_true", help="coarse settings (a smoke run)")
    args = parser.parse_args(argv)
    if args.out is not None:
        try:  # a bad folder is reported now, not after minutes of work
            check_output_dir(args.out)
        except SacflowError as exc:
            parser.error(str(exc))
    rows, results = [], []
    for contact, kind, settings in CASES:
        if args.quick:
            settings = {**settings, **QUICK, **(QUICK_BOX if kind == "full" else {})}
        start = time.perf_counter()
        bracket = rolling_bracket(contact, 0.3, kind=kind, **settings)  # type: ignore[arg-type]
        bound = bracket.melan
        row: dict[str, Any] = {
            "contact": contact, "residual_class": kind, **settings,
            "first_yield_p0_over_k": SQRT3 * bound.elastic_limit,
            "melan_at_samples_p0_over_k": SQRT3 * bracket.sampled,
            "lower_p0_over_k": SQRT3 * bracket.lower,
            "ceiling_p0_over_k": SQRT3 * bracket.ceiling,
            "gap": bracket.gap,
            "certificate": {
                "margin": bracket.margin, "cells": bracket.inside.cells,
                "unresolved_cells": bracket.inside.unresolved,
                "at_cell_corners_p0_over_k": SQRT3 / bracket.inside.sampled,
                "bound_inside": bracket.inside.bound, "bound_outside": bracket.outside,
                "residual_alone": bracket.residual_alone.bound,
            },
            "ceiling_radius_exact_to": bracket.ceiling / bracket.ceiling_low - 1.0,
            "stages": [[s, n, SQRT3 * f] for s, n, f in bound.stages],
            "seconds": time.perf_counter() - start,
        }
        print(json.dumps(row), flush=True)
        rows.append(row)
        results.append(bound)
    if args.out is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        write_atomically(args.out / "shakedown_bounds.json",
                         lambda tmp: tmp.write_text(json.dumps(rows, indent=1) + "\n"))
        write_atomically(args.out / "shakedown_bounds.png", lambda tmp: plot(rows, results, tmp))
    return 0


def plot(rows: list[dict[str, Any]], results: list[MelanBound], path: Path) -> None:
    """Residual stresses on the point contact's axis; the safe state's von Mises envelope."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4.2), layout="constrained")
    left, right = fig.subplots(1, 2)
    full = None
    for row, bound in zip(rows, results, strict=True):
        if row["contact"] != "point":
            continue
        x3 = bound.x3
        centre = bound.residual.shape[0] // 2
        for comp, name in ((0, "ρ11"), (1, "ρ22"), (2, "ρ33")):
            if row["residual_class"] == "depth" and comp == 2:
                continue
            left.plot(x3, SQRT3 * bound.load_factor * bound.residual[centre, :, comp],
                      label=f"{name}, {row['residual_class']} "
                      f"({row['lower_p0_over_k']:.3f} k certified)")
        if row["residual_class"] == "full":
            full = (row, bound)
    left.set(xlabel="depth x3 / a", ylabel="residual stress / k, on the axis x2 = 0",
             title="Safe residual stress at the bound")
    left.legend(fontsize=8)
    if full is not None:
        row, bound = full
        mesh = right.pcolormesh(bound.x2, bound.x3, bound.envelope.T, shading="nearest",
                                vmin=0, vmax=1)
        right.contour(bound.x2, bound.x3, bound.envelope.T, levels=[0.99], colors="w",
                      linewidths=0.8)
        right.invert_yaxis()
        fig.colorbar(mesh, ax=right, label="max over load positions of σ_vM / σ_Y")
        right.set(xlabel="x2 / a (across the track)", ylabel="depth x3 / a",
                  title=f"At the samples, p0 = {row['melan_at_samples_p0_over_k']:.2f} k "
                  "(white: within 1 % of yield)")
    fig.savefig(path, dpi=120, format="png")


if __name__ == "__main__":
    raise SystemExit(main())
