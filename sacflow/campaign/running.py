"""Running a campaign: one dask task and one run file per case, outcomes in the manifest.

Each task (:func:`run_one`) writes ``<out>/<case name>.nc`` through
:func:`sacflow.runner.run_case` -- no shared file, no lock; the campaign
process only gathers the outcomes into the manifest (:mod:`sacflow.campaign.manifest`).
Finished cases are skipped on a re-run, interrupted ones resume after their stored steps, a run
of another case stored under a case's name is not replaced unless asked, and a failing case is
recorded while the others go on.
"""

from __future__ import annotations

import os
import sys
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from tqdm.auto import tqdm

from sacflow.campaign import cluster
from sacflow.campaign.expansion import CampaignCase, expand_campaign, load_campaign
from sacflow.campaign.manifest import CampaignSummary, Manifest
from sacflow.config.schema import Campaign, Case, Elastic
from sacflow.config.solver_inputs import estimate_case_memory
from sacflow.errors import ConfigError, SacflowError
from sacflow.storage.output_dir import prepare_output_dir

if TYPE_CHECKING:
    from sacflow.runner import StateSource

__all__ = [
    "WORKER_DIED",
    "CampaignConflictError",
    "SimulationFactory",
    "run_campaign",
    "run_one",
]

WORKER_DIED = (
    "the worker process died running this case (out of memory, or a crash in compiled code); "
    "see the dask worker logs"
)
#: ``factory(case) -> simulation`` (:class:`sacflow.runner.StateSource`).
SimulationFactory = Callable[[Case], "StateSource"]


class CampaignConflictError(ConfigError):
    """A campaign's cases are named like stored runs of other cases (see ``overwrite``)."""


def run_campaign(
    campaign: Campaign | str | Path,
    out_dir: str | Path,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    simulation_factory: SimulationFactory | None = None,
    overwrite: bool = False,
) -> CampaignSummary:
    """Run every case of ``campaign`` with dask, one task and one file per case.

    Parameters
    ----------
    campaign : Campaign, str or Path
        The campaign, or its file (read with :func:`~sacflow.campaign.load_campaign`).
    out_dir : str or Path
        Output folder: ``<case name>.nc`` per case and ``<campaign>.manifest.json``. With
        ``scheduler``, the workers must see it at the same path (shared file system).
    workers : int, optional
        Worker processes of the local cluster (default: one per core, at most one per case).
    scheduler : str, optional
        Address of a running dask scheduler (``tcp://host:8786``) to use instead.
    progress : bool
        Progress bar over the cases; the dashboard link is printed either way (stderr).
    simulation_factory : callable, optional
        ``factory(case) -> simulation`` passed to :func:`sacflow.runner.run_case`; it must be
        importable by the workers (a module-level function).
    overwrite : bool
        Replace runs of other cases stored under the cases' names. Without it, when a case's
        name holds a run of another case, nothing is run, the manifest is left as it is and
        :class:`CampaignConflictError` names the files, both ids and the fields that differ.

    Returns
    -------
    CampaignSummary
        Records in campaign order; a failed case has ``status == "failed"`` and its message.
    """
    start = time.perf_counter()
    if not isinstance(campaign, Campaign):
        campaign = load_campaign(campaign)
    if workers is not None and (scheduler or workers < 1):
        raise ConfigError(
            "--workers sizes the local cluster; use a positive number and no --scheduler"
        )
    if scheduler:
        cluster.check_scheduler_address(scheduler)
    cases = expand_campaign(campaign)
    out_dir = prepare_output_dir(out_dir).resolve()
    manifest = Manifest(campaign, cases, out_dir)
    pending = _skip_complete(cases, manifest, overwrite)  # refuses before the manifest changes
    if pending and not scheduler:  # its imports overlap the rest, up to the workers' start
        cluster.start_fork_server(
            plastic=any(not isinstance(c.case.body.hardening, Elastic) for c in pending)
        )
    manifest.write()
    _say(
        f"{campaign.name}: {len(cases)} cases, {len(cases) - len(pending)} already complete, "
        f"{len(pending)} to run"
    )
    n_workers, dashboard = 0, None
    if pending:
        memory = {c.index: estimate_case_memory(c.case).total for c in pending}
        with cluster.connect(scheduler, workers, len(pending), max(memory.values())) as client:
            n_workers = len(client.nthreads())
            dashboard = cluster.dashboard(client, local=not scheduler)
            _say(f"dask: {client.scheduler.address}, {n_workers} workers, dashboard {dashboard}")
            _run_pending(client, pending, out_dir, manifest, progress, simulation_factory,
                         overwrite, memory)
    return CampaignSummary(
        name=campaign.name,
        out_dir=out_dir,
        manifest=manifest.path,
        records=tuple(manifest.records.values()),
        wall_time=time.perf_counter() - start,
        workers=n_workers,
        dashboard=dashboard,
    )


def _skip_complete(
    cases: list[CampaignCase], manifest: Manifest, overwrite: bool = False
) -> list[CampaignCase]:
    """Mark the cases whose run file is complete as skipped; return the others to run.

    Raises
    ------
    CampaignConflictError
        When a case's name holds a run of another case (finished or interrupted) and not
        ``overwrite``: nothing is run and the manifest on disk is left as it is, so that the
        records of the finished runs are never rewritten as failed (issue #31).
    """
    from sacflow.storage.run_reader import run_info
    from sacflow.storage.run_writer import replace_message

    pending, conflicts = [], []
    for c in cases:
        info = run_info(manifest.records[c.index].path)
        same = info.exists and info.matches(c.case_id)
        if info.complete and same:
            manifest.update(c.index, status="skipped", steps=info.steps)
        elif info.exists and not same and not info.damaged_only and not overwrite:
            conflicts.append(replace_message(info, c.case))
        else:
            pending.append(c)
    if conflicts:
        raise CampaignConflictError(_conflict_message(manifest, conflicts, len(cases)))
    return pending


