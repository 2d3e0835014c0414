"""Convergence study of the indentation cases: observed orders and Richardson limits (issue #32).

    python pipelines/convergence.py [--cases NAME,...] [--sequences NAME,...] [--levels N]
        [--cache DIR] [--table CSV] [--summary CSV] [--plots DIR] [--overwrite]
        [--set KEY=VALUE ...] [--quick] [--all] [--plan] [--steps H,H,H...]
        [--check STEP [--against CSV] [--check-table CSV]] [--advise [--target E]]

For each case (:data:`sacflow.studies.convergence.STUDY_CASES`) and each refinement sequence
(:data:`sacflow.studies.convergence.SEQUENCES`: lateral cells, layers, box depth, lateral
window at the same cells, increments, all together), runs the levels in this process with
whatever ``sacflow`` is importable, reads
the quantities of each finished run (approach, print depth, largest εp and its depth, residual
σ11 on the axis, residual σ33 / hydrostatic stress of the top layers, peak pressure), and
writes

* the tidy table of every level (``--table``, default ``data/convergence.csv``),
* the summary: observed order, Richardson limit, its uncertainty (GCI, F_s = 1.25) and the
  relative error of the shipped discretisation (``--summary``, default
  ``data/convergence-summary.csv``),
* with ``--plots DIR``, the relative error against h (log-log) of each case and sequence, and
  the residual σ11 axis profile of its levels.

The levels of each sequence lie around the study's base discretisation
(:func:`sacflow.studies.convergence.study_base`): the shipped one, with 10 + 5 increments for
the nano-indentations (which ship 20 + 10, the middle level of ``increments`` and ``together``).
The shipped error is always that of the shipped discretisation, run as a level of its own when
it is not one of the sequence's.

``--steps`` (e.g. ``1/2,1/3,1/4,1/5``, h relative to the coarsest level, decreasing) runs each
sequence at those steps instead of its constant ratio, and extrapolates through the three
finest with the order of unequal ratios (:func:`sacflow.studies.richardson.extrapolate_steps`):
a finer last level where doubling every parameter again would be too costly.

``--plan`` lists the levels of each sequence, and which are already cached, and runs nothing.

``--check STEP`` (e.g. ``1/3``: h relative to the coarsest level) runs the level of each
sequence at that step, one the sequences do not run, and compares each quantity with what a
finished study's model f∞ + C hᵖ predicts there (``--against``, its summary table; default
``--summary``): a test of the extrapolation on a level it was not fitted to, written to
``--check-table`` (default ``data/convergence-check.csv``). ``--advise`` prints, from that
summary and running nothing, the step at which the model puts each quantity within ``--target``
(default 0.005, half a percent) of its limit, and the discretisation that step means.

Each run's results are cached as one JSON file in ``--cache`` (default ``runs/convergence``),
named by the case, the level and a hash of the case file, the overrides and the solver's source
(:func:`sacflow.studies.convergence.source_fingerprint`): an interrupted study resumes, a subset
rerun recomputes nothing else, and a changed solver runs again. The tables are written
atomically and never over an existing file unless ``--overwrite``.

``--quick`` runs tiny grids (8 layers, 8 surface cells per Hertz radius, 2 + 1 increments at
the shipped level: 32 × 32 × 8 cells at 650 mN; seconds per case) into
``runs/convergence-quick``; its tables go there too unless given. ``--set`` overrides apply to
every case (e.g. ``--set solver.fft_threads=1``). See docs/convergence.md.
"""

from __future__ import annotations

import argparse
import fractions
import hashlib
import json
import math
import os
import sys
import tempfile
import time
from collections.abc import Sequence
from itertools import pairwise
from pathlib import Path
from typing import Any

from sacflow.config.solver_inputs import simulation_for
from sacflow.errors import SacflowError
from sacflow.solver.history import scalars_only
from sacflow.studies.convergence import (
    SEQUENCES,
    STUDY_CASES,
    Discretisation,
    Refinement,
    StudyCase,
    base_case,
    case_overrides,
    measure,
    sequences_for,
    shipped_discretisation,
    source_fingerprint,
    study_base,
)
from sacflow.studies.convergence_table import (
    CHECK_COLUMNS,
    LEVEL_COLUMNS,
    SUMMARY_COLUMNS,
    TARGET_ERROR,
    SequenceResult,
    advised_step,
    check_rows,
    count_at_step,
    level_rows,
    plot_errors,
    plot_profiles,
    read_summary,
    summary_rows,
    write_csv,
)

