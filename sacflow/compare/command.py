"""``sacflow compare STAGE RUN.nc [RUN2.nc ...] --out DIR [options]``.

Registered on the main parser by :func:`add_compare_command`. This module imports only the
standard library: the stages (xarray, matplotlib) load when the command runs. Errors are
:class:`~sacflow.compare.core.CompareError` (a :class:`~sacflow.errors.SacflowError`), which the
main command prints as ``error: ...``.
"""

from __future__ import annotations

import argparse
import math
import re
from dataclasses import dataclass
from importlib import import_module
from pathlib import Path
from typing import Any

__all__ = ["NEGATIVE_NUMBER", "STAGES", "add_compare_command", "finite_float"]


@dataclass(frozen=True)
class Stage:
    """A stage as seen from the command line."""

    function: str  # "module:function"
    runs: str  # "1", "2" or "+"
    options: tuple[str, ...] = ()
    required: tuple[str, ...] = ()
    help: str = ""


STAGES: dict[str, Stage] = {
    "hertz-check": Stage("hertz:hertz_check", "1", help="load-approach and pressure vs Hertz"),
    "indentation": Stage(
        "fields:indentation",
        "1",
        ("offsets",),
        help="εp and residual σ11, σ33 vs depth (seed Figs. 13-16)",
    ),
    "load-approach": Stage(
        "hertz:load_approach",
        "1",
        ("reference",),
        help="loading/unloading branches vs Hertz (seed Fig. 11)",
    ),
    "elastic-vs-plastic": Stage(
        "pairs:elastic_vs_plastic", "2", help="pressure profiles at max load (seed Fig. 20)"
    ),
    "vertical-vs-rolling": Stage(
        "pairs:vertical_vs_rolling",
        "2",
        ("depth", "x2", "centre"),
        help="residual σ11 along x1 at a depth (seed Fig. 22)",
    ),
    "track": Stage(
        "rolling_track:track",
        "1",
        ("x2", "tolerance", "end_margin"),
        help="residual displacement on a rolled track (seed Fig. 18)",
    ),
    "residual-map": Stage(
        "fields:residual_map",
        "1",
        ("depth", "component", "step"),
        help="residual stress map in a plane x3 = depth (seed Fig. 21)",
    ),
    "fatigue": Stage(
        "fatigue_index:fatigue",
        "1",
        ("bending_limit", "torsion_limit", "cycle"),
        help="Dang Van and Crossland index fields over one load cycle of the stored history",
    ),
    "passes": Stage("pass_history:passes", "1",
                    help="repeated rolling: plastic flow per pass, shakedown or ratcheting"),
    "melan": Stage("melan_bound:melan", "1", ("step",),
                   help="Melan's shakedown check of the stored pressure, rolled steadily"),
    "material-point": Stage(
        "material:material_point",
        "1",
        ("amplitude", "cycles", "mode", "control", "mean", "increments"),
        required=("amplitude",),
        help="cycles of the case's material (CASE.toml): loops, εp, backstress",
    ),
    "campaign-summary": Stage(
        "campaign:campaign_summary",
        "+",
        ("parameters", "result"),
        help="scalar results of many runs along a case dimension",
    ),
    "case-vs-reference": Stage(
        "reference:case_vs_reference",
        "1",
        (
            "reference",
            "variable",
            "step",
            "select",
            "reference_variable",
            "value_scale",
            "coord_scale",
        ),
        required=("reference", "variable"),
        help="a stored field/profile against reference points (CSV or netCDF)",
    ),
}


def _step(text: str) -> str | int:
    if text in ("last", "max_load", "max-load"):
        return text.replace("-", "_")
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError("use 'last', 'max_load' or a step number") from None