#: At most this many conflicting cases are described in full in the refusal.
_SHOWN_CONFLICTS = 3


def _conflict_message(manifest: Manifest, conflicts: list[str], total: int) -> str:
    """One-screen refusal: which names hold other cases' runs, how they differ, the fixes."""
    out = manifest.path.parent
    lines = [
        f"{manifest.campaign.name}: {len(conflicts)} of {total} cases are named like runs of "
        f"other cases already in {out} (a changed base, --set or sweep gives other case ids "
        "under the same names). Nothing was run and the manifest was left as it is.",
    ]
    for message in conflicts[:_SHOWN_CONFLICTS]:
        lines += [f"  {line}" for line in message.splitlines()[:-1]]
    if len(conflicts) > _SHOWN_CONFLICTS:
        lines.append(f"  ... and {len(conflicts) - _SHOWN_CONFLICTS} more cases")
    lines.append(
        "To keep the stored runs, write this campaign to another folder (--out, out_dir) or "
        "give it another name; to replace them, run again with --overwrite (overwrite=True)."
    )
    return "\n".join(lines)


def _run_pending(
    client: Any,
    pending: list[CampaignCase],
    out_dir: Path,
    manifest: Manifest,
    progress: bool,
    simulation_factory: SimulationFactory | None,
    overwrite: bool = False,
    memory: dict[int, int] | None = None,
) -> None:
    from distributed import as_completed

    # Longest first (dask runs tasks in submission order): a long case started last would keep
    # one worker busy while the others idle. Equal estimates keep the campaign order.
    ordered = sorted(pending, key=_estimated_cost, reverse=True)
    # Each task declares its memory estimate where the workers declare theirs, so that a worker
    # never runs more cases at once than fit; never more than a worker has (dask would wait
    # forever): such a case runs alone, and its worker's memory check decides.
    per_worker = cluster.worker_memory(client)
    futures = {
        client.submit(
            run_one, c.case.canonical_json(), str(out_dir), simulation_factory, overwrite,
            pure=False,
            resources=None if per_worker is None or memory is None else {
                cluster.MEMORY_RESOURCE: min(memory[c.index], per_worker)},
        ): c
        for c in ordered
    }
    failed = 0
    bar = tqdm(total=len(futures), desc=manifest.campaign.name, unit="case", disable=not progress)
    with bar:
        for future in as_completed(futures):
            case = futures.pop(future)
            try:
                outcome = future.result()
            except Exception as exc:  # the worker died (KilledWorker), or the task was lost
                error = _describe(exc)
                if type(exc).__name__ == "KilledWorker":
                    error = f"{WORKER_DIED}: {error}"
                outcome = {"status": "failed", "error": error}
            manifest.update(case.index, **outcome)
            manifest.write()
            failed += outcome["status"] == "failed"
            bar.set_postfix(failed=failed, refresh=False)
            bar.update()


def _estimated_cost(c: CampaignCase) -> int:
    """Estimate the relative cost of a case: grid cells x steps (plasticity not weighed)."""
    grid = c.case.grid
    steps = sum(getattr(s, "increments", 0) or getattr(s, "steps", 1) for s in c.case.load_path)
    return grid.nx * grid.ny * grid.nz * steps


# --------------------------------------------------------------------------- the dask task
def run_one(
    case_json: str,
    out_dir: str,
    simulation_factory: SimulationFactory | None = None,
    overwrite: bool = False,
) -> dict[str, Any]:
    """Rebuild the case from its JSON and run it into ``out_dir`` (the dask task).

    Never raises for a failing case: returns ``status`` (``done`` or ``failed``), ``error``,
    ``traceback`` (unexpected errors only), ``wall_time``, ``cpu_time`` (of the worker process:
    well below the wall time when the machine is oversubscribed), ``steps``, ``resumed_steps``.
    ``SACFLOW_FFT_THREADS`` defaults to 1 in the worker (one case per core). A run of another
    case stored under the case's name is replaced only with ``overwrite``.
    """
    os.environ.setdefault(cluster.FFT_THREADS_ENV, "1")
    start, cpu_start = time.perf_counter(), time.process_time()
    try:
        from sacflow.runner import run_case

        case = Case.model_validate_json(case_json)
        summary = run_case(
            case, out_dir, progress=False, simulation_factory=simulation_factory, resume=True,
            overwrite=overwrite,
        )
    except Exception as exc:  # the case failed; the campaign goes on
        return {
            "status": "failed",
            "error": _describe(exc),
            "traceback": None if isinstance(exc, SacflowError) else traceback.format_exc(),
            "wall_time": time.perf_counter() - start,
            "cpu_time": time.process_time() - cpu_start,
        }
    return {  # complete already: a retry after its worker died with the result (still "done")
        "status": "done",
        "wall_time": time.perf_counter() - start,
        "cpu_time": time.process_time() - cpu_start,
        "steps": summary.steps,
        "resumed_steps": summary.resumed_steps,
    }


def _describe(exc: BaseException) -> str:
    return str(exc) if isinstance(exc, SacflowError) else f"{type(exc).__name__}: {exc}"


def _say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)
