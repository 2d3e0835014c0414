"""The error of a shipped discretisation against the limit of the grid and the window refined.

:func:`sacflow.studies.certify.certify` combines a `together` limit at a fixed window with the
window sequence's shift. Checked on a model with separate errors of the grid and the window,
f(h, W) = f* + C hᵖ + D W⁻ᵠ, whose limit f* is known: the two sequences are extrapolated by the
study's own Richardson analysis, and the combination must find f* and the shipped error.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from sacflow.errors import SacflowError
from sacflow.studies.certify import (
    FINEST,
    LIMIT,
    NO_LIMIT,
    OUTSIDE,
    PARTS,
    WITHIN,
    certify,
    level_discretisation,
    level_values,
    plot_certificates,
    sequence_levels,
)
from sacflow.studies.error_parts import PartsLimit
from sacflow.studies.richardson import MONOTONE, extrapolate

F_STAR, C_GRID, P_GRID, D_WINDOW, Q_WINDOW = 80.0, -3.0, 2.0, -5.0, 3.0
#: The shipped window (in units of the contact radius) and the window sequence's ratio.
W0, WINDOW_RATIO, GRID_RATIO = 2.0, 1.5, 2.0


def model(h: float, window: float) -> float:
    """f(h, W) with errors of the grid and the window that add."""
    return F_STAR + C_GRID * h ** P_GRID + D_WINDOW * window ** -Q_WINDOW


def summary_row(values: list[float], ratio: float, sequence: str) -> dict[str, object]:
    """A summary row as :func:`read_summary` returns it, from the study's own extrapolation."""
    fit = extrapolate(values, ratio)
    return {"case": "model", "sequence": sequence, "quantity": "q", "unit": "m",
            "behaviour": fit.behaviour, "limit": fit.limit, "uncertainty": fit.uncertainty,
            "finest_value": values[-1]}


def sequences(h_window: float) -> tuple[dict[str, object], dict[str, object], float]:
    """The `together` row at W0, the window row at ``h_window`` and its first level."""
    together = summary_row([model(GRID_RATIO ** -k, W0) for k in range(3)], GRID_RATIO,
                           "together")
    windows = [model(h_window, W0 * WINDOW_RATIO ** k) for k in range(3)]
    return together, summary_row(windows, WINDOW_RATIO, "window"), windows[0]


@pytest.mark.parametrize("h_window", [1.0, 0.5])
def test_the_combined_limit_is_the_model_s(h_window):
    together, window, first = sequences(h_window)
    assert together["behaviour"] == MONOTONE and window["behaviour"] == MONOTONE
    # Neither sequence alone finds f*: each keeps the other's error.
    assert abs(together["limit"] - F_STAR) > 0.1
    assert abs(window["limit"] - F_STAR) > 0.1
    shipped = model(0.25, math.inf)
    got = certify(together, window, first, shipped)
    assert got.limit == pytest.approx(F_STAR, rel=1e-12)
    assert got.error == pytest.approx((shipped - F_STAR) / F_STAR, rel=1e-9)
    assert got.value_error == got.error and got.scale == pytest.approx(F_STAR)
    assert got.together_kind == LIMIT


def test_the_window_shift_is_what_the_shipped_window_misses():
    together, window, first = sequences(1.0)
    got = certify(together, window, first, F_STAR)
    assert got.window_shift == pytest.approx(-D_WINDOW * W0 ** -Q_WINDOW, rel=1e-12)
    assert got.error == pytest.approx(0.0, abs=1e-12) and got.verdict == WITHIN


def test_uncertainties_add_with_the_transfer():
    together, window, first = sequences(1.0)
    together = {**together, "uncertainty": 0.2}
    window = {**window, "uncertainty": 0.05}
    got = certify(together, window, first, F_STAR, transfer=-0.03)
    assert got.uncertainty == pytest.approx(0.28)
    assert got.relative_uncertainty == pytest.approx(0.28 / F_STAR)
    assert certify(together, window, first, F_STAR).uncertainty == pytest.approx(0.25)