ROOT = Path(__file__).resolve().parent.parent
#: Quantities whose limit vanishes at the traction-free surface (the top layers' residual σ33,
#: shear and hydrostatic stress): a relative error means nothing for them.
NEAR_ZERO_QUANTITIES = ("residual_s33_layer", "residual_shear_layer", "hydrostatic_layer")
#: ``--advise`` names no discretisation finer than this step (50 × the coarsest level's cells
#: along each refined axis): the model's extrapolation that far is no advice.
SMALLEST_ADVISED_STEP = 0.02
#: The shipped level of ``--quick``: few layers and increments (two-segment load paths), and
#: :data:`QUICK_CELLS_PER_RADIUS` surface cells per Hertz radius of the window (its coarsest
#: lateral level keeps the 8 cells across the contact diameter a case needs).
QUICK = ("grid.nz=8", "load_path.0.increments=2", "load_path.1.increments=1")
QUICK_CELLS_PER_RADIUS = 8
#: Quantities printed in the summary (all are in the tables; ``--all`` prints every one).
PRINTED = ("approach_at_peak_load", "print_depth", "print_depth_refined", "max_plastic_strain",
           "max_plastic_strain_refined", "max_plastic_strain_refined_depth",
           "residual_s11_axis_min", "residual_s11_axis_min_refined",
           "residual_s11_axis_refined_at_1a", "peak_pressure", "residual_s33_layer1_axis",
           "residual_s33_layer1_extreme", "hydrostatic_layer1_extreme")
#: Quantities of the error plots.
PLOTTED = ("approach_at_peak_load", "print_depth_refined", "max_plastic_strain_refined",
           "residual_s11_axis_min_refined", "peak_pressure")


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    try:
        return study(args)
    except SacflowError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


def parse(argv: list[str] | None) -> argparse.Namespace:
    """Parse the command line (defaults of the tables and cache depend on ``--quick``)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", default=",".join(STUDY_CASES),
                        help=f"comma-separated, of {', '.join(STUDY_CASES)}")
    parser.add_argument("--sequences", default=",".join(SEQUENCES),
                        help=f"comma-separated, of {', '.join(SEQUENCES)}")
    parser.add_argument("--levels", type=int, default=3, help="levels per sequence (>= 3)")
    parser.add_argument("--steps", type=step_list, metavar="H,H,H...",
                        help="run the sequences at these steps (e.g. 1/2,1/3,1/4,1/5) instead "
                             "of --levels")
    parser.add_argument("--cache", type=Path)
    parser.add_argument("--table", type=Path)
    parser.add_argument("--summary", type=Path)
    parser.add_argument("--plots", type=Path, help="folder of the error plots (PNG)")
    parser.add_argument("--overwrite", action="store_true", help="replace existing tables")
    parser.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="KEY=VALUE")
    parser.add_argument("--quick", action="store_true", help="tiny grids, for a check")
    parser.add_argument("--all", action="store_true", help="print every quantity")
    parser.add_argument("--plan", action="store_true",
                        help="list the levels (and which are cached), run nothing")
    parser.add_argument("--check", type=step_fraction, metavar="STEP",
                        help="run the level at step STEP (e.g. 1/3) and compare with --against")
    parser.add_argument("--against", type=Path,
                        help="summary table of the study to check or advise from")
    parser.add_argument("--check-table", type=Path)
    parser.add_argument("--advise", action="store_true",
                        help="print the step each quantity needs for --target, run nothing")
    parser.add_argument("--target", type=float, default=TARGET_ERROR,
                        help="relative error of --advise (default %(default)g)")
    args = parser.parse_args(argv)
    if not 0.0 < args.target < 1.0:
        parser.error(f"--target must lie between 0 and 1 (a relative error), got {args.target}")
    args.cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    args.sequences = [s.strip() for s in args.sequences.split(",") if s.strip()]
    for name, known in (("case", STUDY_CASES), ("sequence", SEQUENCES)):
        unknown = [n for n in getattr(args, f"{name}s") if n not in known]
        if unknown:
            parser.error(f"unknown {name} {unknown}: choose among {list(known)}")
    if args.levels < 3:
        parser.error("--levels must be 3 or more (an order needs three levels)")
    out = ROOT / "runs" / ("convergence-quick" if args.quick else "convergence")
    args.cache = args.cache or out
    data = out if args.quick else ROOT / "data"
    args.table = args.table or data / "convergence.csv"
    args.summary = args.summary or data / "convergence-summary.csv"
    args.against = args.against or args.summary
    args.check_table = args.check_table or data / "convergence-check.csv"
    return args


def step_fraction(text: str) -> float:
    """Parse ``--check``'s step: a fraction (``1/3``) or a decimal in (0, 1]."""
    try:
        step = float(fractions.Fraction(text.strip()))
    except (ValueError, ZeroDivisionError):
        raise argparse.ArgumentTypeError(f"not a step: {text!r} (give e.g. 1/3 or 0.5)") from None
    if not 0.0 < step <= 1.0:
        raise argparse.ArgumentTypeError(f"the step is h relative to the coarsest level, in "
                                         f"(0, 1]: got {text!r}")
    return step


