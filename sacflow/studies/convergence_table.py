"""Tables and plots of a convergence study (:mod:`sacflow.studies.convergence`).

Two tidy tables, written as CSV:

* the levels (:data:`LEVEL_COLUMNS`): one row per case, sequence, level and quantity, with the
  level's discretisation, its relative step ``h`` (1 at the coarsest level) and its relative
  error against the sequence's Richardson limit;
* the summary (:data:`SUMMARY_COLUMNS`): one row per case, sequence and quantity, with the
  behaviour of the last three levels (and whether every step of every level converged), the
  observed order (and that of the three before, with four levels or more), the Richardson
  limit and its uncertainty (GCI, F_s = 1.25: :mod:`sacflow.studies.richardson`), the limit
  with the formal order, the shipped discretisation's value with its relative error
  against the limit, and the finest level's step (``ratio`` is that of the finest two levels).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from sacflow.errors import SacflowError
from sacflow.studies.convergence import Discretisation, Refinement, unit_of
from sacflow.studies.richardson import (
    MONOTONE,
    Extrapolation,
    extrapolate,
    extrapolate_steps,
    relative_errors,
    step_for_error,
    value_at_step,
)

__all__ = [
    "CHECK_COLUMNS",
    "LEVEL_COLUMNS",
    "SUMMARY_COLUMNS",
    "TARGET_ERROR",
    "SequenceResult",
    "add_table_arguments",
    "advised_step",
    "check_rows",
    "count_at_step",
    "level_rows",
    "model_check",
    "plot_errors",
    "plot_profiles",
    "read_summary",
    "refuse_existing_table",
    "summary_rows",
    "write_csv",
    "write_figure",
    "write_outputs",
    "write_runs_table",
]

LEVEL_COLUMNS: tuple[str, ...] = (
    "case", "sequence", "level", "nx", "nz", "depth", "increments", "h", "converged", "quantity",
    "unit", "value", "relative_error",
)
SUMMARY_COLUMNS: tuple[str, ...] = (
    "case", "sequence", "quantity", "unit", "ratio", "levels", "converged", "behaviour", "order",
    "previous_order", "formal_order", "limit", "uncertainty", "relative_uncertainty",
    "formal_limit", "finest_value", "shipped_value", "shipped_error", "finest_step",
)
#: Summary columns added since the first recorded tables, which :func:`read_summary` accepts
#: without them.
LATER_COLUMNS: tuple[str, ...] = ("finest_step",)
#: One row per quantity of a level run to check a study's extrapolation (``--check``): the
#: run's value, the value the summary's model f∞ + C hᵖ predicts at its step, and both errors
#: against the summary's limit.
CHECK_COLUMNS: tuple[str, ...] = (
    "case", "sequence", "step", "nx", "nz", "depth", "increments", "converged", "quantity",
    "unit", "value", "predicted", "limit", "relative_uncertainty", "order", "relative_error",
    "predicted_error", "discrepancy",
)
#: Relative error the advice of a study is for (issue #32: every quantity within half a percent
#: of its converged limit).
TARGET_ERROR = 0.005
UM, MPA = 1e6, 1e-6
#: Behaviour of a sequence with a level that did not run (or a quantity it does not have).
MISSING = "missing"


@dataclass(frozen=True)
class SequenceResult:
    """The results of one sequence of one case.

    ``levels`` are the discretisations (coarse to fine), ``quantities`` the measured quantities
    of each level (None for a level that failed), ``shipped`` those of the shipped
    discretisation, ``converged`` whether every step of each level met its tolerances and
    ``profiles`` each level's residual σ11 axis profile (``x3``, ``residual_s11``), if known.
    ``steps`` are the levels' steps h (1 at the sequence's coarsest level) when they are not the
    refinement's constant ratio (``pipelines/convergence.py --steps``); empty: r⁻ᵏ.
    """

    case: str
    refinement: Refinement
    levels: Sequence[Discretisation]
    quantities: Sequence[Mapping[str, float] | None]
    shipped: Mapping[str, float] | None
    converged: Sequence[bool | None] = ()
    profiles: Sequence[Mapping[str, Sequence[float]] | None] = ()
    steps: Sequence[float] = ()

    def step(self, k: int) -> float:
        """Step h of level ``k`` (1 at the coarsest level of the refinement's ratio)."""
        return float(self.steps[k]) if self.steps else self.refinement.step_size(k)

    def names(self) -> list[str]:
        """Return the quantity names, in the order of the first level that has them."""
        for q in (*self.quantities, self.shipped):
            if q is not None:
                return list(q)
        return []

    def values(self, name: str) -> list[float]:
        """Return ``name`` on each level (NaN where missing)."""
        return [math.nan if q is None else float(q.get(name, math.nan))
                for q in self.quantities]

    def analysis(self, name: str) -> Extrapolation | None:
        """Return the Richardson analysis of ``name``, None when a level lacks it."""
        values = self.values(name)
        if not all(math.isfinite(v) for v in values):
            return None
        if self.steps:
            return extrapolate_steps(values, self.steps, self.refinement.formal_order)
        return extrapolate(values, self.refinement.ratio, self.refinement.formal_order)


def level_rows(result: SequenceResult) -> list[dict[str, Any]]:
    """Return the rows of :data:`LEVEL_COLUMNS` of one sequence."""
    rows: list[dict[str, Any]] = []
    for name in result.names():
        values = result.values(name)
        fit = result.analysis(name)
        errors = relative_errors(values, math.nan if fit is None else fit.limit)
        for k, (level, value, error) in enumerate(zip(result.levels, values, errors,
                                                      strict=True)):
            rows.append({
                "case": result.case, "sequence": result.refinement.name, "level": k,
                "nx": level.nx, "nz": level.nz, "depth": level.depth,
                "increments": level.total_increments, "h": result.step(k),
                "converged": result.converged[k] if k < len(result.converged) else "",
                "quantity": name, "unit": unit_of(name), "value": value,
                "relative_error": error,
            })
    return rows


def summary_rows(result: SequenceResult) -> list[dict[str, Any]]:
    """Return the rows of :data:`SUMMARY_COLUMNS` of one sequence."""
    rows: list[dict[str, Any]] = []
    seq = result.refinement
    for name in result.names():
        fit = result.analysis(name)
        values = result.values(name)
        shipped = math.nan if result.shipped is None else result.shipped.get(name, math.nan)
        limit = math.nan if fit is None else fit.limit
        row: dict[str, Any] = {
            "case": result.case, "sequence": seq.name, "quantity": name, "unit": unit_of(name),
            "ratio": (result.step(len(values) - 2) / result.step(len(values) - 1)
                      if result.steps else seq.ratio),
            "levels": len(values),
            "converged": all(c is True for c in result.converged) if result.converged else "",
            "behaviour": MISSING if fit is None else fit.behaviour,
            "order": math.nan if fit is None else fit.order,
            "previous_order": math.nan if fit is None else fit.previous_order,
            "formal_order": math.nan if seq.formal_order is None else seq.formal_order,
            "limit": limit,
            "uncertainty": math.nan if fit is None else fit.uncertainty,
            "formal_limit": math.nan if fit is None else fit.formal_limit,
            "finest_value": values[-1], "shipped_value": shipped,
            "shipped_error": relative_errors([shipped], limit)[0],
            "finest_step": result.step(len(values) - 1),
        }
        row["relative_uncertainty"] = (row["uncertainty"] / abs(limit)
                                       if math.isfinite(limit) and limit != 0.0 else math.nan)
        rows.append(row)
    return rows


def read_summary(path: Path) -> dict[tuple[str, str, str], dict[str, Any]]:
    """Read a summary table (:data:`SUMMARY_COLUMNS`), keyed by (case, sequence, quantity).

    Numbers come back as floats (NaN where empty), the rest as text.
    """
    if not path.is_file():
        raise SacflowError(f"no summary table {path}: give the --summary of a finished study")
    rows: dict[tuple[str, str, str], dict[str, Any]] = {}
    with path.open(newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        missing = [c for c in SUMMARY_COLUMNS
                   if c not in (reader.fieldnames or ()) and c not in LATER_COLUMNS]
        if missing:
            raise SacflowError(f"{path} is not a summary table of pipelines/convergence.py (no "
                               f"column {', '.join(missing[:3])}): give its --summary, e.g. "
                               f"data/convergence-together-summary.csv")
        for row in reader:
            parsed: dict[str, Any] = {k: _parsed(k, v) for k, v in row.items()}
            rows[(row["case"], row["sequence"], row["quantity"])] = parsed
    return rows


def _parsed(column: str, text: str | None) -> Any:
    """Parse a summary cell: text for the names, the behaviour and the flag, float otherwise."""
    if column in ("case", "sequence", "quantity", "unit", "behaviour", "converged"):
        return text or ""
    return float(text) if text else math.nan


def finest_step(row: Mapping[str, Any]) -> float:
    """Return the step of a summary row's finest level (the coarsest's is 1).

    Its ``finest_step``; in the summaries written before that column, r^−(levels − 1).
    """
    step = float(row.get("finest_step", math.nan))
    if math.isfinite(step):
        return step
    return float(row["ratio"]) ** -(float(row["levels"]) - 1.0)


#: Slack below which a refined count's quotient is taken as whole (:func:`count_at_step`).
ROUNDING_SLACK = 1e-9


def advised_step(row: Mapping[str, Any], target: float = TARGET_ERROR) -> float:
    """Step at which a summary row's model f∞ + C hᵖ is within ``target`` of its limit.

    :func:`~sacflow.studies.richardson.step_for_error` through the row's finest level (NaN for
    a row without an order or a limit, infinite when its finest level is the limit).
    """
    return step_for_error(float(row["finest_value"]), float(row["limit"]), float(row["order"]),
                          finest_step(row), target)


def count_at_step(count_at_unit_step: float, step: float) -> int:
    """Return a refined count (cells, layers, increments) at ``step``: count / step, rounded up.

    ``count_at_unit_step`` is the count at h = 1; a quotient within 1e-9 above a whole number
    (a float step such as 2/3) is that number, not the next.
    """
    return math.ceil(count_at_unit_step / step - ROUNDING_SLACK)


def model_check(fit: Mapping[str, Any], value: float, step: float) -> tuple[float, float, float]:
    """Compare a value at ``step`` with a summary row's model f∞ + C hᵖ (through its finest level).

    Return the model's value there (:func:`value_at_step`), the value's relative error against
    the row's limit and the model's; their difference is the ``discrepancy`` of
    :func:`check_rows`. ``fit`` is a row of :func:`read_summary`.
    """
    limit = float(fit["limit"])
    predicted = value_at_step(float(fit["finest_value"]), limit, float(fit["order"]),
                              finest_step(fit), step)
    error, predicted_error = relative_errors([value, predicted], limit)
    return predicted, error, predicted_error


def check_rows(case: str, sequence: str, step: float, level: Discretisation,
               record: Mapping[str, Any],
               summary: Mapping[tuple[str, str, str], Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Rows of :data:`CHECK_COLUMNS`: a run at ``step`` against the summary's prediction there.

    ``record`` is the run (its ``quantities`` and ``converged``), ``summary`` a study's summary
    (:func:`read_summary`). Only quantities whose sequence is monotone (an order and a limit)
    are compared. ``discrepancy`` = (value − predicted) / |f∞|: how far the run is from the
    model f∞ + C hᵖ through the study's finest level (:func:`value_at_step`), in the units of the
    relative errors.
    """
    rows: list[dict[str, Any]] = []
    for name, value in record["quantities"].items():
        fit = summary.get((case, sequence, name))
        if fit is None or fit["behaviour"] != MONOTONE:
            continue
        limit, order = float(fit["limit"]), float(fit["order"])
        predicted, error, predicted_error = model_check(fit, float(value), step)
        rows.append({
            "case": case, "sequence": sequence, "step": step, "nx": level.nx, "nz": level.nz,
            "depth": level.depth, "increments": level.total_increments,
            "converged": record.get("converged", ""), "quantity": name, "unit": unit_of(name),
            "value": float(value), "predicted": predicted, "limit": limit,
            "relative_uncertainty": fit["relative_uncertainty"], "order": order,
            "relative_error": error, "predicted_error": predicted_error,
            "discrepancy": error - predicted_error,
        })
    return rows


def add_table_arguments(parser: argparse.ArgumentParser) -> None:
    """Add a study script's ``--table CSV`` and ``--overwrite`` to ``parser``."""
    parser.add_argument("--table", type=Path, help="CSV to write (refused if it exists)")
    parser.add_argument("--overwrite", action="store_true", help="replace --table")


def refuse_existing_table(path: Path | None, overwrite: bool) -> None:
    """Stop a study script before it runs anything when its ``--table`` cannot be written.

    A user's file is never replaced without ``--overwrite``, and a table whose folder cannot
    be made or written would otherwise fail only after the runs: one line, nothing changed.
    """
    if path is None:
        return
    if path.exists() and not overwrite:
        raise SystemExit(f"error: {path} exists; nothing was changed. "
                         "To replace it, run again with --overwrite")
    folder = path.absolute().parent
    while not folder.exists():  # the nearest folder that exists must take the new ones
        folder = folder.parent
    if not folder.is_dir() or not os.access(folder, os.W_OK | os.X_OK):
        raise SystemExit(f"error: cannot write the table {path}: {folder} is not a folder "
                         "this user can write; nothing was run. Give another --table")


def write_runs_table(path: Path | None, rows: Sequence[Mapping[str, Any]],
                     overwrite: bool = False) -> None:
    """Write a study script's ``--table`` after its runs: one row each, the first's columns.

    Nothing when ``path`` is None. :func:`refuse_existing_table` checked the path before the
    runs; a table that appeared, or a folder that went, while they ran stops the script with
    one line (``SystemExit``), the user's file unchanged.
    """
    if path is None:
        return
    try:
        write_csv(path, rows, list(rows[0]), overwrite)
    except SacflowError as exc:
        raise SystemExit(f"error: {exc}") from None


def write_csv(path: Path, rows: Sequence[Mapping[str, Any]], columns: Sequence[str],
              overwrite: bool = False) -> None:
    """Write ``rows`` to ``path`` as CSV, atomically (a temporary file, then renamed).

    Raises
    ------
    SacflowError
        When ``path`` exists and ``overwrite`` is false (a user's file is never replaced
        without being asked), or when its folder cannot be made or written.
    """
    if path.exists() and not overwrite:
        raise SacflowError(f"{path} exists: give --overwrite to replace it, or another path")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as err:
        raise SacflowError(f"cannot write the table {path}: {err.strerror or err}") from None
    try:
        with os.fdopen(fd, "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, fieldnames=list(columns))
            writer.writeheader()
            for row in rows:
                writer.writerow({k: _cell(row.get(k, "")) for k in columns})
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_figure(figure: Figure, path: Path, overwrite: bool = False) -> None:
    """Write ``figure`` to ``path`` as PNG, whole or not at all (a temporary file, renamed).

    Raises
    ------
    SacflowError
        When ``path`` exists and ``overwrite`` is false (a user's file is never replaced
        without being asked), or when it cannot be written.
    """
    if path.exists() and not overwrite:
        raise SacflowError(f"{path} exists: give --overwrite to replace it, or another path")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        os.close(fd)
        try:
            figure.savefig(tmp, dpi=120, format="png")
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.remove(tmp)
    except OSError as err:
        raise SacflowError(f"cannot write the plot {path}: {err.strerror or err}") from None


def write_outputs(table: Path | None, rows: Sequence[Mapping[str, Any]], columns: Sequence[str],
                  plot: Path | None, figure: Callable[[], Figure],
                  overwrite: bool = False) -> None:
    """Write a scan script's ``--table`` and ``--plot``, each where given.

    The table through :func:`write_csv`, the figure through :func:`write_figure`; ``figure``
    draws it, and is called only when a plot is asked for.
    """
    if table is not None:
        write_csv(table, rows, columns, overwrite)
    if plot is not None:
        write_figure(figure(), plot, overwrite)


def _cell(value: Any) -> Any:
    """Return ``value`` as a CSV cell: floats with 10 significant digits, NaN empty."""
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.10g}"
    return value


def plot_errors(result: SequenceResult, names: Sequence[str]) -> Figure:
    """Plot |f − f∞| / |f∞| against h, log-log, of ``names`` (those with a limit), one line each.

    A dashed line of slope ``formal_order`` through the finest point of the first quantity
    shows the expected rate.
    """
    fig = Figure(figsize=(6.4, 4.8))
    ax = fig.add_subplot()
    seq = result.refinement
    h = np.array([result.step(k) for k in range(len(result.levels))])
    anchor = None
    for name in names:
        fit = result.analysis(name)
        if fit is None or not math.isfinite(fit.limit) or fit.limit == 0.0:
            continue
        errors = np.abs(relative_errors(result.values(name), fit.limit))
        shown = errors > 0.0
        if not shown.any():
            continue
        ax.loglog(h[shown], errors[shown], "o-",
                  label=f"{name} (p = {fit.order:.2f})")
        anchor = anchor or (h[shown][-1], errors[shown][-1])
    if anchor is not None and seq.formal_order is not None:
        ax.loglog(h, anchor[1] * (h / anchor[0]) ** seq.formal_order, "k--",
                  label=f"slope {seq.formal_order:g}")
    spacing = "chosen steps" if result.steps else f"ratio {seq.ratio:g}"
    ax.set_xlabel(f"h relative to the coarsest level ({seq.name}, {spacing})")
    ax.set_ylabel("|f − f∞| / |f∞|")
    ax.set_title(f"{result.case}: {seq.name}")
    if anchor is not None:
        ax.legend(fontsize="small")
    ax.grid(True, which="both", alpha=0.3)
    return fig


def plot_profiles(result: SequenceResult) -> Figure:
    """Plot the residual σ11 on the axis against depth, one line per level of ``result``."""
    fig = Figure(figsize=(6.4, 4.8))
    ax = fig.add_subplot()
    for level, profile in zip(result.levels, result.profiles, strict=False):
        if profile is None:
            continue
        ax.plot(np.asarray(profile["residual_s11"]) * MPA, np.asarray(profile["x3"]) * UM, ".-",
                label=f"{level.nx}² × {level.nz}, {'+'.join(map(str, level.increments))}")
    ax.invert_yaxis()
    ax.set_xlabel("residual σ11 on the axis [MPa]")
    ax.set_ylabel("depth x3 [µm]")
    ax.set_title(f"{result.case}: {result.refinement.name}")
    if any(profile is not None for profile in result.profiles):
        ax.legend(fontsize="small")
    ax.grid(True, alpha=0.3)
    return fig
