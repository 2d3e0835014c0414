"""The shipped configs against limits with the grid, the increments and the window refined.

Issue #32 asks every quantity of the convergence study within half a percent of its own
converged limit at the shipped configs' grids. The study's `together` limits are limits at the
configs' windows; the `window` sequences measure the window's own error at one grid. This
script combines them (:mod:`sacflow.studies.certify`: f* = L_T + (L_W − f_W)) and compares the
shipped discretisation, run with ``solver.traction_beyond_box = true`` as the configs ship it,
with that limit. It runs nothing: every number comes from the study's tables under ``data/``
(:data:`SOURCES`, written by ``pipelines/convergence.py``; their commands are in
``data/README.md``).

    python pipelines/convergence_certify.py --table data/convergence-certified.csv \
        [--plot certified.png]
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

from sacflow.errors import SacflowError
from sacflow.studies.certify import (
    CERTIFIED_COLUMNS,
    Certificate,
    certify,
    level_values,
    plot_certificates,
    transfer,
)
from sacflow.studies.convergence_table import read_summary, write_csv, write_figure

DATA = Path(__file__).resolve().parents[1] / "data"


@dataclass(frozen=True)
class Sources:
    """The tables of ``data/`` one case is certified from.

    ``together`` is the summary with the case's `together` sequence (its limit at the shipped
    window, the traction beyond the box left out, and the shipped value so); ``window`` and
    ``window_far`` the window sequence's levels tables without and with the traction beyond the
    box (and ``window``'s summary, the same name with ``-summary``); ``shipped_far`` the
    summary whose ``shipped_value`` is the shipped discretisation with it.
    """

    together: str
    window: str
    window_far: str
    shipped_far: str

    def window_summary(self) -> str:
        """The window levels table's summary."""
        return self.window.replace(".csv", "-summary.csv")


#: Case -> its tables. The 650 mN case's window sequence runs at its shipped grid, the 190 mN
#: and linear-hardening cases' at the study's base grid (64² × 24 cells, 10 + 5 increments),
#: the press's at 48² × 64 cells with 20 + 6 increments. The press's `together` is the one with
#: its contact on sub-cells whose pressure loads the body, as it ships, to a fourth level and
#: extrapolated through the finest three; its window sequence ran
#: on the cells, and the transfer (:func:`sacflow.studies.certify.transfer`) carries what that
#: changes.
SOURCES = {
    "nanoindentation-650mN": Sources(
        "convergence-650-steps6-summary.csv", "convergence-window-650.csv",
        "convergence-window-650-far.csv", "convergence-window-650-far-summary.csv"),
    "nanoindentation-190mN": Sources(
        "convergence-190-steps6-summary.csv", "convergence-window-base.csv",
        "convergence-window-base-far.csv", "convergence-window-base-far-summary.csv"),
    "nanoindentation-linear-650mN": Sources(
        "convergence-shipped-summary.csv", "convergence-window-base.csv",
        "convergence-window-base-far.csv", "convergence-window-base-far-summary.csv"),
    "dent-from-indentation-press": Sources(
        "convergence-press-subcell-stress4-summary.csv", "convergence-press-window.csv",
        "convergence-press-window-far.csv",
        "convergence-press-shipped-subcell-stress-far-summary.csv"),
}
#: The quantities certified: the issue's (the approach at the peak load, the print depth, the
#: largest εp and its depth, the minimum residual σ11 on the axis and its profile, the peak
#: pressure), each read as the study reads it at the shipped grids (refined between layer
#: centres and interpolated to the axis).
QUANTITIES = (
    "approach_at_peak_load", "print_depth_refined", "max_plastic_strain_refined",
    "max_plastic_strain_refined_depth", "residual_s11_axis_min_refined",
    "residual_s11_axis_refined_at_0.25a", "residual_s11_axis_refined_at_0.5a",
    "residual_s11_axis_refined_at_1a", "residual_s11_axis_refined_at_1.5a",
    "residual_s11_axis_refined_at_2a", "peak_pressure",
)


#: The profile whose points are judged against its largest magnitude (the scale of
#: :func:`sacflow.studies.certify.certify`), and the quantity that is that magnitude.
PROFILE, PROFILE_SCALE = "residual_s11_axis_refined_at_", "residual_s11_axis_min_refined"


def certificates(case: str, sources: Sources, data: Path = DATA) -> list[Certificate]:
    """Each quantity of :data:`QUANTITIES` that every table of ``case`` has, certified.

    The points of the σ11 profile on the axis are judged against the profile's largest
    magnitude, the certified limit of its minimum (:data:`PROFILE_SCALE`, first in
    :data:`QUANTITIES` order before them).
    """
    together = read_summary(data / sources.together)
    window = read_summary(data / sources.window_summary())
    shipped_far = read_summary(data / sources.shipped_far)
    first_off = level_values(data / sources.window, case, "window", 0)
    first_on = level_values(data / sources.window_far, case, "window", 0)
    out: list[Certificate] = []
    scale: float | None = None
    for name in QUANTITIES:
        rows = (together.get((case, "together", name)), window.get((case, "window", name)),
                shipped_far.get((case, "window", name)))
        if any(r is None for r in rows) or name not in first_off or name not in first_on:
            continue
        fit, win, far = rows
        assert fit is not None and win is not None and far is not None
        if not math.isfinite(far["shipped_value"]) or not math.isfinite(fit["shipped_value"]):
            continue
        moved = transfer(far["shipped_value"], fit["shipped_value"], first_on[name],
                         first_off[name])
        certificate = certify(fit, win, first_off[name], far["shipped_value"], moved,
                              scale if name.startswith(PROFILE) else None)
        if name == PROFILE_SCALE:
            scale = certificate.limit
        out.append(certificate)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", type=Path, help="write the certificates here (CSV)")
    parser.add_argument("--plot", type=Path, help="write the errors' plot here (PNG)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing table or plot")
    args = parser.parse_args(argv)
    try:
        found = [c for case, s in SOURCES.items() for c in certificates(case, s)]
        if args.table is not None:
            write_csv(args.table, [c.row() for c in found], CERTIFIED_COLUMNS, args.overwrite)
        if args.plot is not None:
            write_figure(plot_certificates(found), args.plot, args.overwrite)
            print(f"plot: {args.plot}")
    except SacflowError as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    print(f"{'case':28s} {'quantity':34s} {'limit':>12s} {'U/s':>7s} {'error/s':>8s} "
          f"{'error/|f*|':>10s} verdict")
    for c in found:
        print(f"{c.case:28s} {c.quantity:34s} {c.limit:12.5g} "
              f"{100 * c.relative_uncertainty:6.3f}% {100 * c.error:+7.3f}% "
              f"{100 * c.value_error:+9.3f}% {c.verdict} ({c.together_kind})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
