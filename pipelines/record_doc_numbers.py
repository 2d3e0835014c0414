"""Recompute the numbers that README.md and docs/*.md quote from computations.

    python pipelines/record_doc_numbers.py [--slow | --groups NAME,...] [--out DIR] [--write]

``data/doc_numbers.csv`` lists each quoted number: the file, the text that quotes it, the number
as printed, the value recorded (SI units), its tolerance, how it is obtained (a ``group`` of this
script: one computation may give several numbers) and the grid. This script recomputes the
groups and prints one JSON line per row: recorded, recomputed, whether they agree within the
row's tolerance. ``--slow`` adds the groups that run shipped cases at their shipped grids
(minutes each) or take more than about ten seconds; ``--groups`` recomputes only the named
groups (after a change of one case); ``--out`` keeps their runs (default: a temporary folder;
finished runs are reused); ``--write`` stores the recomputed values in the table (review its
diff, then make the docs quote them: ``tests/test_doc_numbers.py`` fails while a quoted number
and its row disagree).

Fast groups are closed forms, ``sacflow validate``'s Hertz numbers and runs of a few seconds;
``tests/test_doc_numbers.py`` recomputes them in the default suite and the slow ones with
``-m slow``. The groups of README.md, docs/compare.md, docs/dent-study.md and docs/inclusions.md
are in ``pipelines/doc_number_groups_a.py``, those of docs/inclusions.md's own hardening in
``pipelines/doc_number_groups_c.py``, docs/convergence.md's certified limits in
``pipelines/doc_number_groups_d.py`` and their lateral cells refined further in
``pipelines/doc_number_groups_e.py``; numbers that are not computed (inputs, literature
values, definitions, measurements) are rows of ``data/doc_inputs.csv`` instead
(``tests/test_doc_inventory.py`` checks that every number of the docs is in one table or the
other).
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import doc_number_groups_a as groups_a  # noqa: E402  (README.md, compare, dent study, inclusions)
import doc_number_groups_c as groups_c  # noqa: E402  (inclusions: own hardening)
import doc_number_groups_d as groups_d  # noqa: E402  (convergence: the certified limits)
import doc_number_groups_e as groups_e  # noqa: E402  (convergence: the finer lateral cells)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "pipelines"))
from doc_number_groups_b import GROUPS as GROUPS_B  # noqa: E402  (a sibling script)
from doc_number_groups_b_runs import GROUPS as RUNS_B  # noqa: E402  (a sibling script)

TABLE = ROOT / "data" / "doc_numbers.csv"
COLUMNS = ["key", "file", "quoted", "number", "unit", "scale", "value", "tolerance", "group",
           "method", "grid", "speed"]
#: ISO 281's Hertz pressure at its fatigue limit (docs/fatigue.md) [Pa]; the indices scale with it.
ISO_P0 = 1.5e9
#: docs/fatigue.md's sampling of the rolled Hertz field: 961 load positions over ±6 a.
PASSAGE_POSITIONS, PASSAGE_HALF_LENGTH = 961, 6.0
#: Depth step of that sampling [a]; the fast group samples 0.30–0.50 a only, where both maxima
#: lie (0.39 a and 0.35 a), the slow one 0.005–1.2 a.
DEPTH_STEP = 0.005


def _case(path: str, overrides: tuple[str, ...] = ()):
    from sacflow.storage.case_file import load_case

    return load_case(ROOT / path, list(overrides))


def hertz_elastic(out: Path) -> dict[str, float]:
    """Hertz numbers of configs/hertz-elastic.toml, as ``sacflow validate`` prints them."""
    hertz = _case("configs/hertz-elastic.toml").hertz()
    return {"hertz_elastic_a": hertz.a, "hertz_elastic_p0": hertz.p0}


def press_hertz(out: Path) -> dict[str, float]:
    """Hertz numbers of the indentation press: its rigid sphere (``sacflow validate``) and, for
    the comparison in docs/initial-states.md, an elastic ball of the same steel on a flat."""
    from sacflow.mechanics.hertz import composite_modulus, hertz_contact

    case = _case("pipelines/dent-from-indentation-press.toml")
    rigid = case.hertz()
    body = case.body
    steel = hertz_contact(rigid.load, case.counterbody.radius,
                          composite_modulus(body.E, body.nu, body.E, body.nu))
    return {"press_hertz_a": rigid.a, "press_hertz_p0": rigid.p0,
            "press_steel_ball_a": steel.a, "press_steel_ball_p0": steel.p0}


def closed_forms(out: Path) -> dict[str, float]:
    """Hertz first yield at ν = 0.3 (``sacflow.mechanics.hertz.first_yield``) and the default
    endurance limits' derived constants (``sacflow.compare.fatigue_index.DEFAULT_LIMITS``)."""
    from sacflow.compare.fatigue_index import DEFAULT_LIMITS
    from sacflow.mechanics.hertz import first_yield

    p0_over_yield, depth_over_a, von_mises_over_p0 = first_yield(0.3)
    return {"first_yield_p0_over_yield": p0_over_yield,
            "first_yield_p0_over_k": p0_over_yield * np.sqrt(3.0),
            "first_yield_depth": depth_over_a, "first_yield_von_mises": von_mises_over_p0,
            "default_torsion_limit": DEFAULT_LIMITS.torsion,
            "default_dang_van_a": DEFAULT_LIMITS.dang_van_a}