def finite_float(text: str) -> float:
    """Read a number option's value: any finite float (``nan`` and ``inf`` refused at once)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


#: What argparse takes for a negative number rather than an option: Python 3.11's own pattern
#: misses exponents (``--bending-limit -9e8`` read as a missing value); this is the pattern of
#: later Pythons (3.13).
NEGATIVE_NUMBER = re.compile(r"-\.?\d")


def add_compare_command(commands: Any) -> None:
    """Add the ``compare`` sub-command to the sub-parsers ``commands`` of the main parser."""
    listing = "\n".join(f"  {name:<20} {s.help}" for name, s in STAGES.items())
    parser = commands.add_parser(
        "compare",
        help="comparison stages on run files (writes netCDF + PNG)",
        description=f"Run a comparison stage on stored runs.\n\nstages:\n{listing}",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser._negative_number_matcher = NEGATIVE_NUMBER  # see NEGATIVE_NUMBER
    number = finite_float
    parser.add_argument("stage", choices=list(STAGES), metavar="STAGE", help="stage name")
    parser.add_argument("runs", nargs="+", type=Path, metavar="RUN",
                        help="run file(s) (.nc); material-point: a case file (.toml)")
    parser.add_argument("--out", type=Path, default=Path("compare"), help="output folder")
    parser.add_argument("--stem", help="output file name without suffix (default: derived)")
    option = parser.add_argument_group("stage options (each stage takes some)")
    option.add_argument("--offsets", type=number, nargs="+", help="indentation: x1 offsets [m]")
    option.add_argument("--depth", type=number, help="depth of the layer x3 [m]")
    option.add_argument("--x2", type=number, help="x2 of the profile [m]")
    option.add_argument("--centre", type=number, help="x1 centre of the asymmetry measure [m]")
    option.add_argument("--tolerance", type=number, help="track: steady band (default 0.02)")
    option.add_argument("--end-margin", type=number, help="track: end left out [m] (default a)")
    option.add_argument("--component", choices=["11", "22", "33", "12", "13", "23"])
    option.add_argument("--step", type=_step, help="'last', 'max_load' or a step number")
    option.add_argument("--reference", type=Path, help="reference file (CSV or netCDF)")
    option.add_argument("--variable", help="case-vs-reference: stored variable")
    option.add_argument("--reference-variable", help="value column of the reference")
    option.add_argument(
        "--select",
        action="append",
        metavar="DIM=VALUE",
        help="fixed position, e.g. --select x2=0 --select component=11",
    )
    option.add_argument("--value-scale", type=number, help="reference values -> SI (1e6: MPa)")
    option.add_argument("--coord-scale", type=number, help="reference coordinates -> m (1e-6: µm)")
    option.add_argument(
        "--bending-limit", type=number, help="fatigue: fully reversed bending endurance limit [Pa]"
    )
    option.add_argument(
        "--cycle", help="fatigue: 'auto' (the last complete pass, or the whole history), 'all' "
        "or a step range 'first:last'")
    option.add_argument(
        "--torsion-limit", type=number, help="fatigue: fully reversed torsion endurance limit [Pa]"
    )
    option.add_argument("--amplitude", type=number,
                        help="material-point: amplitude of the driven strain, or stress [Pa]")
    option.add_argument("--mean", type=number, help="material-point: mean of the cycles")
    option.add_argument("--cycles", type=int, help="material-point: full cycles (default 3)")
    option.add_argument("--increments", type=int,
                        help="material-point: increments per half-cycle (default 40)")
    option.add_argument("--mode", choices=["uniaxial", "shear"], help="material-point: mode")
    option.add_argument("--control", choices=["strain", "stress"],
                        help="material-point: driven quantity")
    option.add_argument(
        "--parameters", help="campaign: manifest JSON file, or comma-separated dotted case keys"
    )
    option.add_argument("--result", help="campaign: result to plot (default max_plastic_strain)")
    parser.set_defaults(handler=run_compare)


def _select(items: list[str]) -> dict[str, Any]:
    from sacflow.compare.core import CompareError

    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise CompareError(f"--select {item!r}: expected DIM=VALUE, e.g. x2=0")
        try:
            out[key.strip()] = float(value) if key.strip() != "component" else value.strip()
        except ValueError:
            out[key.strip()] = value.strip()
    return out


def run_compare(args: argparse.Namespace) -> int:
    """Handle ``sacflow compare``: compute, write stem.nc + stem.png, print the numbers."""
    from sacflow.compare.core import CompareError
    from sacflow.compare.output import summary, write

    stage = STAGES[args.stage]
    given = {name for name in _option_names() if getattr(args, name) is not None}
    stray = sorted(given - set(stage.options))
    if stray:
        flags = ", ".join("--" + s.replace("_", "-") for s in stray)
        raise CompareError(f"{flags} does not apply to {args.stage}")
    missing = [name for name in stage.required if name not in given]
    if missing:
        flags = ", ".join("--" + s.replace("_", "-") for s in missing)
        raise CompareError(f"{args.stage} needs {flags}")
    n = len(args.runs)
    if (stage.runs == "1" and n != 1) or (stage.runs == "2" and n != 2):
        raise CompareError(f"{args.stage} takes {stage.runs} run file(s), got {n}")

    kwargs = {name: getattr(args, name) for name in given if name != "result"}
    if "select" in kwargs:
        kwargs["select"] = _select(kwargs["select"])
    if "parameters" in kwargs:
        text = kwargs["parameters"]
        is_file = text.endswith(".json") or Path(text).is_file()
        kwargs["parameters"] = Path(text) if is_file else [k for k in text.split(",") if k]
    module, name = stage.function.split(":")
    function = getattr(import_module(f"sacflow.compare.{module}"), name)
    result = function(args.runs, **kwargs) if stage.runs == "+" else function(*args.runs, **kwargs)

    plot_options = {}
    if args.result is not None:
        if args.result not in result.data_vars:
            raise CompareError(
                f"--result {args.result!r} is not a result; choose one of "
                f"{', '.join(map(str, result.data_vars))}"
            )
        plot_options["result_name"] = args.result
    stem = args.stem or _default_stem(args.stage, args.runs)
    nc, png = write(result, args.out, stem, **plot_options)
    print(summary(result))
    print(f"  -> {nc}, {png.name}")
    return 0


def _option_names() -> tuple[str, ...]:
    return tuple(sorted({o for s in STAGES.values() for o in s.options}))


def _default_stem(stage: str, runs: list[Path]) -> str:
    if stage == "campaign-summary":
        return "campaign-summary"
    return "-".join([*(r.stem for r in runs), stage])