def test_a_profile_point_is_judged_against_the_profile_s_scale():
    together, window, first = sequences(1.0)
    shipped = F_STAR * 1.02
    own = certify(together, window, first, shipped)
    scaled = certify(together, window, first, shipped, scale=-10 * F_STAR)
    assert own.error == pytest.approx(0.02) and own.verdict == OUTSIDE
    assert scaled.error == pytest.approx(0.002) and scaled.verdict == WITHIN
    assert scaled.value_error == pytest.approx(0.02)


def test_a_together_sequence_without_a_limit_uses_its_finest_level():
    together, window, first = sequences(1.0)
    together = {**together, "behaviour": "oscillating", "limit": math.nan}
    got = certify(together, window, first, F_STAR)
    assert got.together_kind == FINEST
    assert got.together_limit == together["finest_value"]
    assert got.verdict == WITHIN  # an oscillating sequence keeps its spread as uncertainty
    diverging = {**together, "behaviour": "diverging", "uncertainty": math.nan}
    assert certify(diverging, window, first, F_STAR).verdict == NO_LIMIT


def test_a_limit_from_the_parts_stands_in_only_where_the_together_sequence_has_none():
    together, window, first = sequences(1.0)
    parts = PartsLimit(limit=F_STAR + 0.01, uncertainty=0.02, parts_uncertainty=0.015,
                       misfit=0.005, base_errors={}, discrepancies=())
    diverging = {**together, "behaviour": "diverging", "limit": math.nan,
                 "uncertainty": math.nan}
    got = certify(diverging, window, first, F_STAR, parts=parts)
    assert got.together_kind == PARTS
    assert got.together_limit == parts.limit
    assert got.together_uncertainty == parts.uncertainty
    assert got.limit == pytest.approx(parts.limit + got.window_shift)
    assert got.verdict != NO_LIMIT  # without the parts the diverging sequence has none
    assert certify(diverging, window, first, F_STAR).verdict == NO_LIMIT
    kept = certify(together, window, first, F_STAR, parts=parts)
    assert kept.together_kind == LIMIT
    assert kept.together_limit == together["limit"]


def test_a_window_sequence_without_a_limit_is_refused():
    together, window, first = sequences(1.0)
    with pytest.raises(SacflowError, match="window sequence is oscillating"):
        certify(together, {**window, "behaviour": "oscillating", "limit": math.nan}, first, 1.0)


def test_level_values_reads_one_level_and_names_what_is_missing(tmp_path: Path):
    table = tmp_path / "levels.csv"
    table.write_text("case,sequence,level,quantity,value\n"
                     "c,window,0,q,1.5\nc,window,1,q,1.6\nc,window,0,r,\n")
    assert level_values(table, "c", "window", 0) == {"q": 1.5}
    with pytest.raises(SacflowError, match="no level 2 of c's window"):
        level_values(table, "c", "window", 2)
    with pytest.raises(SacflowError, match="no levels table"):
        level_values(tmp_path / "none.csv", "c", "window", 0)


def test_sequence_levels_keys_each_level_by_what_it_ran(tmp_path: Path):
    table = tmp_path / "levels.csv"
    table.write_text("case,sequence,level,nx,nz,increments,quantity,value\n"
                     "c,lateral,0,32,24,15,q,1.5\nc,lateral,1,64,24,15,q,1.6\n"
                     "c,lateral,1,64,24,15,r,\nc,layers,0,64,12,15,q,1.4\n")
    assert sequence_levels(table, "c", "lateral") == {(32, 24, 15): {"q": 1.5},
                                                      (64, 24, 15): {"q": 1.6}}
    with pytest.raises(SacflowError, match="no increments sequence of c"):
        sequence_levels(table, "c", "increments")
    with pytest.raises(SacflowError, match="no levels table"):
        sequence_levels(tmp_path / "none.csv", "c", "lateral")


