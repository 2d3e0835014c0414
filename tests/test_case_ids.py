"""Case ids of every shipped case equal the ids recorded before the case id was cached (#29).

A stored run is identified by its ``case_id``: a change of how the id is computed must not
change it. ``data/case_ids.csv`` holds the ids the code gave before the id became a value
computed once per case (commit 0c0941b): every case of ``configs/`` and ``pipelines/`` as read
from its file, every case of the campaign files expanded, each case made tiny with
``model_copy`` (as ``tests/test_configs.py`` does), a measured surface from ``data/surfaces``,
a chained case (``initial_state``) whose source run stores a known id, and the path-named ids
of a surface file and of a source run that do not exist. ``python
pipelines/record_case_ids.py`` rewrites the table (only after a deliberate change of the id).

The ids are those of the cases as they were then: with ``solver.return_integration =
"backward_euler"``, the one-step return of every run before that option. At the option's new
default (step doubling, other numbers) a plastic case has another id, an elastic one the same.
"""

from __future__ import annotations

import csv
import tomllib
from collections.abc import Iterator
from pathlib import Path

import netCDF4

from sacflow.campaign.expansion import expand_campaign, load_campaign
from sacflow.config.schema import Case
from sacflow.storage.case_file import load_case, read_file

ROOT = Path(__file__).resolve().parent.parent
TABLE = ROOT / "data" / "case_ids.csv"
#: Case files and campaign files whose ids are recorded.
SHIPPED = sorted([*ROOT.glob("configs/*.toml"), *ROOT.glob("pipelines/*.toml")])
#: The case id a fake source run stores (a chained case's id includes its source's).
SOURCE_CASE_ID = "0123456789ab"
#: A chained case (pipelines/dent-from-indentation-rolling.toml) and a measured surface
#: (pipelines/dent-from-indentation-geometric.toml), with files that exist and that do not.
FILE_CASES = {
    "measured-dent-rims": ("pipelines/dent-from-indentation-geometric.toml",
                           "surface.path=../data/surfaces/dent-rims.txt"),
    "measured-absent": ("pipelines/dent-from-indentation-geometric.toml",
                        "surface.path=/nonexistent/surface.txt"),
    "chained-source": ("pipelines/dent-from-indentation-rolling.toml", "initial_state.run={run}"),
    "chained-absent": ("pipelines/dent-from-indentation-rolling.toml",
                       "initial_state.run=/nonexistent/source.nc"),
}


def _tiny(case: Case) -> Case:
    """``case`` on a 16 x 16 x 4 grid: a sweep by ``model_copy``, as tests/test_configs.py."""
    grid = case.grid.model_copy(update={"nx": 16, "ny": 16, "nz": 4})
    return case.model_copy(update={"grid": grid})


def _backward_euler(case: Case) -> Case:
    """``case`` with the one-step return: the numbers, and the id, of before the option."""
    solver = case.solver.model_copy(update={"return_integration": "backward_euler"})
    return case.model_copy(update={"solver": solver})


def _names_a_file(data: dict) -> bool:
    """Tell whether a case table names a file (FILE_CASES give those files)."""
    return "initial_state" in data or data.get("surface", {}).get("kind") == "measured"


def _fake_source_run(folder: Path) -> Path:
    """A netCDF file that stores only the ``case_id`` attribute a chained case's id reads."""
    path = folder / "source.nc"
    with netCDF4.Dataset(path, "w") as nc:
        nc.setncattr("case_id", SOURCE_CASE_ID)
    return path


def case_ids(folder: Path) -> Iterator[tuple[str, str]]:
    """Yield (label, case_id) of every recorded case as it was (:func:`_backward_euler`)."""
    for label, case in cases(folder):
        yield label, _backward_euler(case).case_id


def cases(folder: Path) -> Iterator[tuple[str, Case]]:
    """Yield (label, case) of every recorded case; ``folder`` takes a fake source run."""
    for path in SHIPPED:
        where = path.relative_to(ROOT).as_posix()
        if "sweep" in tomllib.loads(path.read_text()):
            for c in expand_campaign(load_campaign(path), str(path)):
                yield f"{where}:{c.name}", c.case
        elif not _names_a_file(read_file(path)):
            case = load_case(path)
            yield where, case
            yield f"{where}:tiny", _tiny(case)
    run = _fake_source_run(folder)
    for label, (path, override) in FILE_CASES.items():
        data = read_file(ROOT / path)
        key, _, value = override.format(run=run).partition("=")
        table, field = key.split(".")
        value = str((ROOT / path).parent / value) if value.startswith("..") else value
        data[table][field] = value
        case = Case.model_validate(data)  # no file check: the source run is a fake
        yield label, case
        yield f"{label}:tiny", _tiny(case)


def test_case_ids_equal_the_recorded_ones(tmp_path):
    with open(TABLE, newline="", encoding="utf-8") as f:
        recorded = {row["case"]: row["case_id"] for row in csv.DictReader(
            line for line in f if not line.startswith("#"))}
    now = dict(case_ids(tmp_path))
    assert now.keys() == recorded.keys()
    changed = {k: (recorded[k], v) for k, v in now.items() if v != recorded[k]}
    assert not changed, changed


def test_the_return_integration_enters_the_id_of_plastic_cases_only(tmp_path):
    """A plastic case's numbers depend on the return's integration, an elastic case's do not."""
    checked = {"elastic": 0, "plastic": 0}
    for label, case in cases(tmp_path):
        old = _backward_euler(case).case_id
        if case.body.hardening.law == "elastic":
            assert case.case_id == old, label
            checked["elastic"] += 1
        else:
            assert case.case_id != old, label
            checked["plastic"] += 1
    assert min(checked.values()) > 0, checked
