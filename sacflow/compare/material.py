"""Material-point stage: the cyclic response of a case's hardening law, before a contact run.

``sacflow compare material-point CASE.toml --amplitude A [--cycles N --mode uniaxial|shear
--control strain|stress --mean M --increments K]`` drives one material point of the case's body
(E, ν, hardening law with its optional kinematic hardening) through cycles
(:func:`sacflow.mechanics.material_point.material_cycles`) and writes the history with a plot of the
loops, the plastic strain and the backstress against the increments.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from sacflow.compare.core import CompareError
from sacflow.config.hardening_laws import hardening_from_schema, kinematic_from_schema
from sacflow.mechanics.material_point import (
    MaterialHistory,
    MaterialPointError,
    material_cycles,
)
from sacflow.mechanics.stress_measures import COMPONENTS

__all__ = ["history_dataset", "material_point", "plot_material_point"]

#: Defaults of the stage's options.
DEFAULT_CYCLES, DEFAULT_INCREMENTS = 3, 40


def material_point(case_file: Path, amplitude: float | None = None,
                         cycles: int | None = None, mode: str | None = None,
                         control: str | None = None, mean: float | None = None,
                         increments: int | None = None) -> xr.Dataset:
    """Cycle the body's material of ``case_file`` (module docstring); return the history.

    Raises
    ------
    CompareError
        For a run file or an elastic body, a missing amplitude, or a driver failure.
    """
    from pydantic import ValidationError

    from sacflow.config.parsing import format_validation_error
    from sacflow.config.schema import Body
    from sacflow.storage.case_file import read_file

    if Path(case_file).suffix != ".toml":
        raise CompareError(f"material-point takes a case file (.toml), got {case_file}")
    if amplitude is None or amplitude <= 0:
        raise CompareError("material-point needs --amplitude > 0 (a strain, or a stress in Pa "
                           "with --control stress)")
    data = read_file(Path(case_file))  # the body only: a material may carry what runs refuse
    try:
        body = Body.model_validate(data.get("body", {}))
    except ValidationError as exc:
        message = format_validation_error(exc, str(case_file)).replace("\n  ", "\n  body.")
        raise CompareError(message) from None
    if body.hardening.law == "elastic":
        raise CompareError(f"{case_file}: the body is elastic; nothing to cycle")
    cycles = DEFAULT_CYCLES if cycles is None else cycles
    increments = DEFAULT_INCREMENTS if increments is None else increments
    try:
        history = material_cycles(hardening_from_schema(body.hardening), body.E, body.nu,
                                  amplitude, cycles=cycles, increments=increments,
                                  mean=mean or 0.0, mode=mode or "uniaxial",
                                  control=control or "strain",
                                  kinematic=kinematic_from_schema(body.hardening))
    except (ValueError, MaterialPointError) as exc:
        raise CompareError(f"material-point: {exc}") from None
    result = history_dataset(history, amplitude=amplitude, mean=mean or 0.0, cycles=cycles,
                             increments=increments, E=body.E, nu=body.nu)
    result.attrs.update(stage="material-point", case=str(data.get("name", Path(case_file).stem)),
                        source=str(case_file),
                        hardening=body.hardening.model_dump_json())
    result["max_equivalent_plastic_strain"] = xr.DataArray(
        float(result["equivalent_plastic_strain"].max()), attrs={"units": "1"})
    result["max_driven_stress"] = xr.DataArray(
        float(np.abs(result["driven_stress"]).max()), attrs={"units": "Pa"})
    return result


def history_dataset(history: MaterialHistory, **attrs: float) -> xr.Dataset:
    """Return the history of :func:`~sacflow.mechanics.material_point.material_cycles` as data.

    Over ``increment`` (0 = the initial state): ``strain``, ``stress``, ``plastic_strain``,
    ``backstress`` (increment, component), ``equivalent_plastic_strain``, and the driven
    component's ``driven_strain`` and ``driven_stress``; ``attrs`` (the path's amplitude, mean,
    cycles, increments, E, ν) are kept as attributes.
    """
    tensors = {"strain": history.strain, "stress": history.stress,
               "plastic_strain": history.plastic_strain, "backstress": history.backstress}
    data: dict[str, tuple[Any, ...]] = {name: (("increment", "component"), value,
                   {"units": "Pa" if "stress" in name else "1"})
            for name, value in tensors.items()}
    data["equivalent_plastic_strain"] = ("increment", history.equivalent_plastic_strain,
                                         {"units": "1"})
    data["driven_strain"] = ("increment", history.strain[:, history.driven], {"units": "1"})
    data["driven_stress"] = ("increment", history.stress[:, history.driven], {"units": "Pa"})
    n = history.strain.shape[0]
    ds = xr.Dataset(data, coords={"increment": np.arange(n), "component": list(COMPONENTS)})
    ds.attrs.update(attrs, mode=history.mode, control=history.control,
                    driven_component=COMPONENTS[history.driven], Conventions="CF-1.10",
                    title=f"material point, {history.mode} {history.control}-controlled cycles")
    return ds


def plot_material_point(result: xr.Dataset) -> Figure:
    """Stress–strain loops of the driven component; εp and backstress over the increments."""
    fig = Figure(figsize=(11.0, 4.4), layout="constrained")
    left, right = fig.subplots(1, 2)
    comp = result.attrs["driven_component"]
    left.plot(result["driven_strain"] * 100, result["driven_stress"] * 1e-6, ".-", ms=2)
    left.set(xlabel=f"ε{comp} [%]", ylabel=f"σ{comp} [MPa]",
             title=f"{result.attrs['mode']}, {result.attrs['control']} control")
    right.plot(result["increment"], result["equivalent_plastic_strain"] * 100, label="p [%]")
    right.set(xlabel="increment", ylabel="equivalent plastic strain p [%]")
    twin = right.twinx()
    twin.plot(result["increment"], result["backstress"].sel(component=comp) * 1e-6, "C1",
              label=f"X{comp}")
    twin.set_ylabel(f"backstress X{comp} [MPa]")
    for ax in (left, right):
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"{result.attrs.get('case', '')}: material point")
    return fig