def step_list(text: str) -> tuple[float, ...]:
    """Parse ``--steps``: three or more decreasing steps (:func:`step_fraction` each)."""
    steps = tuple(step_fraction(part) for part in text.split(",") if part.strip())
    if len(steps) < 3 or not all(a > b for a, b in pairwise(steps)):
        raise argparse.ArgumentTypeError(f"give three or more decreasing steps (coarse to "
                                         f"fine, e.g. 1/2,1/3,1/4): got {text!r}")
    return steps


def study(args: argparse.Namespace) -> int:
    """Run (or read from the cache) every level, then write the tables and plots."""
    if args.advise:
        return advise(args)
    if args.check is not None:
        return check(args)
    for path in (args.table, args.summary):
        if path.exists() and not (args.overwrite or args.plan):
            raise SacflowError(f"{path} exists: give --overwrite to replace it, or another path")
    fingerprint = source_fingerprint()
    results: list[SequenceResult] = []
    for name in args.cases:
        base, shipped_level, sequences, overrides = case_setup(args, name)
        runner = LevelRunner(STUDY_CASES[name], overrides, args.cache, fingerprint)
        plan = {seq: ([sequences[seq].at_step(base, h) for h in args.steps] if args.steps
                      else sequences[seq].levels(base, args.levels))
                for seq in args.sequences}
        if args.plan:
            print_plan(runner, base, shipped_level, plan)
            continue
        shipped = runner.record(shipped_level)
        for seq_name, levels in plan.items():
            records = [runner.record(level) for level in levels]
            results.append(SequenceResult(
                name, sequences[seq_name], levels,
                [None if r is None else r["quantities"] for r in records],
                None if shipped is None else shipped["quantities"],
                [None if r is None else r["converged"] for r in records],
                [None if r is None else r["profile"] for r in records], args.steps or ()))
    if args.plan:
        return 0
    levels_table = [row for r in results for row in level_rows(r)]
    summary = [row for r in results for row in summary_rows(r)]
    write_csv(args.table, levels_table, LEVEL_COLUMNS, args.overwrite)
    write_csv(args.summary, summary, SUMMARY_COLUMNS, args.overwrite)
    print_summary(summary, None if args.all else PRINTED)
    print(f"tables: {args.table}, {args.summary}")
    if args.plots is not None:
        write_plots(results, args.plots)
    return 0


def case_setup(args: argparse.Namespace, name: str
               ) -> tuple[Discretisation, Discretisation, dict[str, Refinement], list[str]]:
    """The study's base and shipped discretisations, the sequences and the overrides of ``name``."""
    study_case = STUDY_CASES[name]
    overrides = [*(quick_overrides(study_case) if args.quick else ()), *args.overrides]
    case = base_case(study_case, overrides)
    shipped = shipped_discretisation(case)
    return study_base(study_case, shipped, overrides), shipped, sequences_for(case), overrides


def check(args: argparse.Namespace) -> int:
    """Run the level at ``--check``'s step of each case and sequence; compare with the model."""
    if args.check_table.exists() and not (args.overwrite or args.plan):
        raise SacflowError(f"{args.check_table} exists: give --overwrite to replace it, or "
                           f"another --check-table")
    summary = read_summary(args.against)
    fingerprint = source_fingerprint()
    rows: list[dict[str, Any]] = []
    for name in args.cases:
        base, shipped, sequences, overrides = case_setup(args, name)
        runner = LevelRunner(STUDY_CASES[name], overrides, args.cache, fingerprint)
        if args.plan:  # the check's levels, cached or to run; nothing runs
            print_plan(runner, base, shipped, {seq_name: [sequences[seq_name].at_step(
                base, args.check)] for seq_name in args.sequences})
            continue
        for seq_name in args.sequences:
            level = sequences[seq_name].at_step(base, args.check)
            record = runner.record(level)
            if record is not None:
                rows.extend(check_rows(name, seq_name, args.check, level, record, summary))
    if args.plan:
        return 0
    if not rows:
        raise SacflowError(f"nothing to compare: {args.against} has no monotone sequence of "
                           f"these cases and sequences, or every run failed")
    write_csv(args.check_table, rows, CHECK_COLUMNS, args.overwrite)
    print(f"{'case':30s} {'sequence':10s} {'quantity':34s} {'value':>12s} {'predicted':>12s} "
          f"{'error':>8s} {'predicted':>9s}")
    for row in rows:
        if args.all or row["quantity"] in PRINTED:
            print(f"{row['case']:30s} {row['sequence']:10s} {row['quantity']:34s} "
                  f"{row['value']:12.5g} {_fmt(row['predicted'], '12.5g')} "
                  f"{_fmt(100 * row['relative_error'], '+7.3f', '%')} "
                  f"{_fmt(100 * row['predicted_error'], '+8.3f', '%')}")
    print(f"table: {args.check_table}")
    return 0