def _iso_indices(first: float, last: float) -> dict[str, float]:
    from sacflow.compare.fatigue_index import DEFAULT_LIMITS
    from sacflow.mechanics.fatigue_criteria import fatigue_indices
    from sacflow.mechanics.hertz import hertz_subsurface_stress

    a, nu = 1.0, 0.3
    x1 = np.linspace(-PASSAGE_HALF_LENGTH, PASSAGE_HALF_LENGTH, PASSAGE_POSITIONS) * a
    x3 = np.arange(round(first / DEPTH_STEP), round(last / DEPTH_STEP) + 1) * DEPTH_STEP * a
    stress = hertz_subsurface_stress(x1[:, None], 0.0, x3[None, :], a, ISO_P0, nu)
    dang_van, crossland = fatigue_indices(stress, DEFAULT_LIMITS, time_axis=0)
    return {"iso_dang_van": float(dang_van.index.max()),
            "iso_crossland": float(crossland.index.max())}


def iso_fatigue_band(out: Path) -> dict[str, float]:
    """docs/fatigue.md's indices at ISO's limit, depths 0.30–0.50 a (both maxima inside)."""
    return _iso_indices(0.30, 0.50)


def iso_fatigue_full(out: Path) -> dict[str, float]:
    """The same over depths 0.005–1.2 a, the sampling docs/fatigue.md describes."""
    return _iso_indices(DEPTH_STEP, 1.2)


def compare_example(out: Path) -> dict[str, float]:
    """docs/compare.md's case-vs-reference example: hertz-elastic, data/hertz-axis-s11.csv."""
    from sacflow.compare import case_vs_reference
    from sacflow.runner import run_case

    path = run_case(_case("configs/hertz-elastic.toml"), out, progress=False).path
    result = case_vs_reference(
        path, ROOT / "data" / "hertz-axis-s11.csv", "stress",
        select={"x1": 0.0, "x2": 0.0, "component": "11"}, reference_variable="s11",
        value_scale=1e6, coord_scale=1e-6)
    return {"compare_example_relative": float(result["max_relative_difference"]),
            "compare_example_points": float(result["points"])}


def _seed_run(name: str, out: Path) -> Path:
    sys.path.insert(0, str(ROOT / "pipelines"))
    import seed_report

    from sacflow.runner import run_case

    return run_case(seed_report.build(name, []), out, progress=False).path


def seed_indentation(out: Path) -> dict[str, float]:
    """The 650 mN indentation at its shipped grid: print depth, residual approach."""
    from sacflow import compare

    path = _seed_run("nanoindentation-650mN", out)
    return {"seed_print_depth": float(compare.indentation(path)["print_depth"]),
            "residual_approach_650mN": float(compare.load_approach(path)["residual_approach"])}


def seed_dent_vertical(out: Path) -> dict[str, float]:
    """The dent loaded vertically, elastic and elastic-plastic (seed Fig. 20), shipped grid."""
    from sacflow import compare

    pair = compare.elastic_vs_plastic(_seed_run("dent-vertical-elastic", out),
                                      _seed_run("dent-vertical", out))
    return {"seed_dent_peak_ratio": float(pair["peak_ratio"])}


def seed_dent_rolling(out: Path) -> dict[str, float]:
    """The dent rolled over against loaded vertically on the same grid (seed Fig. 22): the
    residual σ11 along x1 at 75 µm deep (the nearest layer), track centre, last step."""
    from sacflow import compare

    path = _seed_run("dent-rolling", out)
    rolled = compare.vertical_vs_rolling(_seed_run("dent-vertical-rolling-grid", out), path,
                                         depth=75e-6)
    numbers = {f"seed_rolling_{k}": float(rolled[k]) for k in (
        "min_vertical", "min_rolling", "min_ratio", "asymmetry_rolling", "asymmetry_vertical")}
    numbers["seed_rolling_min_rolling_x1"] = float(rolled["min_rolling_x1"])
    return {**numbers, **dent_rolling_fields(path)}


