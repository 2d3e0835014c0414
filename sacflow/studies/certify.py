"""The error of a shipped discretisation against a limit with the window refined as well.

A convergence study's `together` sequence (:mod:`sacflow.studies.convergence`) refines the
cells, the layers and the increments at a fixed contact window; its Richardson limit L_T is a
limit *at that window*. The `window` sequence widens the window at fixed cells, with the
residual stress's surface traction left out beyond the box, and its limit L_W is the limit of
an unbounded window at its grid h_w. With errors that add (f(h, W) = f* + E_h(h) + E_W(W)),
the limit of both is

    f* = L_T + (L_W − f_W),

f_W being the window sequence's first level (the shipped window, at h_w). Its uncertainty is
taken as U_T + U_W, each sequence's grid convergence index
(:mod:`sacflow.studies.richardson`), plus how far the window's error moves with the grid:
when the shipped discretisation h_s is not h_w, the change that removing the traction beyond
the box (``solver.traction_beyond_box``) makes at h_s, d_s, against the change it makes at
h_w, d_w (|d_s − d_w|, the ``transfer``), which is the error of the assumption that the
window's error does not depend on the grid, measured between the two grids.

The shipped discretisation's error is then (f_s − f*) / s for its value f_s with the
traction beyond the box removed: the error a user of the shipped case gets, the window
included. The scale s is |f*| for a quantity of its own; for a point of a profile that
changes sign (the residual σ11 on the axis) it is the profile's largest magnitude, since an
error relative to the value itself grows without bound where the profile crosses zero.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from sacflow.errors import SacflowError
from sacflow.studies.convergence_table import TARGET_ERROR
from sacflow.studies.error_parts import PartsLimit
from sacflow.studies.richardson import MONOTONE, relative_errors

__all__ = ["CERTIFIED_COLUMNS", "DEPTH_TOLERANCE", "FINEST", "LIMIT", "NO_LIMIT", "OUTSIDE",
           "PARTS", "WITHIN", "Certificate", "Level", "certify", "level_discretisation",
           "level_values", "plot_certificates", "sequence_levels", "transfer"]

#: One row per case and quantity: the shipped value (the traction beyond the box removed), the
#: `together` limit (or its finest level where it has none) and its uncertainty, the window's
#: shift L_W − f_W and its uncertainty, the transfer |d_s − d_w|, the combined limit and
#: uncertainty, the shipped error against it and the verdict.
CERTIFIED_COLUMNS: tuple[str, ...] = (
    "case", "quantity", "unit", "shipped_value", "together_limit", "together_uncertainty",
    "together_kind", "window_shift", "window_uncertainty", "transfer", "limit", "uncertainty",
    "scale", "relative_uncertainty", "error", "value_error", "verdict",
)
#: ``together_kind`` of a `together` sequence with a Richardson limit, of one without
#: (oscillating, or no order) whose finest level stands in for it, and of one without whose
#: limit the one-at-a-time sequences give (:mod:`sacflow.studies.error_parts`).
LIMIT, FINEST, PARTS = "limit", "finest", "parts"
#: Relative tolerance on a recorded level's box depth against a config's: the tables store it
#: to ten significant digits.
DEPTH_TOLERANCE = 1e-8
#: ``verdict``: within the target, outside it, or no limit to judge by (a diverging `together`
#: sequence: its finest level stands in, with no uncertainty).
WITHIN, OUTSIDE, NO_LIMIT = "within", "outside", "no limit"


@dataclass(frozen=True)
class Certificate:
    """One quantity of one case against the limit of the grid and the window refined."""

    case: str
    quantity: str
    unit: str
    shipped_value: float
    together_limit: float
    together_uncertainty: float
    together_kind: str
    window_shift: float
    window_uncertainty: float
    transfer: float
    limit: float
    uncertainty: float
    scale: float
    relative_uncertainty: float
    error: float
    value_error: float
    verdict: str

    def row(self) -> dict[str, Any]:
        """Return the certificate as a row of :data:`CERTIFIED_COLUMNS`."""
        return {name: getattr(self, name) for name in CERTIFIED_COLUMNS}


def certify(together: Mapping[str, Any], window: Mapping[str, Any], window_first: float,
            shipped_value: float, transfer: float = math.nan, scale: float | None = None,
            target: float = TARGET_ERROR, parts: PartsLimit | None = None) -> Certificate:
    """Compare the shipped value with f* = L_T + (L_W − f_W) (the module's equations).

    Parameters
    ----------
    together
        The `together` summary row of the case and quantity (:func:`read_summary`): a
        monotone one gives L_T ± U_T; otherwise ``parts`` stands in when given, else its
        finest level, with its uncertainty (half the range of an oscillating sequence; none
        for a diverging one).
    window
        The `window` summary row of the same case and quantity (the traction beyond the box
        left out); it must be monotone, with a limit L_W ± U_W.
    window_first
        That sequence's first level f_W, at the shipped window.
    shipped_value
        The shipped discretisation's value with the traction beyond the box removed.
    transfer
        |d_s − d_w|, or NaN when it was not measured.
    scale
        What the error and the uncertainty are relative to: |f*| by default, the largest
        magnitude of the profile for a point of a profile that changes sign.
    target
        The relative error the certificate is for.
    parts
        The limit the one-at-a-time sequences give (at the shipped window, the traction
        beyond the box left out, as the `together` sequence), for a `together` sequence
        without a limit of its own.

    Raises
    ------
    SacflowError
        When the window sequence has no limit (it did not converge monotonically).
    """
    if window["behaviour"] != MONOTONE or not math.isfinite(float(window["limit"])):
        raise SacflowError(f"{window['case']} {window['quantity']}: the window sequence is "
                           f"{window['behaviour']}, with no limit to correct the `together` "
                           f"limit by; widen its windows (more levels) and run it again")
    monotone = together["behaviour"] == MONOTONE and math.isfinite(float(together["limit"]))
    if monotone:
        kind, together_limit = LIMIT, float(together["limit"])
        together_uncertainty = float(together["uncertainty"])
    elif parts is not None:
        kind, together_limit, together_uncertainty = PARTS, parts.limit, parts.uncertainty
    else:
        kind, together_limit = FINEST, float(together["finest_value"])
        together_uncertainty = float(together["uncertainty"])
    shift = float(window["limit"]) - window_first
    limit = together_limit + shift
    uncertainty = (together_uncertainty + float(window["uncertainty"])
                   + (0.0 if math.isnan(transfer) else abs(transfer)))
    value_error = relative_errors([shipped_value], limit)[0]
    scale = abs(limit) if scale is None else abs(scale)
    error = (shipped_value - limit) / scale if scale != 0.0 else math.nan
    return Certificate(
        case=str(together["case"]), quantity=str(together["quantity"]),
        unit=str(together["unit"]), shipped_value=shipped_value,
        together_limit=together_limit, together_uncertainty=together_uncertainty,
        together_kind=kind, window_shift=shift,
        window_uncertainty=float(window["uncertainty"]), transfer=transfer, limit=limit,
        uncertainty=uncertainty, scale=scale,
        relative_uncertainty=uncertainty / scale if scale != 0.0 else math.nan,
        error=error, value_error=value_error,
        verdict=(NO_LIMIT if not math.isfinite(uncertainty)
                 else WITHIN if abs(error) <= target else OUTSIDE))


def transfer(shipped_on: float, shipped_off: float, first_on: float, first_off: float) -> float:
    """Return |d_s − d_w|, how much the window's error moves with the grid (module notes).

    d_s = ``shipped_on − shipped_off`` is the change removing the traction beyond the box
    makes at the shipped grid, d_w = ``first_on − first_off`` the one it makes at the window
    sequence's grid (its first level).
    """
    return abs((shipped_on - shipped_off) - (first_on - first_off))


#: A level of a levels table by what it ran: (cells per side, layers, increments).
Level = tuple[int, int, int]


def _sequence_rows(path: Path, case: str, sequence: str) -> list[dict[str, str]]:
    """Return the rows of one sequence of a levels table (``LEVEL_COLUMNS``)."""
    if not path.is_file():
        raise SacflowError(f"no levels table {path}: give the --table of a finished study")
    with path.open(newline="", encoding="utf-8") as f:
        return [r for r in csv.DictReader(f) if r["case"] == case and r["sequence"] == sequence]


def sequence_levels(path: Path, case: str, sequence: str) -> dict[Level, dict[str, float]]:
    """Return each level of one sequence of a levels table, keyed by what it ran.

    The key is (cells per side, layers, increments), the value the level's quantities (those
    with a value).

    Raises
    ------
    SacflowError
        When the table does not have that case and sequence.
    """
    out: dict[Level, dict[str, float]] = {}
    for r in _sequence_rows(path, case, sequence):
        if r["value"]:
            key = (int(r["nx"]), int(r["nz"]), int(r["increments"]))
            out.setdefault(key, {})[r["quantity"]] = float(r["value"])
    if not out:
        raise SacflowError(f"{path} has no {sequence} sequence of {case}: run "
                           f"pipelines/convergence.py --sequences {sequence} into it")
    return out


def _level_rows(path: Path, case: str, sequence: str, level: int) -> list[dict[str, str]]:
    """Return the rows of one level of a levels table, or raise a message naming the fix."""
    rows = [r for r in _sequence_rows(path, case, sequence) if r["level"] == str(level)]
    if not rows:
        raise SacflowError(f"{path} has no level {level} of {case}'s {sequence} sequence: "
                           f"give the levels table the study wrote with that sequence")
    return rows


def level_values(path: Path, case: str, sequence: str, level: int) -> dict[str, float]:
    """Return the quantities of one level of a levels table (``LEVEL_COLUMNS``): name -> value.

    Raises
    ------
    SacflowError
        When the table does not have that case, sequence and level.
    """
    return {r["quantity"]: float(r["value"]) for r in _level_rows(path, case, sequence, level)
            if r["value"]}


def level_discretisation(path: Path, case: str, sequence: str,
                         level: int) -> tuple[int, int, int, float]:
    """Return what one level of a levels table ran: (cells per side, layers, increments, depth).

    The increments are those of the whole load path, the box depth in metres.

    Raises
    ------
    SacflowError
        When the table does not have that case, sequence and level.
    """
    row = _level_rows(path, case, sequence, level)[0]
    return int(row["nx"]), int(row["nz"]), int(row["increments"]), float(row["depth"])


#: Marker of each verdict in :func:`plot_certificates`.
VERDICT_MARKERS = {WITHIN: ("o", "tab:blue"), OUTSIDE: ("s", "tab:red"),
                   NO_LIMIT: ("x", "tab:gray")}


def plot_certificates(certificates: Sequence[Certificate],
                      target: float = TARGET_ERROR) -> Figure:
    """Plot each case's errors ± the limits' uncertainties against the ±``target`` band.

    One panel per case, one row per quantity: the error relative to its scale (per cent),
    a horizontal bar of the uncertainty (none for "no limit"), the marker of its verdict, the
    band ±``target`` shaded. What a certificate table says, at a glance.
    """
    cases = list(dict.fromkeys(c.case for c in certificates))
    fig = Figure(figsize=(6.4 * max(len(cases), 1) / 1.6, 5.2), layout="constrained")
    axes = fig.subplots(1, max(len(cases), 1), sharey=True, squeeze=False)[0]
    names = list(dict.fromkeys(c.quantity for c in certificates))
    for ax, case in zip(axes, cases, strict=False):
        ax.axvspan(-100 * target, 100 * target, color="tab:green", alpha=0.12)
        ax.axvline(0.0, color="k", lw=0.6)
        for c in (c for c in certificates if c.case == case):
            marker, colour = VERDICT_MARKERS[c.verdict]
            spread = 100 * c.relative_uncertainty if np.isfinite(c.relative_uncertainty) else None
            ax.errorbar(100 * c.error, names.index(c.quantity), xerr=spread, fmt=marker,
                        color=colour, capsize=3)
        ax.set_title(case, fontsize="small")
        ax.set_xlabel("error / scale [%]")
        ax.grid(True, axis="x", alpha=0.3)
    axes[0].set_yticks(range(len(names)), names, fontsize="x-small")
    axes[0].invert_yaxis()
    return fig
