"""The shipped dent study on a tiny grid: pipeline, summary, physics trends, notebook.

The study's campaigns run as shipped except for the grid and the number of roll steps (``--set``
on the base case), so every file the study uses is exercised: the campaign files, the base case,
the pipeline script, the summary and the notebook.
"""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from sacflow.studies.dent_study import DentStudyError, case_metrics, dent_summary

ROOT = Path(__file__).resolve().parents[1]
PIPELINE = ROOT / "pipelines" / "dent_study.py"
NOTEBOOK = ROOT / "pipelines" / "dent_study.ipynb"
TINY = ["--set", "grid.nx=12", "--set", "grid.ny=12", "--set", "grid.nz=4",
        "--set", "load_path.1.steps=8", "--no-progress"]
CF_NAME = r"^[A-Za-z][A-Za-z0-9_]*$"


def _pipeline():
    spec = importlib.util.spec_from_file_location("dent_study_pipeline", PIPELINE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("study") / "dent-study"
    assert _pipeline().main(["--out", str(out), "--workers", "2", *TINY]) == 0
    return out


def test_summary_pairs_each_dent_with_its_smooth_case(study):
    summary = xr.load_dataset(study / "dent-study-summary.nc")
    assert summary.sizes["case"] == 18  # 3 depths x 3 widths x 2 loads
    assert sorted(set(summary["load"].values)) == [675.0, 1318.0]
    np.testing.assert_allclose(summary["dent_slope"], summary["dent_depth"] / summary["dent_width"])
    for name in summary.variables:
        assert re.match(CF_NAME, str(name)), name
        assert summary[name].attrs.get("units"), name
    smooth = json.loads((study / "dent-study-smooth.manifest.json").read_text())["cases"]
    by_load = {}
    for record in smooth:
        with xr.open_dataset(study / record["path"]) as run:
            load = float(run["load"].max())
        by_load[load] = case_metrics(study / record["path"],
                                     study / "fatigue" / f"{record['name']}-fatigue.nc")
    for i in range(summary.sizes["case"]):
        row = summary.isel(case=i)
        ref = by_load[float(row["load"])]
        assert float(row["dang_van_max_smooth"]) == ref["dang_van_max"]
        assert float(row["dang_van_ratio"]) == pytest.approx(
            float(row["dang_van_max"]) / ref["dang_van_max"], rel=1e-12)
        assert float(row["pressure_peak_ratio"]) == pytest.approx(
            float(row["peak_pressure"]) / ref["peak_pressure"], rel=1e-12)


def test_a_deeper_dent_raises_the_pressure_peak_and_the_index(study):
    summary = xr.load_dataset(study / "dent-study-summary.nc")
    for load in (675.0, 1318.0):
        for width in np.unique(summary["dent_width"].values):
            row = summary.where((summary["load"] == load) & (summary["dent_width"] == width),
                                drop=True).sortby("dent_depth")
            assert row.sizes["case"] == 3
            # Steeper flanks, same width: a higher pressure spike at the rim and a higher index.
            assert np.all(np.diff(row["pressure_peak_ratio"].values) > 0.0)
            assert np.all(np.diff(row["dang_van_ratio"].values) > 0.0)
            assert np.all(row["pressure_peak_ratio"].values > 1.0)


def test_rerun_keeps_runs_and_fatigue_results(study, capsys):
    results = sorted((study / "fatigue").glob("*-fatigue.nc"))
    assert len(results) == 20
    before = {p: p.stat().st_mtime_ns for p in results}
    assert _pipeline().main(["--out", str(study), "--workers", "2", *TINY]) == 0
    assert {p: p.stat().st_mtime_ns for p in results} == before
    assert "0 to run" in capsys.readouterr().err


def test_missing_smooth_reference_is_named(study, tmp_path):
    manifest = json.loads((study / "dent-study-smooth.manifest.json").read_text())
    manifest["cases"] = [c for c in manifest["cases"] if "to675" not in c["name"]]
    partial = study / "partial-smooth.manifest.json"
    partial.write_text(json.dumps(manifest))
    try:
        with pytest.raises(DentStudyError, match="no smooth case"):
            dent_summary(study / "dent-study.manifest.json", partial, study / "fatigue")
    finally:
        partial.unlink()


def test_notebook_runs_on_the_study(study, monkeypatch):
    import nbclient
    import nbformat

    monkeypatch.setenv("SACFLOW_STUDY_DIR", str(study))
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    nbclient.NotebookClient(notebook, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(NOTEBOOK.parent)}}).execute()
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    images = [o for o in outputs if "image/png" in o.get("data", {})]
    assert len(images) >= 3  # slope plot, worst-case maps, residual σ11 profile