#: docs/friction.md's layer under the dent: the cell layer centred at 87.5 µm.
FRICTION_LAYER_DEPTH = 87.5e-6


def dent_rolling_fields(path: Path) -> dict[str, float]:
    """docs/friction.md's μ = 0 column: dent-rolling after the pass, on the track-centre row."""
    from sacflow.storage.run_reader import open_run

    ds = open_run(path)
    last = ds.isel(step=-1)
    row = last.sel(x2=0.0, method="nearest")
    s11 = row["residual_stress"].sel(component="11")
    x1 = ds["x1"].values
    deep = s11.sel(x3=FRICTION_LAYER_DEPTH, method="nearest").values
    first = s11.isel(x3=0).values
    eqps = last["equivalent_plastic_strain"]
    where = np.unravel_index(int(np.nanargmax(eqps.values)), eqps.shape)
    return {
        "dent_rolling_min_s11_87um": float(deep.min()),
        "dent_rolling_min_s11_87um_x1": float(x1[int(np.argmin(deep))]),
        "dent_rolling_min_s11_87um_after": float(deep[x1 > 0.0].min()),
        "dent_rolling_first_layer_s11_min": float(first.min()),
        "dent_rolling_first_layer_s11_max": float(first.max()),
        "dent_rolling_max_eqps": float(eqps.max()),
        "dent_rolling_max_eqps_x1": float(eqps[eqps.dims[0]].values[where[0]]),
        "dent_rolling_peak_pressure": float(ds["max_pressure"].max()),
    }


def dent_rolling_traction(out: Path) -> dict[str, float]:
    """docs/friction.md's μ = 0.2 column: configs/dent-rolling-traction.toml after the pass."""
    from sacflow.runner import run_case

    path = run_case(_case("configs/dent-rolling-traction.toml"), out, progress=False).path
    return {f"traction_{key}": value for key, value in dent_rolling_fields(path).items()}


def shakedown(out: Path) -> dict[str, float]:
    """pipelines/shakedown_bounds.py's line contact and sphere (whole class) brackets [k]."""
    sys.path.insert(0, str(ROOT / "pipelines"))
    import shakedown_bounds

    from sacflow.mechanics.shakedown_bracket import rolling_bracket

    numbers = {}
    for contact, kind, settings in shakedown_bounds.CASES:
        if kind == "depth" and contact == "point":
            continue
        bracket = rolling_bracket(contact, 0.3, kind=kind, **settings)
        numbers[f"shakedown_{contact}_lower"] = shakedown_bounds.SQRT3 * bracket.lower
        numbers[f"shakedown_{contact}_ceiling"] = shakedown_bounds.SQRT3 * bracket.ceiling
    return numbers


def dent_fatigue(out: Path) -> dict[str, float]:
    """docs/fatigue.md: the stage's Dang Van maximum on dent-rolling at two coarse grids."""
    from sacflow.compare import fatigue
    from sacflow.runner import run_case

    numbers = {}
    for n, nz in ((32, 12), (40, 14)):
        case = _case("configs/dent-rolling.toml", (
            f"grid.nx={n}", f"grid.ny={n}", f"grid.nz={nz}", "output.volume_every=1",
            f"name=dent-rolling-{n}"))
        result = fatigue(run_case(case, out, progress=False).path)
        numbers[f"dent_fatigue_dang_van_{n}"] = float(result["dang_van_max"])
        numbers[f"dent_fatigue_depth_{n}"] = float(result["dang_van_max_depth"])
    return numbers


#: docs/repeated-rolling.md's Melan table: nominal p0/k -> (load [N], roll distance [m]) of
#: configs/campaign-rolling-cycles.toml's sweep.
CAMPAIGN_LOADS = {"4.5": (2722.6, 2.8295e-3), "5.0": (3734.7, 3.1438e-3)}


def melan_on_runs(out: Path) -> dict[str, float]:
    """``sacflow compare melan`` on two cases of campaign-rolling-cycles (six passes each)."""
    from sacflow.compare import melan
    from sacflow.runner import run_case

    numbers = {}
    for label, (load, distance) in CAMPAIGN_LOADS.items():
        case = _case("configs/rolling-cycles-shakedown.toml", (
            f"load_path.0.to={load}", f"load_path.1.distance={distance}",
            f"name=rolling-cycles-{label}k"))
        result = melan(run_case(case, out, progress=False).path)
        numbers[f"melan_{label}k_load_factor"] = float(result["load_factor"])
        numbers[f"melan_{label}k_peak"] = float(result["peak_pressure"])
    return numbers


