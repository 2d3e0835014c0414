"""The dented-surface study, end to end: campaigns, fatigue stage, summary, plots.

    python pipelines/dent_study.py --out runs/dent-study [--workers N] [--scheduler ADDRESS]
                                   [--set KEY=VALUE ...] [--bending-limit PA --torsion-limit PA]

1. runs the campaigns ``dent-study.toml`` (dent depth x width x load) and
   ``dent-study-smooth.toml`` (the smooth surface at each load) into ``--out`` with dask (this
   machine, or the cluster at ``--scheduler``); finished cases are not run again;
2. runs the fatigue stage on every run (``<out>/fatigue/<case>-fatigue.nc`` and ``.png``; kept
   when still valid for the same run and endurance limits);
3. writes the summary along ``case`` (``<out>/dent-study-summary.nc``) and its plots
   (``dent-study-index-vs-slope.png``, ``dent-study-worst-case.png``).

``--set`` changes the base case of both campaigns (``--set grid.nx=48 --set grid.ny=48`` for a
finer grid). Prints the time of each stage and a table of the summary.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from sacflow.campaign import load_campaign, run_campaign
from sacflow.compare.plots import display_scale
from sacflow.errors import SacflowError
from sacflow.storage.atomic_file import write_atomically
from sacflow.studies.dent_study import (
    dent_summary,
    fatigue_results,
    plot_index_vs_slope,
    plot_worst_case,
    write_summary,
)

HERE = Path(__file__).resolve().parent
DENTED, SMOOTH = HERE / "dent-study.toml", HERE / "dent-study-smooth.toml"
COLUMNS = ("dang_van_ratio", "dang_van_max_offset", "dang_van_max_depth", "pressure_peak_ratio",
           "residual_stress_11_min", "max_plastic_strain")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("runs/dent-study"))
    parser.add_argument("--workers", type=int)
    parser.add_argument("--scheduler")
    parser.add_argument("--set", dest="overrides", action="append", default=[],
                        metavar="KEY=VALUE")
    parser.add_argument("--bending-limit", type=float)
    parser.add_argument("--torsion-limit", type=float)
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args(argv)
    if (args.bending_limit is None) != (args.torsion_limit is None):
        parser.error("give both --bending-limit and --torsion-limit, or neither")
    limits = None if args.bending_limit is None else (args.bending_limit, args.torsion_limit)
    try:
        return _study(args, limits)
    except SacflowError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


def _study(args: argparse.Namespace, limits: tuple[float, float] | None) -> int:
    progress = not args.no_progress
    start = time.perf_counter()
    manifests = []
    for path in (DENTED, SMOOTH):
        outcome = run_campaign(load_campaign(path, args.overrides), args.out,
                               workers=args.workers, scheduler=args.scheduler, progress=progress)
        print(outcome.table())
        if outcome.failed:
            print(f"{len(outcome.failed)} case(s) failed; the summary leaves them out",
                  file=sys.stderr)
        manifests.append(outcome.manifest)
    runs = time.perf_counter()
    fatigue_dir = args.out / "fatigue"
    for manifest in manifests:
        fatigue_results(manifest, fatigue_dir, limits=limits, progress=progress)
    stage = time.perf_counter()
    summary = dent_summary(*manifests, fatigue_dir)
    nc = write_summary(summary, args.out / "dent-study-summary.nc")
    for name, figure in (("index-vs-slope", plot_index_vs_slope(summary)),
                         ("worst-case", plot_worst_case(summary, fatigue_dir))):
        write_atomically(args.out / f"dent-study-{name}.png",
                         lambda tmp, figure=figure: figure.savefig(tmp, dpi=120))
    end = time.perf_counter()
    _print_table(summary)
    print(f"campaigns {runs - start:.0f} s, fatigue stage {stage - runs:.0f} s, summary "
          f"{end - stage:.0f} s, total {end - start:.0f} s -> {nc}")
    return 0


def _print_table(summary) -> None:
    shown = {}
    for name in COLUMNS:
        units = summary[name].attrs.get("units", "1")
        factor, unit = display_scale(units, summary[name].values)
        shown[name] = (factor, unit)
    head = ["A [µm]", "w [µm]", "W [N]"] + [f"{n} [{u}]" for n, (_, u) in shown.items()]
    print("  ".join(head))
    for i in range(summary.sizes["case"]):
        row = [f"{summary['dent_depth'].values[i] * 1e6:.0f}",
               f"{summary['dent_width'].values[i] * 1e6:.0f}",
               f"{summary['load'].values[i]:.0f}"]
        row += [f"{summary[n].values[i] * f:.4g}" for n, (f, _) in shown.items()]
        print("  ".join(row))


if __name__ == "__main__":
    sys.exit(main())
