"""Stage :func:`track`: residual surface displacement along a rolled track (seed Fig. 18).

The track runs from the load position at the first loaded step to the load position at the last
loaded step (load > 0), along x1. Steady state (seed: reached after rolling ≈ 2 a):

* plateau = median of the profile over the second half of the track;
* the check window runs from the track start to ``end_margin`` before the track end (default:
  one Hertz contact radius, the patch of the final contact, which has not been rolled over);
* the steady-state distance is the distance from the track start to the first point of the
  window from which every point up to the end of the window lies within ``tolerance`` · |plateau|
  of the plateau (NaN if the last point of the window is outside that band).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from sacflow.compare.core import (
    CompareError,
    RunLike,
    build,
    case_name,
    case_of,
    load_run,
    nearest_inside,
    require,
    step_index,
)

__all__ = ["steady_state_distance", "track"]


def steady_state_distance(
    distance: np.ndarray,
    values: np.ndarray,
    length: float,
    tolerance: float = 0.02,
    end_margin: float = 0.0,
) -> tuple[float, float]:
    """Plateau and steady-state distance of a profile along a track (module docstring).

    Parameters
    ----------
    distance : ndarray
        Distance of each profile point from the track start, along the rolling direction [m].
    values : ndarray
        Profile values.
    length : float
        Track length [m].
    tolerance : float
        Relative half-width of the steady band around the plateau.
    end_margin : float
        Length before the track end excluded from the check [m].

    Returns
    -------
    plateau, distance : float
    """
    distance, values = np.asarray(distance, dtype=float), np.asarray(values, dtype=float)
    second_half = (distance >= 0.5 * length) & (distance <= length) & np.isfinite(values)
    if not second_half.any():
        raise CompareError("no profile point on the second half of the rolled track")
    plateau = float(np.median(values[second_half]))
    window = np.flatnonzero((distance >= 0.0) & (distance <= length - end_margin))
    if window.size == 0:
        raise CompareError(
            f"the rolled track ({length:g} m) is not longer than the end margin ({end_margin:g} m)"
        )
    window = window[np.argsort(distance[window])]
    inside = np.abs(values[window] - plateau) <= tolerance * abs(plateau)  # NaN: outside
    if inside.all():
        return plateau, float(distance[window[0]])
    last_out = int(np.flatnonzero(~inside)[-1])
    if last_out == window.size - 1:
        return plateau, np.nan
    return plateau, float(distance[window[last_out + 1]])


def track(
    run: RunLike,
    x2: float = 0.0,
    tolerance: float = 0.02,
    end_margin: float | None = None,
) -> xr.Dataset:
    """Residual surface displacement along x1 on the track at the last step, steady state.

    Parameters
    ----------
    run : Dataset or path
        A rolling run (e.g. ``rolling-smooth``).
    x2 : float
        Lateral position of the profile [m] (nearest row of cells; the track centre is 0); a
        position outside the stored cells is an error.
    tolerance : float
        Relative width of the steady band (default 2 %).
    end_margin : float, optional
        Part of the track end left out of the steady-state check [m] (default: Hertz a).

    Returns
    -------
    xarray.Dataset
        ``residual_displacement`` and ``track_distance`` along ``x1``; ``plateau``,
        ``steady_state_distance`` (and over Hertz a), ``track_start``, ``track_end``,
        ``hertz_radius``.
    """
    ds = load_run(run)
    stage = "track"
    require(ds, "load", "load_x1", "residual_displacement", stage=stage)
    index = step_index(ds, "residual_displacement", "last", stage)
    row = nearest_inside(ds, "x2", x2, "--x2", fix="(the track centre is x2 = 0)")
    profile = np.asarray(ds["residual_displacement"].isel(step=index, x2=row).values, dtype=float)
    x1 = np.asarray(ds["x1"].values, dtype=float)
    loaded = np.flatnonzero(np.asarray(ds["load"].values, dtype=float) > 0.0)
    if loaded.size == 0:
        raise CompareError(f"run {case_name(ds)!r} has no loaded step")
    start, end = (float(ds["load_x1"].values[i]) for i in (loaded[0], loaded[-1]))
    length = abs(end - start)
    cell = float(np.min(np.diff(x1))) if x1.size > 1 else 0.0
    if length < cell or length == 0.0:
        raise CompareError(
            f"run {case_name(ds)!r} has no rolled track along x1 (the load stays at "
            f"x1 = {start:g} m); use a run with a roll segment"
        )
    a = case_of(ds).hertz().a
    margin = a if end_margin is None else float(end_margin)
    distance = (x1 - start) * np.sign(end - start)
    plateau, steady = steady_state_distance(distance, profile, length, tolerance, margin)
    return build(
        {
            "residual_displacement": ("x1", profile),
            "plateau": plateau,
            "steady_state_distance": steady,
            "steady_state_distance_over_a": steady / a,
            "track_start": start,
            "track_end": end,
            "hertz_radius": a,
        },
        coords={"x1": x1, "track_distance": ("x1", distance)},
        attrs={
            "stage": stage,
            "case": case_name(ds),
            "step": int(ds["step"].values[index]),
            "profile_x2": float(ds["x2"].values[row]),
            "tolerance": float(tolerance),
            "end_margin": margin,
        },
    )