#: group name -> (speed, function of the output folder returning {key: value in SI units}).
#: The convergence study's cases quoted in docs/convergence.md, by the label its table uses.
CONVERGENCE_ROWS = {
    "650 mN, print depth": ("nanoindentation-650mN", "print_depth"),
    "650 mN, max εp (refined)": ("nanoindentation-650mN", "max_plastic_strain_refined"),
    "650 mN, approach at peak load": ("nanoindentation-650mN", "approach_at_peak_load"),
    "650 mN, peak pressure": ("nanoindentation-650mN", "peak_pressure"),
    "650 mN, min residual σ11 on the axis": ("nanoindentation-650mN", "residual_s11_axis_min"),
    "190 mN, print depth": ("nanoindentation-190mN", "print_depth"),
    "linear hardening 650 mN, max εp (refined)": ("nanoindentation-linear-650mN",
                                                   "max_plastic_strain_refined"),
    "press 600 N, max εp": ("dent-from-indentation-press", "max_plastic_strain"),
    "press 600 N, min residual σ11 on the axis": ("dent-from-indentation-press",
                                                  "residual_s11_axis_min"),
}


def convergence_study(out: Path) -> dict[str, float]:
    """The increment sequences of ``data/convergence*-summary.csv`` that convergence.md quotes.

    Per row of its first table: the observed order and the shipped error with one
    backward-Euler step per increment (``..._be_order``, ``..._be_error``) and step-doubled
    (``..._order``, ``..._error``), the Richardson limit and its relative uncertainty.
    """
    def summary(name: str) -> dict[tuple[str, str], dict[str, str]]:
        with open(ROOT / "data" / name, newline="", encoding="utf-8") as f:
            return {(r["case"], r["quantity"]): r for r in csv.DictReader(f)
                    if r["sequence"] == "increments"}

    after = summary("convergence-summary.csv")
    before = summary("convergence-backward-euler-summary.csv")
    numbers: dict[str, float] = {}
    for index, key in enumerate(CONVERGENCE_ROWS.values()):
        stem = f"convergence_{index}"
        numbers[f"{stem}_be_order"] = float(before[key]["order"])
        numbers[f"{stem}_be_error"] = float(before[key]["shipped_error"])
        numbers[f"{stem}_order"] = float(after[key]["order"])
        numbers[f"{stem}_error"] = float(after[key]["shipped_error"])
        numbers[f"{stem}_limit"] = float(after[key]["limit"])
        numbers[f"{stem}_uncertainty"] = float(after[key]["relative_uncertainty"])
    return numbers


#: The cells of docs/initial-states.md's table of the press's residual hydrostatic stress:
#: (grid, radius [µm] the nearest cell centre on x1 > 0 is taken at, depth label of
#: ``data/dent-hydrostatic.csv``); 4 µm is the first layer centre of the 64-layer grids.
HYDROSTATIC_CELLS = [
    (grid, radius, where)
    for grid, depths in (("48x16", ("16 um",)), ("48x32", ("16 um", "8 um")),
                         ("48x64", ("16 um", "8 um", "first layer")),
                         ("72x64", ("16 um", "8 um", "first layer")))
    for radius, wheres in ((148, ("16 um",)), (177, depths), (205, depths))
    for where in wheres
]


def dent_hydrostatic(out: Path) -> dict[str, float]:
    """σh of the press where docs/initial-states.md quotes it (data/dent-hydrostatic.csv)."""
    with open(ROOT / "data" / "dent-hydrostatic.csv", newline="", encoding="utf-8") as f:
        rows = [r for r in csv.DictReader(f) if r["quantity"] == "hydrostatic"]
    numbers: dict[str, float] = {}
    for grid, radius, where in HYDROSTATIC_CELLS:
        line = [r for r in rows if r["grid"] == grid and r["where"] == where
                and float(r["x1_m"]) > 0]
        nearest = min(line, key=lambda r: abs(float(r["x1_m"]) - radius * 1e-6))
        numbers[f"hydrostatic_{grid}_{radius}_{where.replace(' ', '_')}"] = float(
            nearest["value_Pa"])
    return numbers


#: Cells per radius of the Eshelby sphere that docs/inclusions.md quotes.
ESHELBY_CELLS = (2, 3, 5)


