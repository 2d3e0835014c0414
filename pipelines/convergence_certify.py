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
from typing import Any

from sacflow.errors import SacflowError
from sacflow.studies.certify import (
    CERTIFIED_COLUMNS,
    DEPTH_TOLERANCE,
    Certificate,
    Level,
    certify,
    level_discretisation,
    level_values,
    plot_certificates,
    sequence_levels,
    transfer,
)
from sacflow.studies.convergence import STUDY_CASES, base_case, shipped_discretisation
from sacflow.studies.convergence_table import (
    finest_step,
    read_summary,
    refuse_existing_table,
    write_csv,
    write_figure,
)
from sacflow.studies.error_parts import ModelCheck, Part, PartsLimit, parts_limit
from sacflow.studies.richardson import MONOTONE

DATA = Path(__file__).resolve().parents[1] / "data"


@dataclass(frozen=True)
class Sources:
    """The tables of ``data/`` one case is certified from.

    ``together`` is the summary with the case's `together` sequence (its limit at the shipped
    window, the traction beyond the box left out, and the shipped value so); ``window`` and
    ``window_far`` the window sequence's levels tables without and with the traction beyond the
    box (and ``window``'s summary, the same name with ``-summary``); ``shipped_far`` the
    summary whose ``shipped_value`` is the shipped discretisation with it.
    ``shipped_off``, when given, is the levels table, sequence and level that ran the shipped
    discretisation without the traction beyond the box, for a config whose discretisation
    changed after its `together` summary recorded its ``shipped_value``; that level must then
    be the config's grid and increments (:func:`shipped_off_values`). ``parts``, when given,
    is the levels table of the lateral, layers and increments sequences refined one at a time
    from the study's base (its summary the same name with ``-summary``): the limit they add
    up to (:mod:`sacflow.studies.error_parts`) stands in where the `together` sequence has
    none. ``parts_lateral``, when given, is a levels table of the lateral cells refined further
    from the base's layers and increments: the lateral part is extrapolated through its levels
    instead of the ``parts`` table's lateral sequence (:func:`lateral_part_rows`).
    """

    together: str
    window: str
    window_far: str
    shipped_far: str
    shipped_off: tuple[str, str, int] | None = None
    parts: str | None = None
    parts_lateral: str | None = None

    def window_summary(self) -> str:
        """The window levels table's summary."""
        return self.window.replace(".csv", "-summary.csv")


