"""Plots of the comparison results, one function per stage: result Dataset -> Figure.

Figures are built with :class:`matplotlib.figure.Figure` directly (Agg rendering, no pyplot):
nothing changes the backend or the global state of a notebook, and nothing is left open.
Axes are labelled with units (lengths in µm or nm, stresses in MPa, pressures in GPa), every
figure has a legend and a title with the case name.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from sacflow.compare.material import plot_material_point
from sacflow.compare.melan_bound import plot_melan
from sacflow.compare.pass_history import plot_passes
from sacflow.mechanics.hertz import hertz_contact, hertz_pressure

__all__ = ["PLOTS", "display_scale", "plot"]

UM, MPA, GPA = 1e6, 1e-6, 1e-9


def display_scale(units: str, values) -> tuple[float, str]:
    """Display factor and unit for SI ``units``, chosen from the size of ``values``."""
    finite = np.abs(np.asarray(values, dtype=float))
    finite = finite[np.isfinite(finite)]
    big = float(finite.max()) if finite.size else 0.0
    if units == "Pa":
        return (GPA, "GPa") if big >= 1e9 else (MPA, "MPa")
    if units == "m":
        return (1e9, "nm") if 0 < big < 1e-6 else (UM, "µm")
    if units == "N":
        return (1e3, "mN") if 0 < big < 1.0 else (1.0, "N")
    return 1.0, units


def _figure(result: xr.Dataset, what: str, panels: tuple[int, int] = (1, 1), size=(7.0, 4.5)):
    fig = Figure(figsize=size, layout="constrained")
    axes = fig.subplots(*panels, squeeze=False)
    fig.suptitle(f"{result.attrs.get('case', 'run')}: {what}")
    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
    return fig, axes


def _label(reference: str) -> str:
    """Return a short label for a reference: its file name."""
    return Path(reference).name or reference


def _note(ax, text: str) -> None:
    ax.text(
        0.02,
        0.02,
        text,
        transform=ax.transAxes,
        fontsize=8,
        va="bottom",
        ha="left",
        bbox={"boxstyle": "round", "fc": "white", "alpha": 0.8, "lw": 0.5},
    )


def plot_hertz_check(result: xr.Dataset) -> Figure:
    """Load–approach vs Hertz (left), pressure along x1 at max load vs Hertz (right)."""
    fig, axes = _figure(result, "Hertz check", (1, 2), (10.0, 4.2))
    left, right = axes[0]
    fw, wu = display_scale("N", result["load"])
    fd, du = display_scale("m", result["approach_hertz"])
    loads = np.linspace(0.0, result.attrs["load_max"], 101)
    radius, e_star = result.attrs["effective_radius"], result.attrs["e_star"]
    curve = [hertz_contact(w, radius, e_star).approach for w in loads]
    left.plot(np.asarray(curve) * fd, loads * fw, "k-", label="Hertz")
    left.plot(result["approach"] * fd, result["load"] * fw, "o", label="run")
    left.set(xlabel=f"approach δ [{du}]", ylabel=f"load W [{wu}]", title="load vs approach")
    left.legend()
    c1 = result.attrs["load_x1"]
    x = (result["x1"].values - c1) * UM
    a, p0 = float(result["contact_radius_hertz"]), float(result["p0_hertz"])
    fine = np.linspace(x.min(), x.max(), 400) / UM
    dy = result.attrs["profile_x2"] - result.attrs["load_x2"]
    right.plot(fine * UM, hertz_pressure(np.hypot(fine, dy), a, p0) * GPA, "k-", label="Hertz")
    right.step(x, result["pressure"] * GPA, where="mid", label="run (cells)")
    right.plot(x, result["pressure"] * GPA, ".", color="C0")
    right.set(
        xlabel="x1 − load x1 [µm]",
        ylabel="pressure [GPa]",
        title=f"pressure at max load (x2 = {result.attrs['profile_x2'] * UM:.3g} µm)",
    )
    right.legend()
    _note(
        right,
        f"p0 error {float(result['p0_error']):+.2%}\n"
        f"a error {float(result['contact_radius_error']):+.2%}\n"
        f"δ error {float(result['approach_max_error']):+.2%}",
    )
    return fig


def plot_load_approach(result: xr.Dataset) -> Figure:
    """Plot the loading, unloading and shifted unloading branches with the elastic Hertz curve."""
    fig, axes = _figure(result, "load vs approach")
    ax = axes[0, 0]
    fw, wu = display_scale("N", result["hertz_load"])
    fd, du = display_scale("m", result["hertz_approach"])
    ax.plot(result["hertz_approach"] * fd, result["hertz_load"] * fw, "k-", label="Hertz (elastic)")
    branch = result["branch"].values
    load, approach = result["load"].values, result["approach"].values
    top = int(np.flatnonzero(result["step"].values == result.attrs["step_max_load"])[0])
    loading = np.flatnonzero(branch == "loading")
    ax.plot(
        np.r_[0.0, approach[loading]] * fd,
        np.r_[0.0, load[loading]] * fw,
        "o-",
        ms=3,
        label="loading",
    )
    unloading = np.flatnonzero(branch == "unloading")
    unloading = unloading[unloading > top]
    if unloading.size:
        ax.plot(
            np.r_[approach[top], approach[unloading]] * fd,
            np.r_[load[top], load[unloading]] * fw,
            "s-",
            ms=3,
            label="unloading",
        )
        shifted = result["approach_shifted"].values
        ax.plot(
            np.r_[result["approach_max_hertz"].item(), shifted[unloading]] * fd,
            np.r_[load[top], load[unloading]] * fw,
            "s--",
            ms=3,
            mfc="none",
            label=f"unloading shifted by {float(result['unloading_shift']) * fd:.3g} {du}",
        )
    if "reference_load" in result:
        ax.plot(
            result["reference_approach"] * fd,
            result["reference_load"] * fw,
            "x",
            color="0.4",
            label=f"reference ({_label(result.attrs.get('reference', ''))})",
        )
    ax.set(xlabel=f"rigid-body approach δ [{du}]", ylabel=f"load W [{wu}]")
    ax.legend(loc="upper left")
    return fig


def plot_indentation(result: xr.Dataset) -> Figure:
    """Rows: profile offsets; columns: εp [%] and residual σ11, σ33 [MPa] versus depth."""
    n = result.sizes["offset"]
    fig, axes = _figure(
        result, "plastic strain and residual stress vs depth", (n, 2), (10.0, 3.2 * n + 0.6)
    )
    depth = result["x3"].values * UM
    styles = {"max_load": ("--", "at max load"), "last": ("-", "after unloading")}
    for row, offset in enumerate(result["offset"].values):
        left, right = axes[row]
        where = "on the axis" if offset == 0 else f"{offset * UM:.3g} µm off axis"
        for when, (style, label) in styles.items():
            at = result.sel(when=when, offset=offset)
            left.plot(
                depth, at["equivalent_plastic_strain"] * 100, style, color="C0", label=f"εp {label}"
            )
            right.plot(
                depth, at["residual_stress_11"] * MPA, style, color="C1", label=f"σ11 {label}"
            )
            right.plot(
                depth, at["residual_stress_33"] * MPA, style, color="C2", label=f"σ33 {label}"
            )
        left.set(
            xlabel="depth x3 [µm]",
            ylabel="equivalent plastic strain [%]",
            title=f"plastic strain {where}",
        )
        right.set(
            xlabel="depth x3 [µm]", ylabel="residual stress [MPa]", title=f"residual stress {where}"
        )
        left.legend(fontsize=8)
        right.legend(fontsize=8)
    _note(
        axes[0, 0],
        f"max εp {float(result['max_plastic_strain']):.3%} at "
        f"x3 = {float(result['max_plastic_strain_depth']) * UM:.3g} µm\n"
        f"print depth {float(result['print_depth']) * 1e9:.3g} nm",
    )
    return fig


def plot_elastic_vs_plastic(result: xr.Dataset) -> Figure:
    """Pressure profiles of the elastic and the elastic-plastic run at max load."""
    fig, axes = _figure(result, "contact pressure, elastic vs elastic-plastic")
    ax = axes[0, 0]
    x = result["x1"].values * UM
    for name, label, color in (
        ("elastic", result.attrs["case_elastic"], "C0"),
        ("plastic", result.attrs["case_plastic"], "C3"),
    ):
        ax.plot(x, result[f"pressure_{name}"] * GPA, "-", color=color, label=label)
        ax.plot(
            float(result[f"peak_{name}_x1"]) * UM,
            float(result[f"peak_{name}"]) * GPA,
            "v",
            color=color,
            label=f"peak {float(result[f'peak_{name}']) * GPA:.3g} GPa",
        )
    ax.set(xlabel="x1 [µm]", ylabel="pressure [GPa]")
    ax.legend()
    _note(ax, f"elastic / elastic-plastic peak = {float(result['peak_ratio']):.3f}")
    return fig


def plot_vertical_vs_rolling(result: xr.Dataset) -> Figure:
    """Residual σ11 along x1 at the chosen depth after vertical loading and after rolling."""
    depth = result.attrs["depth_vertical"] * UM
    fig, axes = _figure(result, f"residual σ11 at x3 ≈ {depth:.3g} µm")
    ax = axes[0, 0]
    c = result.attrs["centre"]
    for name, color in (("vertical", "C0"), ("rolling", "C3")):
        x = (result[f"x1_{name}"].values - c) * UM
        ax.plot(
            x,
            result[f"residual_stress_11_{name}"] * MPA,
            "-",
            color=color,
            label=f"{name} ({result.attrs[f'case_{name}']})",
        )
        ax.plot(
            (float(result[f"min_{name}_x1"]) - c) * UM,
            float(result[f"min_{name}"]) * MPA,
            "v",
            color=color,
            label=f"min {float(result[f'min_{name}']) * MPA:.4g} MPa",
        )
    ax.set(xlabel=f"x1 − {c * UM:.4g} µm [µm]", ylabel="residual stress σ11 [MPa]")
    ax.legend()
    _note(
        ax,
        f"min ratio rolling / vertical {float(result['min_ratio']):.3f}\n"
        f"asymmetry {float(result['asymmetry_vertical']):.3f} (vertical), "
        f"{float(result['asymmetry_rolling']):.3f} (rolling)",
    )
    return fig


def plot_track(result: xr.Dataset) -> Figure:
    """Residual surface displacement along the track, plateau band and steady-state point."""
    fig, axes = _figure(result, "residual surface displacement on the track")
    ax = axes[0, 0]
    end = float(result["track_end"])
    fu, unit = display_scale("m", result["residual_displacement"])
    x = (result["x1"].values - end) * UM
    ax.plot(x, result["residual_displacement"] * fu, "-", label="residual displacement")
    plateau, tol = float(result["plateau"]), result.attrs["tolerance"]
    ax.axhspan(
        (plateau - tol * abs(plateau)) * fu,
        (plateau + tol * abs(plateau)) * fu,
        color="C2",
        alpha=0.2,
        label=f"plateau ± {tol:.0%}",
    )
    start = (float(result["track_start"]) - end) * UM
    ax.axvline(start, color="0.5", ls=":", label="track start")
    steady = float(result["steady_state_distance"])
    if np.isfinite(steady):
        direction = np.sign(end - float(result["track_start"])) or 1.0
        ax.axvline(
            start + direction * steady * UM,
            color="C3",
            ls="--",
            label=f"steady after {steady * UM:.4g} µm "
            f"({float(result['steady_state_distance_over_a']):.2f} a)",
        )
    ax.set(xlabel="x1 − x1 at unloading [µm]", ylabel=f"residual displacement [{unit}]")
    ax.legend()
    return fig


def plot_residual_map(result: xr.Dataset) -> Figure:
    """Map of the residual stress component in the chosen plane, minimum marked."""
    comp, depth = result.attrs["component"], result.attrs["depth"] * UM
    fig, axes = _figure(result, f"residual σ{comp} at x3 = {depth:.3g} µm", size=(6.5, 5.5))
    ax = axes[0, 0]
    ax.grid(False)
    values = result["residual_stress_map"].transpose("x2", "x1").values * MPA
    mesh = ax.pcolormesh(
        result["x1"] * UM,
        result["x2"] * UM,
        values,
        shading="nearest",
        cmap="RdBu_r",
        vmin=-np.nanmax(np.abs(values)),
        vmax=np.nanmax(np.abs(values)),
    )
    fig.colorbar(mesh, ax=ax, label=f"residual σ{comp} [MPa]")
    ax.plot(
        float(result["map_min_x1"]) * UM,
        float(result["map_min_x2"]) * UM,
        "kv",
        label=f"min {float(result['map_min']) * MPA:.4g} MPa",
    )
    ax.set(xlabel="x1 [µm]", ylabel="x2 [µm]", aspect="equal")
    ax.legend(loc="upper right")
    return fig


def plot_campaign_summary(result: xr.Dataset, result_name: str = "max_plastic_strain") -> Figure:
    """``result_name`` versus the first swept parameter (one line per value of the second)."""
    if result_name not in result.data_vars:
        choices = ", ".join(map(str, result.data_vars))
        raise KeyError(f"no result {result_name!r}; choose one of {choices}")
    params = result.attrs.get("parameters", "").split()
    meta = result[result_name].attrs
    fy, uy = display_scale(meta.get("units", "1"), result[result_name])
    fig, axes = _figure(result, f"{meta.get('long_name', result_name)}")
    ax = axes[0, 0]
    y = result[result_name].values * fy
    if not params:
        ax.plot(np.arange(result.sizes["case"]), y, "o", label=result_name)
        ax.set_xticks(np.arange(result.sizes["case"]), result["case"].values, rotation=30)
        ax.set_xlabel("case")
    else:
        first = result[params[0]].values
        numeric = np.issubdtype(first.dtype, np.number)
        x = first if numeric else np.unique(first, return_inverse=True)[1]
        groups = result[params[1]].values if len(params) > 1 else np.zeros(len(x))
        for value in dict.fromkeys(groups.tolist()):
            sel = groups == value
            order = np.argsort(x[sel])
            label = f"{params[1]} = {value}" if len(params) > 1 else result_name
            ax.plot(x[sel][order], y[sel][order], "o-", label=label)
        if not numeric:
            ax.set_xticks(np.arange(len(np.unique(first))), np.unique(first))
        ax.set_xlabel(params[0])
    ax.set_ylabel(f"{result_name} [{uy}]")
    ax.legend(fontsize=8)
    return fig


def plot_case_vs_reference(result: xr.Dataset) -> Figure:
    """Run and reference along the one interpolated coordinate, else a parity plot."""
    dims = result.attrs.get("interpolated_dims", "").split()
    units = result["reference_value"].attrs.get("units", "1")
    both = np.r_[result["reference_value"].values, result["run_value"].values]
    fv, uv = display_scale(units, both)
    var = result.attrs["variable"]
    if len(dims) == 1:
        fig, axes = _figure(result, f"{var} vs reference", (2, 1), (7.0, 6.0))
        top, bottom = axes[:, 0]
        bottom.sharex(top)
        fx, ux = display_scale(result[dims[0]].attrs.get("units", "1"), result[dims[0]])
        order = np.argsort(result[dims[0]].values)
        x = result[dims[0]].values[order] * fx
        top.plot(
            x,
            result["reference_value"].values[order] * fv,
            "o",
            mfc="none",
            label=f"reference ({_label(result.attrs['reference'])})",
        )
        top.plot(x, result["run_value"].values[order] * fv, "-", label="run (interpolated)")
        top.set(ylabel=f"{var} [{uv}]")
        fd, ud = display_scale(units, result["difference"])
        bottom.plot(x, result["difference"].values[order] * fd, "o-", ms=3, label="run − reference")
        bottom.axhline(0.0, color="k", lw=0.8)
        diff = result["difference"].values * fd
        if np.isfinite(diff).any():  # keep zero in view: the size of the difference shows
            low, high = min(0.0, np.nanmin(diff)), max(0.0, np.nanmax(diff))
            pad = 0.1 * (high - low) or 1.0
            bottom.set_ylim(low - pad, high + pad)
        bottom.set(xlabel=f"{dims[0]} [{ux}]", ylabel=f"difference [{ud}]")
        top.legend()
        bottom.legend()
    else:
        fig, axes = _figure(result, f"{var} vs reference", size=(5.5, 5.0))
        ax = axes[0, 0]
        ref, run = result["reference_value"] * fv, result["run_value"] * fv
        ax.plot(ref, run, "o", ms=3, label="points")
        lims = [np.nanmin(both) * fv, np.nanmax(both) * fv]
        ax.plot(lims, lims, "k-", lw=0.8, label="run = reference")
        ax.set(xlabel=f"reference {var} [{uv}]", ylabel=f"run {var} [{uv}]")
        ax.legend()
        bottom = ax
    fd, ud = display_scale(units, result["difference"])
    _note(
        bottom,
        f"max |diff| {float(result['max_abs_difference']) * fd:.4g} {ud}, "
        f"RMS {float(result['rms_difference']) * fd:.4g} {ud}",
    )
    return fig


def _index_map(fig, ax, field: xr.DataArray, x: str, y: str, top: float, title: str) -> None:
    """One Dang Van index map (µm axes, depth downwards when ``y`` is x3)."""
    ax.grid(False)
    mesh = ax.pcolormesh(field[x] * UM, field[y] * UM, field.transpose(y, x).values,
                         shading="nearest", cmap="magma", vmin=0.0, vmax=top)
    fig.colorbar(mesh, ax=ax, label="Dang Van index")
    ax.set(xlabel=f"{x} [µm]", ylabel=f"{y} [µm]", title=title)
    if y == "x3":
        ax.invert_yaxis()


def plot_fatigue(result: xr.Dataset) -> Figure:
    """Dang Van index: plane through the maximum, sections through it and along the track."""
    fig, axes = _figure(result, "Dang Van index", (1, 3), (15.0, 4.4))
    dv = result["dang_van"]
    top = float(dv.max())
    at = {k: float(result[f"dang_van_max_{k}"]) for k in ("x1", "x2", "depth")}
    track = float(result.attrs.get("track_x2", 0.0))
    plane = dv.sel(x3=at["depth"], method="nearest")
    _index_map(fig, axes[0, 0], plane, "x1", "x2", top, f"plane x3 = {at['depth'] * UM:.3g} µm")
    _index_map(fig, axes[0, 1], dv.sel(x2=at["x2"], method="nearest"), "x1", "x3", top,
               f"section x2 = {at['x2'] * UM:.3g} µm (through the maximum)")
    _index_map(fig, axes[0, 2], dv.sel(x2=track, method="nearest"), "x1", "x3", top,
               f"section x2 = {track * UM:.3g} µm (track centre)")
    label = f"max {top:.3g} (step {int(result['dang_van_max_step'])})"
    axes[0, 0].plot(at["x1"] * UM, at["x2"] * UM, "c*", ms=12, label=label)
    axes[0, 1].plot(at["x1"] * UM, at["depth"] * UM, "c*", ms=12, label=label)
    for ax in axes[0, :2]:
        ax.legend(loc="upper right", fontsize=8)
    _note(axes[0, 2], f"f₋₁ = {result.attrs['bending_limit'] * MPA:.4g} MPa, "
          f"t₋₁ = {result.attrs['torsion_limit'] * MPA:.4g} MPa")
    return fig


#: Plot function of each stage, keyed by the ``stage`` attribute of its result.
PLOTS: dict[str, Callable[..., Figure]] = {
    "hertz-check": plot_hertz_check,
    "load-approach": plot_load_approach,
    "indentation": plot_indentation,
    "elastic-vs-plastic": plot_elastic_vs_plastic,
    "vertical-vs-rolling": plot_vertical_vs_rolling,
    "track": plot_track,
    "residual-map": plot_residual_map,
    "campaign-summary": plot_campaign_summary,
    "case-vs-reference": plot_case_vs_reference,
    "fatigue": plot_fatigue,
    "material-point": plot_material_point,
    "passes": plot_passes,
    "melan": plot_melan,
}


def plot(result: xr.Dataset, **options) -> Figure:
    """Return the figure of any stage result (dispatch on ``result.attrs["stage"]``)."""
    stage = result.attrs.get("stage")
    if stage not in PLOTS:
        raise ValueError(f"not a comparison result (stage {stage!r})")
    return PLOTS[stage](result, **options)