def eshelby_sphere(out: Path) -> dict[str, float]:
    """Interior-strain errors of Eshelby's sphere (E*/E = 2) and their observed order.

    The runs and the closed form of ``tests/test_inhomogeneity_solver.py`` (a few seconds).
    """
    sys.path.insert(0, str(ROOT / "tests"))
    import test_inhomogeneity_solver as eshelby

    ratio = 2.0
    _, exact = eshelby.eshelby_interior(ratio)
    errors = []
    for cells in ESHELBY_CELLS:
        _, states = eshelby.run(eshelby.eshelby_inputs(ratio, cells))
        _, strain = eshelby.interior(states[-1], ratio)
        errors.append(float(np.linalg.norm(strain - exact) / np.linalg.norm(exact)))
    numbers = {f"eshelby_error_{cells}": e for cells, e in zip(ESHELBY_CELLS, errors, strict=True)}
    numbers["eshelby_order"] = float(np.log(errors[0] / errors[-1])
                                     / np.log(ESHELBY_CELLS[-1] / ESHELBY_CELLS[0]))
    return numbers


_OWN: dict[str, tuple[str, Callable[[Path], dict[str, float]]]] = {
    "hertz_elastic": ("fast", hertz_elastic),
    "closed_forms": ("fast", closed_forms),
    "press_hertz": ("fast", press_hertz),
    "iso_fatigue_band": ("fast", iso_fatigue_band),
    "iso_fatigue_full": ("slow", iso_fatigue_full),
    "compare_example": ("fast", compare_example),
    "seed_indentation": ("slow", seed_indentation),
    "seed_dent_vertical": ("slow", seed_dent_vertical),
    "seed_dent_rolling": ("slow", seed_dent_rolling),
    "dent_rolling_traction": ("slow", dent_rolling_traction),
    "shakedown": ("slow", shakedown),
    "dent_fatigue": ("slow", dent_fatigue),
    "melan_on_runs": ("slow", melan_on_runs),
    "convergence_study": ("fast", convergence_study),
    "dent_hydrostatic": ("fast", dent_hydrostatic),
    "eshelby_sphere": ("fast", eshelby_sphere),
}
#: Every group: this script's and its sibling modules' (each exports ``GROUPS``).
GROUPS: dict[str, tuple[str, Callable[[Path], dict[str, float]]]] = {}
for _groups in (_OWN, groups_a.GROUPS, GROUPS_B, RUNS_B, groups_c.GROUPS, groups_d.GROUPS,
                groups_e.GROUPS):
    if set(_groups) & set(GROUPS):
        raise ValueError(f"doc-number groups named twice: {sorted(set(_groups) & set(GROUPS))}")
    GROUPS.update(_groups)


def read_table(path: Path = TABLE) -> list[dict[str, str]]:
    """Rows of ``data/doc_numbers.csv`` (``#`` lines are comments)."""
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def recompute(group: str, out: Path) -> dict[str, float]:
    """Run one group into ``out`` and return its numbers by key."""
    return GROUPS[group][1](out)


def agrees(row: dict[str, str], value: float) -> bool:
    """Whether a recomputed value is the row's recorded one within its relative tolerance."""
    recorded = float(row["value"])
    return bool(abs(float(value) - recorded) <= float(row["tolerance"]) * abs(recorded))


def _write(rows: list[dict[str, str]], new: dict[str, float]) -> None:
    header = [line for line in TABLE.read_text(encoding="utf-8").splitlines(keepends=True)
              if line.startswith("#")]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({**row, "value": f"{new[row['key']]:.10g}"} if row["key"] in new else row)
    TABLE.write_text("".join(header) + buffer.getvalue(), encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--slow", action="store_true", help="also the shipped-grid runs")
    parser.add_argument("--out", type=Path, default=None, help="folder for the runs")
    parser.add_argument("--write", action="store_true", help="store the values in the table")
    parser.add_argument("--groups", default=None,
                        help="only these groups, comma-separated (slow ones included)")
    args = parser.parse_args(argv)
    chosen = None if args.groups is None else args.groups.split(",")
    unknown = sorted(set(chosen or ()) - set(GROUPS))
    if unknown:
        parser.error(f"unknown group(s) {', '.join(unknown)}: choose from {', '.join(GROUPS)}")
    rows = read_table()
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or Path(tmp)
        new: dict[str, float] = {}
        for group, (speed, _) in GROUPS.items():
            if (group in chosen) if chosen is not None else (speed == "fast" or args.slow):
                new.update(recompute(group, out))
    for row in rows:
        if row["key"] in new:
            value = new[row["key"]]
            print(json.dumps({"key": row["key"], "file": row["file"],
                              "recorded": float(row["value"]), "recomputed": float(value),
                              "agrees": agrees(row, value)}))
    if args.write:
        _write(rows, new)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
