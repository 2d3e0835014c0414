"""Campaigns: a base case swept over parameters, one dask task and one run file per case.

A campaign file (TOML) names a base case and ``[[sweep]]`` blocks of dotted case paths with
lists of values; each case becomes one dask task writing ``<out>/<case name>.nc``, and the
campaign process gathers the outcomes into ``<out>/<campaign>.manifest.json`` (see
``docs/campaigns.md``). One module per job:

* :mod:`sacflow.campaign.expansion`: campaign file -> checked cases, their names and messages;
* :mod:`sacflow.campaign.manifest`: per-case records, the JSON manifest, the summary table;
* :mod:`sacflow.campaign.cluster`: the dask client, local cluster, fork server, worker
  environment;
* :mod:`sacflow.campaign.running`: :func:`run_campaign`, skipping and resuming, the task.

Everything public is importable from here: ``from sacflow.campaign import run_campaign``.
"""

from __future__ import annotations

from sacflow.campaign.cluster import (
    FFT_THREADS_ENV,
    FORK_SERVER_LAST,
    MAX_PORT,
    PLASTIC_PRELOAD,
    SCHEDULER_FORM,
    SCHEDULER_SCHEMES,
    WORKER_ENV,
    WORKER_PRELOAD,
    check_scheduler_address,
)
from sacflow.campaign.expansion import (
    MAX_NAME,
    CampaignCase,
    campaign_rows,
    case_names,
    expand_campaign,
    load_campaign,
)
from sacflow.campaign.manifest import CampaignSummary, CaseRecord, Status
from sacflow.campaign.running import (
    WORKER_DIED,
    CampaignConflictError,
    SimulationFactory,
    run_campaign,
    run_one,
)
from sacflow.config.problems import MAX_PROBLEMS

__all__ = [
    "FFT_THREADS_ENV",
    "FORK_SERVER_LAST",
    "MAX_NAME",
    "MAX_PORT",
    "MAX_PROBLEMS",
    "PLASTIC_PRELOAD",
    "SCHEDULER_FORM",
    "SCHEDULER_SCHEMES",
    "WORKER_DIED",
    "WORKER_ENV",
    "WORKER_PRELOAD",
    "CampaignCase",
    "CampaignConflictError",
    "CampaignSummary",
    "CaseRecord",
    "SimulationFactory",
    "Status",
    "campaign_rows",
    "case_names",
    "check_scheduler_address",
    "expand_campaign",
    "load_campaign",
    "run_campaign",
    "run_one",
]
