"""Fatigue stage: Dang Van and Crossland indices over the stress history of one run.

The stress history of a material point (a cuboid of the body grid) is the *total* stress
(contact + residual, run variable ``stress``) at every step of the run: loading, the rolling
pass, unloading. In a rolling run the body grid is fixed to the material while the load moves,
so a cuboid's stored values over the steps are exactly the history it lived through. Each
cuboid's history goes through :func:`sacflow.mechanics.fatigue_criteria.fatigue_indices`
(minimum ball of the deviatoric path, exact), see that module for the criteria.

What the run must store: the ``stress`` field (the default of ``output.fields``) at every step
(``output.volume_every = 1``); a run that stores it every k > 1 steps, or not at all, or that
is not finished, is refused with the fix. The volume is read in blocks of ``x1`` rows, at most
``max_memory`` bytes of history at a time, so a long run never needs its whole history in
memory.

Material constants: fully reversed bending and torsion endurance limits. The defaults
(:data:`DEFAULT_LIMITS`) are those stated in :data:`DEFAULT_LIMITS_SOURCE`; give the limits of
your own material (``bending_limit``, ``torsion_limit``; ``--bending-limit``,
``--torsion-limit``) for any quantitative use.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sacflow.compare.core import CompareError, RunLike, build, case_name, case_of, require
from sacflow.compare.load_cycle import AUTOMATIC, LoadCycle, load_cycle
from sacflow.mechanics.fatigue_criteria import EnduranceLimits, fatigue_indices
from sacflow.solver.state import COMPONENTS
from sacflow.storage.run_reader import RunFileError, not_a_run, open_run, run_info

__all__ = [
    "DEFAULT_LIMITS",
    "DEFAULT_LIMITS_SOURCE",
    "DEFAULT_MAX_MEMORY",
    "ISO_281_FATIGUE_LIMIT",
    "TRACK_MARGIN_RADII",
    "track_middle",
    "fatigue",
    "history_blocks",
]

#: ISO 281:2007's fatigue-limit stress of bearing steel, a von Mises stress [Pa]: "The fatigue
#: limit used in ISO Standard 281:2007 is a Von Mises stress of 900 MPa (130,500 psi), which
#: corresponds to a maximum Hertz contact stress of 1500 MPa" (E. V. Zaretsky, "In search of a
#: fatigue limit: a critique of ISO Standard 281:2007", Tribology & Lubrication Technology,
#: STLE, August 2010, p. 30).
ISO_281_FATIGUE_LIMIT = 900e6
#: Default limits: ``f₋₁`` = the ISO 281 value read as the fully reversed uniaxial limit, and
#: ``t₋₁ = f₋₁/√3``, the von Mises ratio (Crossland's pressure term then vanishes, α = 0, and
#: Dang Van's a = 3 (1/√3 − ½) = 0.232). Order-of-magnitude values for comparing cases, not
#: the limits of a particular heat; give those of your steel for absolute margins.
DEFAULT_LIMITS = EnduranceLimits(bending=ISO_281_FATIGUE_LIMIT,
                                 torsion=ISO_281_FATIGUE_LIMIT / math.sqrt(3.0))
#: Where the defaults come from (stored with every result).
DEFAULT_LIMITS_SOURCE = (
    "f-1 = 900 MPa: the von Mises fatigue-limit stress of bearing steel in ISO 281:2007 "
    "(Zaretsky, Tribol. Lubr. Technol., Aug. 2010), read as the fully reversed uniaxial limit; "
    "t-1 = f-1/sqrt(3) (von Mises ratio)"
)
#: Bytes of stress history read at once (one block of x1 rows; 6 float64 per cuboid and step).
DEFAULT_MAX_MEMORY = 256 * 2**20
#: Bytes per cuboid and step of the history (6 components, float64).
_BYTES_PER_VALUE = 8 * len(COMPONENTS)

#: The middle of a rolled track: cuboids more than this many Hertz radii from both of its ends
#: (the load's position at the first and the last loaded step), which the whole contact passed.
TRACK_MARGIN_RADII = 2.0

_STAGE = "fatigue"


def fatigue(
    run: RunLike,
    bending_limit: float | None = None,
    torsion_limit: float | None = None,
    max_memory: int = DEFAULT_MAX_MEMORY,
    progress: bool = False,
    cycle: str = AUTOMATIC,
) -> xr.Dataset:
    """Dang Van and Crossland index fields of a run on one load cycle, and where their maxima sit.

    Parameters
    ----------
    run : Dataset or path
        A finished run storing ``stress`` at every step.
    bending_limit, torsion_limit : float, optional
        ``f₋₁`` and ``t₋₁`` [Pa], fully reversed endurance limits (amplitudes); default
        :data:`DEFAULT_LIMITS`. Both or neither.
    max_memory : int
        Bytes of stress history held at once (the volume is processed in blocks of x1 rows).
    progress : bool
        Show a progress bar over the blocks.
    cycle : str
        The load cycle (:mod:`sacflow.compare.load_cycle`): ``"auto"`` (default: the last
        complete pass of a repeated-rolling run, else the whole history), ``"all"``, or a range
        of step numbers ``"first:last"``.

    Returns
    -------
    xarray.Dataset
        Fields over (x1, x2, x3): ``dang_van``, ``crossland``, ``sqrt_j2_amplitude``,
        ``hydrostatic_max``, ``dang_van_step``; scalars ``dang_van_max`` with
        ``dang_van_max_x1``, ``_x2``, ``_depth``, ``_step`` and the same for ``crossland_max``.
        Attributes: the limits, the constants a, b, α, β derived from them and their source,
        the cycle (``cycle``, ``cycle_first_step``, ``cycle_last_step``).

    Raises
    ------
    CompareError
        The run is not finished, does not store ``stress``, or stores it every k > 1 steps.
    """
    limits, source = _limits(bending_limit, torsion_limit)
    ds, close = _open(run)
    try:
        _check_history(ds)
        chosen = load_cycle(ds, cycle)
        fields = _indices(ds.isel(step=chosen.steps), limits, max_memory, progress)
        return _result(ds, fields, limits, source, chosen)
    finally:
        if close:
            ds.close()


def _limits(bending: float | None, torsion: float | None) -> tuple[EnduranceLimits, str]:
    if bending is None and torsion is None:
        return DEFAULT_LIMITS, DEFAULT_LIMITS_SOURCE
    if bending is None or torsion is None:
        raise CompareError(
            "give both --bending-limit and --torsion-limit (the criteria need their ratio), "
            "or neither for the bearing-steel defaults"
        )
    try:
        return EnduranceLimits(bending=float(bending), torsion=float(torsion)), "given"
    except ValueError as exc:
        raise CompareError(str(exc).replace("EnduranceLimits.", "endurance limit ")) from None


def _open(run: RunLike) -> tuple[xr.Dataset, bool]:
    """Return the run, opened lazily when given a path, and whether the caller closes it."""
    if isinstance(run, xr.Dataset):
        return run, False
    path = Path(run)
    info = run_info(path)
    if not info.exists:
        raise CompareError(f"{path}: no such run file")
    if info.unreadable:
        raise CompareError(not_a_run(path, info.problem))
    if not info.complete:
        raise CompareError(
            f"{path}: the run is not finished ({info.steps} steps stored); the fatigue stage "
            "needs the whole load cycle: finish it with `sacflow run` on its case"
        )
    try:
        ds = open_run(path, lazy=True)
    except RunFileError as exc:  # damaged, or not a run: what it is, what to do
        raise CompareError(str(exc)) from None
    ds.attrs.setdefault("source", str(path))
    return ds, True


def _check_history(ds: xr.Dataset) -> None:
    """Refuse a run whose stress history is incomplete, naming the fix."""
    if "case" not in ds.attrs or "step" not in ds.dims:
        raise CompareError("not a sacflow run (no 'case' attribute or no 'step' dimension)")
    require(ds, "stress", stage=_STAGE)
    output = case_of(ds).output
    if output.volume_every != 1 and "stress" not in output.every_step:
        raise CompareError(
            f"run {case_name(ds)!r} stores the volume fields every {output.volume_every} steps; "
            "the fatigue stage needs the stress at every step of the load cycle: set [output] "
            "volume_every = 1 (or every_step = [\"stress\"]) in the case and run it again"
        )
    if ds.sizes["step"] < 2:
        raise CompareError(f"run {case_name(ds)!r} has {ds.sizes['step']} step: no history")


def history_blocks(shape: tuple[int, int, int, int], max_memory: int) -> list[slice]:
    """Blocks of x1 rows whose stress history fits in ``max_memory`` bytes (one row at least).

    Parameters
    ----------
    shape : (steps, n1, n2, n3)
        Size of the history.
    max_memory : int
        Bytes per block.
    """
    steps, n1, n2, n3 = shape
    row = steps * n2 * n3 * _BYTES_PER_VALUE
    rows = max(1, min(n1, int(max_memory // max(row, 1))))
    return [slice(i, min(i + rows, n1)) for i in range(0, n1, rows)]


def _indices(
    ds: xr.Dataset, limits: EnduranceLimits, max_memory: int, progress: bool
) -> dict[str, np.ndarray]:
    stress = ds["stress"].transpose("step", "x1", "x2", "x3", "component")
    steps, n1, n2, n3, _ = stress.shape
    names = ("dang_van", "crossland", "sqrt_j2_amplitude", "hydrostatic_max", "dang_van_step")
    out = {name: np.empty((n1, n2, n3)) for name in names}
    blocks = history_blocks((steps, n1, n2, n3), max_memory)
    for block in _progress(blocks, progress):
        history = np.asarray(stress.isel(x1=block).values, dtype=float)
        bad = ~np.isfinite(history).reshape(steps, -1).all(axis=1)
        if bad.any():
            first = int(ds["step"].values[int(np.flatnonzero(bad)[0])])
            raise CompareError(
                f"run {case_name(ds)!r} has no stress at step {first} ({int(bad.sum())} steps "
                "without it); the fatigue stage needs it at every step (output.volume_every = 1)"
            )
        dv, cr = fatigue_indices(history, limits, time_axis=0)
        out["dang_van"][block] = dv.index
        out["crossland"][block] = cr.index
        out["sqrt_j2_amplitude"][block] = cr.sqrt_j2a
        out["hydrostatic_max"][block] = cr.p_max
        out["dang_van_step"][block] = ds["step"].values[dv.time_index]
    return out


def _progress(blocks: list[slice], show: bool) -> Any:
    if not show or len(blocks) < 2:
        return blocks
    from tqdm import tqdm

    return tqdm(blocks, desc="fatigue", unit="block")


def _argmax(field: np.ndarray, ds: xr.Dataset) -> tuple[float, float, float, float]:
    i, j, k = np.unravel_index(int(np.argmax(field)), field.shape)
    return (float(field[i, j, k]), float(ds["x1"][i]), float(ds["x2"][j]), float(ds["x3"][k]))


def _result(
    ds: xr.Dataset, fields: dict[str, np.ndarray], limits: EnduranceLimits, source: str,
    chosen: LoadCycle,
) -> xr.Dataset:
    dims = ("x1", "x2", "x3")
    data: dict[str, Any] = {name: (dims, value) for name, value in fields.items()}
    for name in ("dang_van", "crossland"):
        value, x1, x2, x3 = _argmax(fields[name], ds)
        data |= {f"{name}_max": value, f"{name}_max_x1": x1, f"{name}_max_x2": x2,
                 f"{name}_max_depth": x3}
    i, j, k = np.unravel_index(int(np.argmax(fields["dang_van"])), fields["dang_van"].shape)
    data["dang_van_max_step"] = float(fields["dang_van_step"][i, j, k])
    case = case_of(ds)
    middle = track_middle(ds, TRACK_MARGIN_RADII * case.hertz().a)
    for name in ("dang_van", "crossland"):
        inside = np.where(middle[:, :, None], fields[name], -np.inf)
        value, x1, x2, x3 = _argmax(inside, ds) if middle.any() else (np.nan,) * 4
        data |= {f"{name}_track_max": value, f"{name}_track_max_x1": x1,
                 f"{name}_track_max_x2": x2, f"{name}_track_max_depth": x3}
    coords = {d: ds[d].values for d in dims}
    roll = [s for s in case.load_path if s.kind == "roll"]
    result = build(
        data,
        coords=coords,
        attrs={
            "stage": _STAGE,
            "case": case_name(ds),
            "source": ds.attrs.get("source"),
            "case_id": ds.attrs.get("case_id"),
            "bending_limit": limits.bending,
            "torsion_limit": limits.torsion,
            "dang_van_a": limits.dang_van_a,
            "dang_van_b": limits.dang_van_b,
            "crossland_alpha": limits.crossland_alpha,
            "crossland_beta": limits.crossland_beta,
            "limits_source": source,
            "history_steps": int(chosen.positions.size),
            "cycle": chosen.description,
            "cycle_first_step": int(ds["step"].values[chosen.positions[0]]),
            "cycle_last_step": int(ds["step"].values[chosen.positions[-1]]),
            "rolling": bool(roll),
            "track_x2": _track_x2(ds),
            "track_margin": TRACK_MARGIN_RADII * case.hertz().a,
        },
    )
    for d in dims:
        result[d].attrs.update(ds[d].attrs)
    return result


def track_middle(ds: xr.Dataset, margin: float) -> np.ndarray:
    """Return the (x1, x2) cells farther than ``margin`` from both ends of the rolled track.

    Along the track (the line from the load's first to its last loaded position) only; all
    False when the load does not move by more than twice the margin.
    """
    load = np.asarray(ds["load"].values, dtype=float)
    loaded = np.flatnonzero(load > 0.0)
    shape = (ds.sizes["x1"], ds.sizes["x2"])
    if loaded.size == 0 or "load_x1" not in ds.variables:
        return np.zeros(shape, dtype=bool)
    ends = [np.array([float(ds["load_x1"].values[i]), float(ds["load_x2"].values[i])])
            for i in (loaded[0], loaded[-1])]
    length = float(np.linalg.norm(ends[1] - ends[0]))
    if length <= 2.0 * margin:
        return np.zeros(shape, dtype=bool)
    direction = (ends[1] - ends[0]) / length
    x1, x2 = np.meshgrid(ds["x1"].values, ds["x2"].values, indexing="ij")
    along = (x1 - ends[0][0]) * direction[0] + (x2 - ends[0][1]) * direction[1]
    return (along >= margin) & (along <= length - margin)


def _track_x2(ds: xr.Dataset) -> float:
    """x2 of the load during the run (the track centre of a roll along x1): its median."""
    if "load_x2" not in ds.variables:
        return 0.0
    values = np.asarray(ds["load_x2"].values, dtype=float)
    values = values[np.isfinite(values)]
    return float(np.median(values)) if values.size else 0.0
