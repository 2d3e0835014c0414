"""Opening a campaign's results in one call: :func:`open_campaign`.

The cases of a campaign have their own grids (a swept load or grid size changes the window and
the cell count), so their run files cannot be concatenated into one array: ``xr.open_mfdataset``
fails and nested concatenation is mostly NaN. A campaign opens instead as

* ``summary``: the per-case scalar results (:func:`sacflow.compare.campaign.run_results`) as one
  Dataset along ``case``, the swept parameters as coordinates with CF-valid names
  (``load_path.0.to`` -> ``load_path_0_to``, the dotted path in the ``parameter_path``
  attribute), and ``case_id`` and ``status`` coordinates; the wall time of a case is taken
  from the manifest when its run file does not record it;
* ``fields``: an :class:`xarray.DataTree` with one node per finished case (node name = case
  name) holding its run Dataset, opened lazily: nothing is read until used.

Failed, pending or missing cases stay in the summary (their status, NaN results) and are absent
from the tree. The run files decide, not the manifest: a complete run of the recorded case is
opened whatever its record says (its status then reads ``done``), a finished case whose file is
gone reads ``missing``, and a file holding another case's run is an error naming it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from sacflow.compare.campaign import (
    RESULT_NAMES,
    fill_wall_times,
    run_results,
    summary_dataset,
)
from sacflow.errors import SacflowError
from sacflow.storage.run_reader import open_run, run_info

__all__ = ["MANIFEST_SUFFIX", "CampaignOpenError", "CampaignResults", "open_campaign"]

#: File name ending of a campaign manifest, ``<out>/<campaign>.manifest.json``.
MANIFEST_SUFFIX = ".manifest.json"
#: Manifest statuses whose run file is finished.
_FINISHED = ("done", "skipped")


class CampaignOpenError(SacflowError):
    """A campaign cannot be opened: no manifest, several, or an unreadable one."""


@dataclass(frozen=True)
class CampaignResults:
    """A campaign opened by :func:`open_campaign`.

    Attributes
    ----------
    name : str
        Campaign name.
    manifest : Path
        The manifest read.
    summary : xarray.Dataset
        Per-case scalars along ``case`` (see the module docstring).
    fields : xarray.DataTree
        One node per finished case, its run opened lazily.
    """

    name: str
    manifest: Path
    summary: xr.Dataset
    fields: xr.DataTree

    def close(self) -> None:
        """Close the run files opened for :attr:`fields`."""
        for node in self.fields.subtree:
            node.close()


def find_manifest(source: str | Path) -> Path:
    """Return the manifest ``source`` names: the file itself, or the only one in a folder.

    Raises
    ------
    CampaignOpenError
        No such file or folder, no manifest in the folder, or several (named).
    """
    path = Path(source)
    if path.is_file():
        return path
    if not path.is_dir():
        raise CampaignOpenError(f"{path}: no such manifest file or campaign folder")
    found = sorted(path.glob(f"*{MANIFEST_SUFFIX}"))
    if not found:
        raise CampaignOpenError(
            f"{path}: no campaign manifest (*{MANIFEST_SUFFIX}) in this folder; give the "
            "folder `sacflow campaign --out` wrote, or the manifest file"
        )
    if len(found) > 1:
        names = ", ".join(p.name for p in found)
        raise CampaignOpenError(
            f"{path}: {len(found)} campaign manifests here ({names}); pass the one to open"
        )
    return found[0]


def _records(manifest: Path) -> tuple[str, list[dict[str, Any]]]:
    try:
        data = json.loads(manifest.read_text())
        return str(data.get("campaign", manifest.name.removesuffix(MANIFEST_SUFFIX))), list(
            data["cases"]
        )
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise CampaignOpenError(f"{manifest}: not a campaign manifest ({exc})") from None


def open_campaign(source: str | Path) -> CampaignResults:
    """Open a campaign's results: scalars along ``case`` and the runs as a DataTree.

    Parameters
    ----------
    source : str or Path
        The campaign manifest ``<out>/<campaign>.manifest.json`` or the folder holding it (and
        no other manifest).

    Returns
    -------
    CampaignResults
        ``summary`` (Dataset along ``case``) and ``fields`` (DataTree, one node per finished
        case); close with :meth:`CampaignResults.close` when done.

    Raises
    ------
    CampaignOpenError
        See :func:`find_manifest`; an unreadable manifest.
    """
    manifest = find_manifest(source)
    name, records = _records(manifest)
    runs: dict[str, xr.Dataset] = {}
    rows: list[dict[str, Any]] = []
    statuses = [str(r.get("status", "")) for r in records]
    try:
        for record in records:
            path = manifest.parent / Path(str(record.get("path", f"{record['name']}.nc"))).name
            ds, statuses[len(rows)] = _open_finished(path, record)
            if ds is None:
                rows.append(dict.fromkeys(RESULT_NAMES, np.nan))
                continue
            runs[str(record["name"])] = ds
            rows.append(run_results(ds))
    except BaseException:
        for ds in runs.values():
            ds.close()
        raise
    fill_wall_times(rows, records)
    parameters = list(dict.fromkeys(k for r in records for k in r.get("parameters", {})))
    summary = summary_dataset(
        [str(r["name"]) for r in records],
        rows,
        {k: [r.get("parameters", {}).get(k) for r in records] for k in parameters},
        {
            "case_id": [str(r.get("case_id", "")) for r in records],
            "status": statuses,
        },
        attrs={"title": f"campaign {name}", "campaign": name, "manifest": str(manifest)},
    )
    fields = xr.DataTree.from_dict(runs)
    for case, ds in runs.items():
        # a node built from a dataset does not inherit its closer: without this, the files
        # stay open until garbage collection, which may close one while the same file is being
        # opened again in this process (HDF5 then fails with "NetCDF: HDF error")
        fields[case].set_close(ds.close)
    return CampaignResults(name, manifest, summary, fields)


def _open_finished(path: Path, record: dict[str, Any]) -> tuple[xr.Dataset | None, str]:
    """Open the run of a case as it is on disk; return it (None if not finished) and a status.

    The run file, not the manifest, decides (the manifest lags behind the files, and an older
    sacflow could rewrite a finished case's record as failed): a complete file of the record's
    case is opened, whatever the record says ("done" when it said otherwise); no file or an
    interrupted run leaves the case out with the record's status (``missing`` for a finished
    record without its file, ``pending`` for one whose file is interrupted).

    Raises
    ------
    CampaignOpenError
        The file holds a run of another case, or is not a readable run.
    """
    status = str(record.get("status", ""))
    info = run_info(path)
    if not info.exists:
        return None, "missing" if status in _FINISHED else status
    if info.unreadable:
        raise CampaignOpenError(f"{path}: not a readable run file ({info.problem})")
    case_id = str(record.get("case_id", ""))
    if case_id and not info.matches(case_id):
        raise CampaignOpenError(
            f"{path} holds {info.describe()}, the manifest records case {case_id}: it was "
            "replaced after this campaign ran (sacflow run --overwrite or another campaign "
            "with --overwrite); run the campaign again to recompute it"
        )
    if not info.complete:
        return None, status if status not in _FINISHED else "pending"
    try:
        return open_run(path, lazy=True), status if status in _FINISHED else "done"
    except (OSError, ValueError, RuntimeError) as exc:
        raise CampaignOpenError(f"{path}: not a readable run file ({exc})") from None
