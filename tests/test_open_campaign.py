"""``sacflow.open_campaign``: a campaign's scalars along ``case`` and its runs as a DataTree."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import sacflow
from sacflow.campaign import run_campaign
from sacflow.campaign.opening import CampaignOpenError
from sacflow.compare.campaign import RESULT_NAMES, run_results
from sacflow.config.dotted import CF_NAME, cf_names
from sacflow.storage.run_reader import open_run

SMOKE = Path(__file__).resolve().parents[1] / "configs" / "campaign-smoke.toml"


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("smoke")
    summary = run_campaign(SMOKE, out, workers=2, progress=False)
    assert not summary.failed
    return out


def test_summary_along_case_with_cf_named_parameters(smoke, tmp_path):
    opened = sacflow.open_campaign(smoke / "campaign-smoke.manifest.json")
    try:
        s = opened.summary
        manifest = json.loads((smoke / "campaign-smoke.manifest.json").read_text())["cases"]
        assert list(s["case"].values) == [c["name"] for c in manifest]
        assert s.attrs["parameters"] == "load_path_0_to counterbody_radius"
        assert s["load_path_0_to"].attrs["parameter_path"] == "load_path.0.to"
        np.testing.assert_array_equal(s["load_path_0_to"],
                                      [c["parameters"]["load_path.0.to"] for c in manifest])
        np.testing.assert_array_equal(s["counterbody_radius"],
                                      [c["parameters"]["counterbody.radius"] for c in manifest])
        assert set(s["status"].values) == {"done"}
        np.testing.assert_allclose(s["wall_time"], [c["wall_time"] for c in manifest])
        for name in s.variables:
            assert CF_NAME.match(str(name)), name
        s.to_netcdf(tmp_path / "summary.nc")
        with xr.open_dataset(tmp_path / "summary.nc") as back:
            xr.testing.assert_identical(back.load(), s)
        # the peak pressure grows with the load at each radius (Hertz: p0 ∝ W^(1/3))
        for radius in np.unique(s["counterbody_radius"].values):
            row = s.where(s["counterbody_radius"] == radius, drop=True).sortby("load_path_0_to")
            assert np.all(np.diff(row["peak_pressure"].values) > 0.0)
    finally:
        opened.close()


def test_fields_tree_holds_each_run_lazily(smoke):
    opened = sacflow.open_campaign(smoke)  # the folder holding one manifest
    try:
        assert sorted(opened.fields.children) == sorted(opened.summary["case"].values)
        for name, node in opened.fields.children.items():
            expected = open_run(smoke / f"{name}.nc")
            xr.testing.assert_equal(node.to_dataset().load(), expected)
            assert run_results(expected)["peak_pressure"] == float(
                opened.summary["peak_pressure"].sel(case=name))
    finally:
        opened.close()


def test_failed_and_missing_cases_stay_in_the_summary(smoke, tmp_path):
    for path in smoke.glob("*.nc"):
        shutil.copy(path, tmp_path / path.name)
    data = json.loads((smoke / "campaign-smoke.manifest.json").read_text())
    data["cases"][0]["status"] = "failed"
    (tmp_path / data["cases"][0]["path"]).unlink()  # failed: no file
    (tmp_path / data["cases"][1]["path"]).unlink()  # done, but its file is gone
    (tmp_path / "campaign-smoke.manifest.json").write_text(json.dumps(data))
    opened = sacflow.open_campaign(tmp_path)
    try:
        first, second = (data["cases"][i]["name"] for i in (0, 1))
        assert opened.summary["status"].sel(case=first) == "failed"
        assert opened.summary["status"].sel(case=second) == "missing"
        for name in (first, second):
            assert np.isnan(float(opened.summary["max_plastic_strain"].sel(case=name)))
            assert np.isnan(float(opened.summary["peak_pressure"].sel(case=name)))
            assert name not in opened.fields.children
        assert len(opened.fields.children) == len(data["cases"]) - 2
    finally:
        opened.close()


def test_the_run_files_decide_not_the_manifest(smoke, tmp_path):
    """Issue #31: finished runs recorded as failed (an older sacflow's re-run) still open."""
    for path in smoke.glob("*.nc"):
        shutil.copy(path, tmp_path / path.name)
    data = json.loads((smoke / "campaign-smoke.manifest.json").read_text())
    for record in data["cases"]:
        record["status"] = "failed"
    (tmp_path / "campaign-smoke.manifest.json").write_text(json.dumps(data))
    opened = sacflow.open_campaign(tmp_path)
    try:
        assert set(opened.summary["status"].values) == {"done"}
        name = data["cases"][0]["name"]
        assert opened.fields[name].ds.sizes["step"] >= 1
    finally:
        opened.close()
    data["cases"][0]["case_id"] = "0123456789ab"  # the file holds another case than recorded
    (tmp_path / "campaign-smoke.manifest.json").write_text(json.dumps(data))
    with pytest.raises(CampaignOpenError, match=r"manifest records case 0123456789ab"):
        sacflow.open_campaign(tmp_path)


def test_no_manifest_or_several_are_named(smoke, tmp_path):
    with pytest.raises(CampaignOpenError, match="no campaign manifest"):
        sacflow.open_campaign(tmp_path)
    for name in ("a", "b"):
        shutil.copy(smoke / "campaign-smoke.manifest.json", tmp_path / f"{name}.manifest.json")
    with pytest.raises(CampaignOpenError, match=r"2 campaign manifests.*a\.manifest\.json"):
        sacflow.open_campaign(tmp_path)
    with pytest.raises(CampaignOpenError, match="no such manifest"):
        sacflow.open_campaign(tmp_path / "absent")
    (tmp_path / "c.manifest.json").write_text("{not json")
    with pytest.raises(CampaignOpenError, match="not a campaign manifest"):
        sacflow.open_campaign(tmp_path / "c.manifest.json")


def test_result_names_are_those_of_a_run(smoke):
    assert tuple(run_results(open_run(next(smoke.glob("*.nc"))))) == RESULT_NAMES


def test_cf_names_are_valid_and_distinct():
    names = cf_names(["load_path.0.to", "load_path_0.to", "0.x", "a b", "grid.nx"],
                     taken=["grid_nx"])
    assert names == {"load_path.0.to": "load_path_0_to", "load_path_0.to": "load_path_0_to_2",
                     "0.x": "p_0_x", "a b": "a_b", "grid.nx": "grid_nx_2"}
    assert all(CF_NAME.match(n) for n in names.values())


def _open_descriptors(folder: Path) -> int:
    """Count this process's open file descriptors on ``folder``'s run files (Linux /proc)."""
    runs = {p.resolve() for p in folder.glob("*.nc")}
    count = 0
    for fd in Path("/proc/self/fd").iterdir():
        try:
            count += Path(fd.readlink()) in runs
        except OSError:
            continue
    return count


@pytest.mark.skipif(not Path("/proc/self/fd").is_dir(), reason="needs /proc/self/fd")
def test_close_releases_the_run_files(smoke):
    before = _open_descriptors(smoke)
    opened = sacflow.open_campaign(smoke)
    float(next(iter(opened.fields.children.values()))["pressure"].max())
    assert _open_descriptors(smoke) > before
    opened.close()
    assert _open_descriptors(smoke) == before