def test_level_discretisation_reads_what_the_level_ran(tmp_path: Path):
    table = tmp_path / "levels.csv"
    table.write_text("case,sequence,level,nx,nz,depth,increments,quantity,value\n"
                     "c,increments,2,96,128,0.0005128859423,52,q,1.5\n")
    assert level_discretisation(table, "c", "increments", 2) == (96, 128, 52, 0.0005128859423)
    with pytest.raises(SacflowError, match="no level 1 of c's increments"):
        level_discretisation(table, "c", "increments", 1)


def test_the_press_s_shipped_value_without_the_far_traction_is_its_config_s():
    """The press's certificate takes its shipped value without the traction beyond the box from
    a recorded level; that level must be the config's discretisation, and another is refused
    with a message that says what to run."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pipelines"))
    import convergence_certify

    case = "dent-from-indentation-press"
    source = convergence_certify.SOURCES[case].shipped_off
    assert source is not None
    values = convergence_certify.shipped_off_values(case, source)
    assert math.isfinite(values["peak_pressure"])
    table, sequence, _ = source
    with pytest.raises(SacflowError, match=r"level 0 ran 96² × 128 cells with 26 increments.*"
                                           r"ships 96² × 128 cells with 52 increments"):
        convergence_certify.shipped_off_values(case, (table, sequence, 0))


def test_the_stored_certificates_follow_from_the_stored_study_tables():
    """``data/convergence-certified.csv`` is what ``pipelines/convergence_certify.py`` computes
    from the study's tables under ``data/`` (a table changed without it fails here)."""
    import csv
    import sys

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "pipelines"))
    import convergence_certify

    with (root / "data" / "convergence-certified.csv").open(encoding="utf-8") as f:
        stored = {(r["case"], r["quantity"]): r for r in csv.DictReader(f)}
    found = [c for case, sources in convergence_certify.SOURCES.items()
             for c in convergence_certify.certificates(case, sources)]
    assert {(c.case, c.quantity) for c in found} == set(stored)
    for c in found:
        row = stored[(c.case, c.quantity)]
        assert row["verdict"] == c.verdict
        for name in ("limit", "uncertainty", "error", "shipped_value"):
            value = getattr(c, name)
            if row[name] == "":  # NaN is written as an empty cell
                assert math.isnan(value), (c.case, c.quantity, name)
            else:
                assert float(row[name]) == pytest.approx(value, rel=1e-9), (c.case, name)


def test_the_plot_has_a_panel_per_case_and_a_point_per_certificate():
    together, window, first = sequences(1.0)
    diverging = {**together, "behaviour": "diverging", "uncertainty": math.nan}
    found = [certify({**together, "case": case}, window, first, F_STAR * (1 + shift))
             for case in ("a", "b") for shift in (0.0, 0.02)]
    found.append(certify({**diverging, "case": "b", "quantity": "r"}, window, first, F_STAR))
    fig = plot_certificates(found)
    axes = fig.get_axes()
    assert [ax.get_title() for ax in axes] == ["a", "b"]
    assert [len(ax.containers) for ax in axes] == [2, 3]  # one error bar per certificate
    assert [t.get_text() for t in axes[0].get_yticklabels()] == ["q", "r"]
    # the "outside" point lies at its error, in per cent of its scale
    x, _ = axes[0].containers[1].lines[0].get_data()
    assert x[0] == pytest.approx(2.0)


def test_the_script_keeps_an_existing_plot_and_says_how_to_replace_it(tmp_path, capsys):
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pipelines"))
    import convergence_certify

    plot = tmp_path / "certified.png"
    plot.write_bytes(b"the user's")
    assert convergence_certify.main(["--plot", str(plot)]) == 1
    assert plot.read_bytes() == b"the user's"
    assert "--overwrite" in capsys.readouterr().err
    assert convergence_certify.main(["--plot", str(plot), "--overwrite"]) == 0
    assert plot.read_bytes().startswith(b"\x89PNG")