def advise(args: argparse.Namespace) -> int:
    """Print the step (and discretisation) at which each quantity is within ``--target``."""
    summary = read_summary(args.against)
    print(f"within {100 * args.target:g} % of the limit, by the model f∞ + C hᵖ of "
          f"{args.against} (h relative to the coarsest level):")
    for name in args.cases:
        base, _, sequences, _ = case_setup(args, name)
        for (case, seq_name, quantity), row in summary.items():
            if case != name or seq_name not in args.sequences or not (
                    args.all or quantity in PRINTED):
                continue
            step = advised_step(row, args.target)
            if quantity.startswith(NEAR_ZERO_QUANTITIES):
                advice = "no relative error: its limit is (nearly) zero, read its values"
            elif math.isnan(step):
                advice = f"no order ({row['behaviour']})"
            elif math.isinf(step):
                advice = "the finest level is the limit"
            elif step < SMALLEST_ADVISED_STEP:
                advice = f"h = {step:.2g}: beyond any grid (order p = {row['order']:.2f})"
            else:
                advice = (f"p = {row['order']:5.2f}, h = {step:5.3f}: "
                          f"{level_near(sequences[seq_name], base, step)}")
            print(f"  {case:30s} {seq_name:10s} {quantity:34s} {advice}")
    return 0


def level_near(sequence: Refinement, base: Discretisation, step: float) -> str:
    """The discretisation of ``sequence`` at ``step`` (each refined number rounded up)."""
    coarsest = sequence.level(base, 0)

    def at(name: str, value: int) -> int:
        return count_at_step(value, step) if name in sequence.start else value

    increments = "+".join(str(at("increments", n)) for n in coarsest.increments)
    if "depth" in sequence.start:
        return f"box depth × {coarsest.depth / base.depth / step:.3g} of the shipped one"
    if "window" in sequence.start:
        return f"window × {coarsest.nx / base.nx / step:.3g} of the shipped one, same cells"
    return f"{at('nx', coarsest.nx)}² × {at('nz', coarsest.nz)} cells, increments {increments}"


def quick_overrides(study_case: StudyCase) -> list[str]:
    """The ``--quick`` overrides of ``study_case``: :data:`QUICK` and a small surface grid."""
    half_width = base_case(study_case).grid.half_width
    cells = 2 * round(QUICK_CELLS_PER_RADIUS * half_width)
    return [f"grid.nx={cells}", f"grid.ny={cells}", *QUICK]


def print_plan(runner: LevelRunner, base: Discretisation, shipped: Discretisation,
               plan: dict[str, list[Discretisation]]) -> None:
    """Print the levels of each sequence of one case, each marked cached or to run."""
    def line(level: Discretisation) -> str:
        state = "cached" if runner.path(level).exists() else "to run"
        window = "" if level.half_width is None else f", window {level.half_width:g} a"
        return (f"{level.nx:4d}² × {level.nz:3d} layers, depth {level.depth * 1e6:8.3f} µm"
                f"{window}, increments {'+'.join(map(str, level.increments)):>7s}: {state}")

    print(f"{runner.study_case.name}: shipped {line(shipped)}")
    if base != shipped:
        print(f"  study base {line(base)}")
    for name, levels in plan.items():
        for k, level in enumerate(levels):
            print(f"  {name:10s} {k}: {line(level)}")