#: Case -> its tables. The three nano-indentations' one-at-a-time sequences run from the
#: study's base grid to h = 1/6, extrapolated through their finest three levels as their
#: `together` sequences; their lateral part is the lateral cells refined further, 128², 160² and
#: 200² cells at the base's layers and increments: a constant ratio, each count putting the
#: Hertz contact's edge on a cell boundary (docs/convergence.md, "The lateral cells refined
#: further"). The 650 mN case's window sequence runs at its shipped grid, the 190 mN
#: and linear-hardening cases' at the study's base grid (64² × 24 cells, 10 + 5 increments),
#: the press's at 48² × 64 cells with 20 + 6 increments. The press's `together` is the one with
#: its contact on sub-cells whose pressure loads the body, as it ships, to a fourth level and
#: extrapolated through the finest three; its window sequence ran
#: on the cells, and the transfer (:func:`sacflow.studies.certify.transfer`) carries what that
#: changes. The press ships 40 + 12 increments since its `together` summary recorded its
#: shipped value with 20 + 6: its shipped value without the traction beyond the box is the
#: increments sequence's level at 40 + 12 on its shipped grid (the same discretisation), and its
#: shipped value with that traction a run of the config as it ships.
SOURCES = {
    "nanoindentation-650mN": Sources(
        "convergence-650-steps6-summary.csv", "convergence-window-650.csv",
        "convergence-window-650-far.csv", "convergence-window-650-far-summary.csv",
        parts="convergence-parts-steps6.csv", parts_lateral="convergence-parts-lateral-fine.csv"),
    "nanoindentation-190mN": Sources(
        "convergence-190-steps6-summary.csv", "convergence-window-base.csv",
        "convergence-window-base-far.csv", "convergence-window-base-far-summary.csv",
        parts="convergence-parts-steps6.csv", parts_lateral="convergence-parts-lateral-fine.csv"),
    "nanoindentation-linear-650mN": Sources(
        "convergence-shipped-summary.csv", "convergence-window-base.csv",
        "convergence-window-base-far.csv", "convergence-window-base-far-summary.csv",
        parts="convergence-parts-steps6.csv", parts_lateral="convergence-parts-lateral-fine.csv"),
    "dent-from-indentation-press": Sources(
        "convergence-press-subcell-stress4-summary.csv", "convergence-press-window.csv",
        "convergence-press-window-far.csv",
        "convergence-press-shipped-increments40-far-summary.csv",
        ("convergence-press-subcell-stress-increments.csv", "increments", 2)),
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


def shipped_off_values(case: str, source: tuple[str, str, int],
                       data: Path = DATA) -> dict[str, float]:
    """Return the quantities of the level ``source`` names, checked to be ``case`` as it ships.

    Raises
    ------
    SacflowError
        When the level's cells, layers, box depth or increments are not those of the case's
        config (the config changed again after that level ran).
    """
    table, sequence, level = source
    path = data / table
    shipped = shipped_discretisation(base_case(STUDY_CASES[case]))
    ran = level_discretisation(path, case, sequence, level)
    wanted = (shipped.nx, shipped.nz, shipped.total_increments)
    if ran[:3] != wanted or not math.isclose(ran[3], shipped.depth, rel_tol=DEPTH_TOLERANCE):
        raise SacflowError(
            f"{path.name}: {case}'s {sequence} level {level} ran {ran[0]}² × {ran[1]} cells "
            f"with {ran[2]} increments over {ran[3]:.6g} m, but its config ships "
            f"{wanted[0]}² × {wanted[1]} cells with {wanted[2]} increments over "
            f"{shipped.depth:.6g} m: run the shipped config without the traction beyond the box "
            f"and name that level in SOURCES")
    return level_values(path, case, sequence, level)


@dataclass(frozen=True)
class OptionChange:
    """One quantity's values with and without the traction beyond the box, at the shipped grid
    (``shipped_on``, ``shipped_off``) and at the window sequence's first level (``first_on``,
    ``first_off``): :func:`sacflow.studies.certify.transfer` of the four is the transfer."""

    shipped_on: float
    shipped_off: float
    first_on: float
    first_off: float

    @property
    def at_shipped(self) -> float:
        """d_s, the change removing the traction beyond the box makes at the shipped grid."""
        return self.shipped_on - self.shipped_off

    @property
    def at_window(self) -> float:
        """d_w, the change it makes at the window sequence's first level."""
        return self.first_on - self.first_off


def option_changes(case: str, sources: Sources, data: Path = DATA) -> dict[str, OptionChange]:
    """Each quantity of :data:`QUANTITIES` with finite values in every table: its
    :class:`OptionChange`."""
    together = read_summary(data / sources.together)
    shipped_far = read_summary(data / sources.shipped_far)
    first_off = level_values(data / sources.window, case, "window", 0)
    first_on = level_values(data / sources.window_far, case, "window", 0)
    shipped_off = (None if sources.shipped_off is None
                   else shipped_off_values(case, sources.shipped_off, data))
    out: dict[str, OptionChange] = {}
    for name in QUANTITIES:
        fit, far = together.get((case, "together", name)), shipped_far.get((case, "window", name))
        if fit is None or far is None or name not in first_off or name not in first_on:
            continue
        off = fit["shipped_value"] if shipped_off is None else shipped_off.get(name, math.nan)
        if math.isfinite(far["shipped_value"]) and math.isfinite(off):
            out[name] = OptionChange(far["shipped_value"], off, first_on[name], first_off[name])
    return out


#: The parameter each one-at-a-time sequence refines: its column of the levels table.
PART_PARAMETERS = {"lateral": "nx", "layers": "nz", "increments": "increments"}
#: One row per case and quantity of ``--parts-table``: the base's value, each part's limit and
#: share of the base's error, the limit they give with its two uncertainties, the largest
#: misfit and the level it was found at, and the `together` sequence's own behaviour and limit.
PARTS_COLUMNS: tuple[str, ...] = (
    "case", "quantity", "unit", "base_value", "lateral_limit", "layers_limit",
    "increments_limit", "lateral_share", "layers_share", "increments_share", "limit",
    "parts_uncertainty", "misfit", "misfit_level", "uncertainty", "together_behaviour",
    "together_limit", "together_uncertainty",
)


@dataclass(frozen=True)
class PartsFound:
    """One quantity's limit from the parts, with the `together` row it stands in for."""

    case: str
    quantity: str
    unit: str
    base_value: float
    parts: dict[str, Part]
    found: PartsLimit
    misfit_level: str
    together: dict[str, object]

    def row(self) -> dict[str, object]:
        """The row of :data:`PARTS_COLUMNS`."""
        return {
            "case": self.case, "quantity": self.quantity, "unit": self.unit,
            "base_value": self.base_value,
            **{f"{k}_limit": p.limit for k, p in self.parts.items()},
            **{f"{k}_share": e for k, e in self.found.base_errors.items()},
            "limit": self.found.limit, "parts_uncertainty": self.found.parts_uncertainty,
            "misfit": self.found.misfit, "misfit_level": self.misfit_level,
            "uncertainty": self.found.uncertainty,
            "together_behaviour": self.together["behaviour"],
            "together_limit": self.together["limit"],
            "together_uncertainty": self.together["uncertainty"],
        }


#: Relative slack of a finer lateral table's steps against the parts table's (both h = n₀/nx).
STEP_SLACK = 1e-9


def lateral_part_rows(case: str, table: Path, base: Level,
                      coarsest_cells: int) -> dict[tuple[str, str, str], dict[str, Any]]:
    """Return the summary rows of ``case``'s lateral sequence in ``table``, checked to refine
    the lateral cells alone from ``base``.

    Each level must run the base's layers and increments on more cells than the base, and the
    summary's steps must be relative to the parts table's coarsest lateral level
    (``coarsest_cells``), so that the part's error C h^p is read on the same scale of h.

    Raises
    ------
    SacflowError
        When a level refines anything but the lateral cells, is not finer than the base, or the
        steps are on another scale.
    """
    levels = sequence_levels(table, case, "lateral")
    for nx, nz, increments in levels:
        if (nz, increments) != base[1:] or nx <= base[0]:
            raise SacflowError(
                f"{table}: {case}'s lateral level {nx}² × {nz}, {increments} increments does "
                f"not refine the lateral cells alone from the base {base[0]}² × {base[1]}, "
                f"{base[2]} increments: run it with the base's layers and increments")
    summary = read_summary(table.with_name(table.stem + "-summary.csv"))
    rows = {k: r for k, r in summary.items() if k[0] == case and k[1] == "lateral"}
    expected = coarsest_cells / max(nx for nx, _, _ in levels)
    for (_, _, name), r in rows.items():
        if abs(finest_step(r) / expected - 1.0) > STEP_SLACK:
            raise SacflowError(
                f"{table}: {case}'s {name} has its finest step {finest_step(r):.6g}, not "
                f"{expected:.6g} = {coarsest_cells}/{max(nx for nx, _, _ in levels)}: run it "
                f"with --steps relative to {coarsest_cells} cells, as the parts table")
    return rows


def parts_limits(case: str, sources: Sources, data: Path = DATA) -> dict[str, PartsFound]:
    """Each quantity's limit from the one-at-a-time sequences of ``sources.parts`` (if any).

    The base is the level every part shares. The model is checked on the `together` levels
    finer than the base and off every one-at-a-time line (they differ from the base in two
    parameters or more), and on the shipped discretisation (the traction beyond the box left
    out), when it is off the lines too.
    """
    if sources.parts is None:
        return {}
    table = data / sources.parts
    summary = read_summary(table.with_name(table.stem + "-summary.csv"))
    levels = {seq: sequence_levels(table, case, seq) for seq in PART_PARAMETERS}
    shared = set.intersection(*(set(v) for v in levels.values()))
    if len(shared) != 1:
        raise SacflowError(f"{table}: {case}'s one-at-a-time sequences share {len(shared)} "
                           f"levels, not one base: run them from one base grid")
    base = shared.pop()
    index = dict(zip(PART_PARAMETERS, range(3), strict=True))
    coarsest = {seq: min(lv[index[seq]] for lv in levels[seq]) for seq in PART_PARAMETERS}
    lateral = summary if sources.parts_lateral is None else lateral_part_rows(
        case, data / sources.parts_lateral, base, coarsest["lateral"])

    def steps(level: Level) -> dict[str, float]:
        """Each parameter's step h, relative to its sequence's coarsest level as the study's."""
        return {seq: coarsest[seq] / level[index[seq]] for seq in PART_PARAMETERS}

    def off_the_lines(level: Level) -> bool:
        finer = all(a >= b for a, b in zip(level, base, strict=True))
        return finer and sum(a != b for a, b in zip(level, base, strict=True)) >= 2

    together_table = data / sources.together.replace("-summary.csv", ".csv")
    candidates = {f"together {lv[0]}² × {lv[1]}, {lv[2]} increments": (lv, values)
                  for lv, values in sequence_levels(together_table, case, "together").items()
                  if off_the_lines(lv)}
    together = read_summary(data / sources.together)
    shipped = shipped_discretisation(base_case(STUDY_CASES[case]))
    shipped_level = (shipped.nx, shipped.nz, shipped.total_increments)
    out: dict[str, PartsFound] = {}
    for name in QUANTITIES:
        rows = {seq: (lateral if seq == "lateral" else summary).get((case, seq, name))
                for seq in PART_PARAMETERS}
        fit = together.get((case, "together", name))
        if fit is None or any(r is None for r in rows.values()) or name not in levels[
                "lateral"][base]:
            continue
        parts = {seq: Part(str(r["behaviour"]), r["limit"], r["uncertainty"], r["order"],
                           r["finest_value"], finest_step(r))
                 for seq, r in rows.items() if r is not None}
        checks = {label: ModelCheck(steps(lv), values[name])
                  for label, (lv, values) in candidates.items() if name in values}
        if sources.shipped_off is None and off_the_lines(shipped_level) and math.isfinite(
                fit["shipped_value"]):
            checks["shipped"] = ModelCheck(steps(shipped_level), fit["shipped_value"])
        found = parts_limit(levels["lateral"][base][name], parts, list(checks.values()))
        if found is None:
            continue
        worst = max(zip(found.discrepancies, checks, strict=True), key=lambda d: abs(d[0]),
                    default=(0.0, ""))
        out[name] = PartsFound(case, name, str(fit["unit"]), levels["lateral"][base][name],
                               parts, found, worst[1], fit)
    return out


def certificates(case: str, sources: Sources, data: Path = DATA,
                 from_parts: dict[str, PartsFound] | None = None) -> list[Certificate]:
    """Each quantity of :data:`QUANTITIES` that every table of ``case`` has, certified.

    The points of the σ11 profile on the axis are judged against the profile's largest
    magnitude, the certified limit of its minimum (:data:`PROFILE_SCALE`, first in
    :data:`QUANTITIES` order before them). Where the `together` sequence has no limit, the
    parts' (:func:`parts_limits`, or ``from_parts`` when the caller has them) stands in when
    they give one.
    """
    together = read_summary(data / sources.together)
    window = read_summary(data / sources.window_summary())
    changes = option_changes(case, sources, data)
    if from_parts is None:
        from_parts = parts_limits(case, sources, data)
    out: list[Certificate] = []
    scale: float | None = None
    for name in QUANTITIES:
        fit, win = together.get((case, "together", name)), window.get((case, "window", name))
        change = changes.get(name)
        if fit is None or win is None or change is None:
            continue
        moved = transfer(change.shipped_on, change.shipped_off, change.first_on,
                         change.first_off)
        parts = from_parts.get(name)
        certificate = certify(fit, win, change.first_off, change.shipped_on, moved,
                              scale if name.startswith(PROFILE) else None,
                              parts=None if parts is None else parts.found)
        if name == PROFILE_SCALE:
            scale = certificate.limit
        out.append(certificate)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table", type=Path, help="write the certificates here (CSV)")
    parser.add_argument("--plot", type=Path, help="write the errors' plot here (PNG)")
    parser.add_argument("--parts-table", type=Path,
                        help="write the limits the one-at-a-time sequences give here (CSV)")
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an existing table or plot")
    args = parser.parse_args(argv)
    try:  # every output checked first: none is written when one is refused
        for path in (args.table, args.plot, args.parts_table):
            refuse_existing_table(path, args.overwrite)
    except SystemExit as refused:
        print(refused, file=sys.stderr)
        return 1
    try:
        by_case = {case: parts_limits(case, s) for case, s in SOURCES.items()}
        found = [c for case, s in SOURCES.items() for c in certificates(case, s, DATA,
                                                                        by_case[case])]
        from_parts = [p for parts in by_case.values() for p in parts.values()]
        if args.parts_table is not None:
            write_csv(args.parts_table, [p.row() for p in from_parts], PARTS_COLUMNS,
                      args.overwrite)
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
    print_parts(from_parts)
    return 0


def print_parts(found: list[PartsFound]) -> None:
    """Print each limit from the parts beside the `together` sequence's own."""
    print(f"\n{'case':28s} {'quantity':34s} {'parts limit':>12s} {'U/|f*|':>7s} "
          f"{'misfit':>7s} {'together':>12s} {'U/|f*|':>7s}")
    for p in found:
        limit = p.found.limit
        own = float(str(p.together["limit"]))
        own_u = (f"{100 * float(str(p.together['uncertainty'])) / abs(own):6.3f}%"
                 if p.together["behaviour"] == MONOTONE else f"{p.together['behaviour']:>7s}")
        print(f"{p.case:28s} {p.quantity:34s} {limit:12.6g} "
              f"{100 * p.found.uncertainty / abs(limit):6.3f}% "
              f"{100 * p.found.misfit / abs(limit):6.3f}% {own:12.6g} {own_u}")


if __name__ == "__main__":
    sys.exit(main())