def test_a_plot_that_cannot_be_written_is_a_message_and_leaves_nothing(tmp_path):
    from matplotlib.figure import Figure

    from sacflow.studies.convergence_table import write_figure

    blocked = tmp_path / "a-file"
    blocked.write_text("not a folder")
    with pytest.raises(SacflowError, match="cannot write the plot"):
        write_figure(Figure(), blocked / "certified.png")
    write_figure(Figure(), tmp_path / "new" / "certified.png")
    assert sorted(p.name for p in (tmp_path / "new").iterdir()) == ["certified.png"]


def test_the_stored_parts_limits_follow_from_the_stored_study_tables():
    """``data/convergence-parts-limits.csv`` is what ``pipelines/convergence_certify.py
    --parts-table`` computes from the one-at-a-time sequences, and the certificate takes such a
    limit exactly where the `together` sequence has none."""
    import csv
    import sys

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "pipelines"))
    import convergence_certify

    with (root / "data" / "convergence-parts-limits.csv").open(encoding="utf-8") as f:
        stored = {(r["case"], r["quantity"]): r for r in csv.DictReader(f)}
    found = {(p.case, p.quantity): p for case, sources in convergence_certify.SOURCES.items()
             for p in convergence_certify.parts_limits(case, sources).values()}
    assert set(found) == set(stored)
    for key, p in found.items():
        assert float(stored[key]["limit"]) == pytest.approx(p.found.limit, rel=1e-9), key
        assert float(stored[key]["uncertainty"]) == pytest.approx(p.found.uncertainty, rel=1e-9)
    with (root / "data" / "convergence-certified.csv").open(encoding="utf-8") as f:
        certified = list(csv.DictReader(f))
    for row in certified:
        key = (row["case"], row["quantity"])
        if row["together_kind"] == PARTS:
            assert key in found and found[key].together["behaviour"] != MONOTONE, key
            assert float(row["together_limit"]) == pytest.approx(found[key].found.limit)
        elif key in found:
            assert row["together_kind"] == LIMIT, key


def test_a_finer_lateral_table_must_refine_the_lateral_cells_alone_on_the_parts_scale(tmp_path):
    """The parts' finer lateral sequence (``Sources.parts_lateral``) is read only when each of
    its levels runs the base's layers and increments on more cells, and its steps are on the
    parts table's scale (h = 32 / nx): otherwise C h^p would be read at the wrong h."""
    import csv
    import shutil
    import sys

    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "pipelines"))
    import convergence_certify

    case = "nanoindentation-650mN"
    sources = convergence_certify.SOURCES[case]
    assert sources.parts_lateral is not None
    table = root / "data" / sources.parts_lateral
    base = (64, 24, 15)
    rows = convergence_certify.lateral_part_rows(case, table, base, 32)
    assert rows and {k[:2] for k in rows} == {(case, "lateral")}
    with pytest.raises(SacflowError, match="relative to 64 cells"):
        convergence_certify.lateral_part_rows(case, table, base, 64)
    with pytest.raises(SacflowError, match="lateral cells alone"):
        convergence_certify.lateral_part_rows(case, table, (128, 24, 15), 32)
    with table.open(newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        fields, levels = list(reader.fieldnames or ()), list(reader)
    for r in levels:
        if r["case"] == case and r["nx"] == "160":
            r["nz"] = "48"
    changed = tmp_path / table.name
    with changed.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(levels)
    summary = table.with_name(table.stem + "-summary.csv")
    shutil.copy(summary, tmp_path / summary.name)
    with pytest.raises(SacflowError, match="160² × 48"):
        convergence_certify.lateral_part_rows(case, changed, base, 32)


def test_an_existing_output_stops_the_script_before_any_other_is_written(tmp_path, capsys):
    """With ``--table`` the user's and ``--parts-table`` new, neither is written."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pipelines"))
    import convergence_certify

    table, parts = tmp_path / "certified.csv", tmp_path / "parts.csv"
    table.write_text("the user's\n")
    assert convergence_certify.main(["--table", str(table), "--parts-table", str(parts)]) == 1
    assert table.read_text() == "the user's\n"
    assert not parts.exists()
    assert "--overwrite" in capsys.readouterr().err