class LevelRunner:
    """Runs the levels of one case, each once: results cached as JSON in ``cache``."""

    def __init__(self, study_case: StudyCase, overrides: Sequence[str], cache: Path,
                 fingerprint: str) -> None:
        self.study_case = study_case
        self.overrides = list(overrides)
        self.cache = cache
        self.fingerprint = fingerprint
        self.case_text = study_case.path.read_text(encoding="utf-8")

    def path(self, level: Discretisation) -> Path:
        """The cache file of ``level``: readable name, then a hash of all that decides it."""
        key = json.dumps({"case_file": self.case_text,
                          "overrides": [*case_overrides(self.study_case), *self.overrides,
                                        *level.overrides()],
                          "source": self.fingerprint}, sort_keys=True)
        digest = hashlib.sha256(key.encode()).hexdigest()[:16]
        increments = "+".join(str(n) for n in level.increments)
        window = "" if level.half_width is None else f"-w{level.half_width:.4g}a"
        return self.cache / (f"{self.study_case.name}-nx{level.nx}-nz{level.nz}-"
                             f"d{level.depth * 1e6:.4g}um{window}-inc{increments}-{digest}.json")

    def record(self, level: Discretisation) -> dict[str, Any] | None:
        """The record of ``level`` (:meth:`run`): cached, else run (None when the run fails)."""
        path = self.path(level)
        if path.exists():
            return dict(json.loads(path.read_text(encoding="utf-8")))
        label = f"{self.study_case.name} {path.stem.rsplit('-', 1)[0]}"
        print(f"running {label} ...", flush=True)
        try:
            record = self.run(level)
        except SacflowError as exc:
            print(f"  failed: {exc}", file=sys.stderr)
            return None
        print(f"  {record['elapsed']:.1f} s, {record['plasticity_iterations']} plasticity "
              f"iterations, all steps converged: {record['converged']}", flush=True)
        write_json(path, record)
        return record

    def run(self, level: Discretisation) -> dict[str, Any]:
        """Run ``level`` in this process and return its record."""
        case = base_case(self.study_case, [*self.overrides, *level.overrides(),
                                           f"output.volume_every={level.total_increments}"])
        start = time.perf_counter()
        sim = simulation_for(case)
        states = [scalars_only(state) for state in sim.run()]
        elapsed = time.perf_counter() - start
        quantities, profile = measure(sim, states, case.hertz().a)
        return {
            "case": self.study_case.name, "case_file": str(self.study_case.path),
            "overrides": [*case_overrides(self.study_case), *self.overrides,
                          *level.overrides()],
            "nx": level.nx, "nz": level.nz, "depth": level.depth,
            "increments": list(level.increments), "source": self.fingerprint,
            "elapsed": elapsed, "converged": all(s.converged for s in states),
            "plasticity_iterations": sum(s.plasticity_iterations for s in states),
            "quantities": quantities, "profile": profile,
        }


def write_json(path: Path, record: dict[str, Any]) -> None:
    """Write ``record`` to ``path`` atomically (a temporary file renamed over it)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(record, f, indent=1)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def print_summary(rows: Sequence[dict[str, Any]], names: Sequence[str] | None) -> None:
    """Print one line per (case, sequence, quantity): behaviour, p, limit ± U, shipped error."""
    print(f"{'case':30s} {'sequence':10s} {'quantity':34s} {'behaviour':11s} {'p':>6s} "
          f"{'limit':>12s} {'U/|limit|':>9s} {'shipped':>8s}")
    for row in rows:
        if names is not None and row["quantity"] not in names:
            continue
        print(f"{row['case']:30s} {row['sequence']:10s} {row['quantity']:34s} "
              f"{row['behaviour']:11s} {_fmt(row['order'], '6.2f')} {_fmt(row['limit'], '12.5g')} "
              f"{_fmt(100 * row['relative_uncertainty'], '8.3f', '%')} "
              f"{_fmt(100 * row['shipped_error'], '+7.3f', '%')}")


def _fmt(value: float, spec: str, suffix: str = "") -> str:
    """``value`` formatted with ``suffix``, blank (of the same width) when not finite."""
    width = int(spec.split(".")[0].lstrip("+")) + len(suffix)
    return format(value, spec) + suffix if math.isfinite(value) else " " * width


def write_plots(results: Sequence[SequenceResult], folder: Path) -> None:
    """Write ``<case>-<sequence>.png`` (errors against h) and ``<case>-<sequence>-s11.png``
    (the residual σ11 axis profiles of the levels) of each result into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    for result in results:
        stem = f"{result.case}-{result.refinement.name}"
        plot_errors(result, PLOTTED).savefig(folder / f"{stem}.png", dpi=120,
                                             bbox_inches="tight")
        plot_profiles(result).savefig(folder / f"{stem}-s11.png", dpi=120, bbox_inches="tight")
    print(f"plots: {folder}")


if __name__ == "__main__":
    sys.exit(main())
