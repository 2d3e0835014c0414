"""Where a campaign's tasks run: a dask scheduler given by address, or a local cluster.

The local cluster (:func:`connect` without a scheduler) has one single-threaded worker process
per core, started with the thread and malloc settings of :data:`WORKER_ENV` and
:data:`~sacflow.machine.malloc.MALLOC_ENV`. Its workers are forked from multiprocessing's fork
server
(:func:`start_fork_server`), which has imported sacflow and the solver once, so that a worker
starts with everything a case needs loaded. What this costs and saves is measured by
``benchmarks/campaign.py`` (figures in ``docs/campaigns.md``).
"""

from __future__ import annotations

import importlib.util
import logging
import os
import re
from collections.abc import Iterable, Iterator
from contextlib import contextmanager, nullcontext
from typing import Any

from sacflow.errors import ConfigError, SacflowError
from sacflow.machine.malloc import MALLOC_ENV
from sacflow.machine.resources import available_memory, usable_cores

__all__ = [
    "FFT_THREADS_ENV",
    "FORK_SERVER_LAST",
    "MAX_PORT",
    "MEMORY_RESOURCE",
    "PLASTIC_PRELOAD",
    "SCHEDULER_FORM",
    "SCHEDULER_SCHEMES",
    "WORKER_ENV",
    "WORKER_PRELOAD",
    "check_scheduler_address",
    "connect",
    "dashboard",
    "saved_environ",
    "start_fork_server",
    "worker_environ",
    "worker_memory",
]

#: Environment variable read by the FFT operators; campaign workers default to 1 thread each.
FFT_THREADS_ENV = "SACFLOW_FFT_THREADS"
#: Environment of the local cluster's workers: n single-threaded cases on n cores, not n × cores
#: FFT or BLAS threads. OpenMP and BLAS read theirs when numpy loads, so the worker processes
#: (or the fork server they are forked from) start with them.
WORKER_ENV = {
    FFT_THREADS_ENV: "1",
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
}
#: Modules the fork server imports once, before forking the local cluster's workers.
WORKER_PRELOAD = ("distributed", "sacflow.campaign", "sacflow.runner", "sacflow.solver.simulation")
#: ... and, when a case has plasticity, what only elastic-plastic runs import (numba included).
PLASTIC_PRELOAD = ("scipy.sparse.linalg", "sacflow.kernels.eigenstrain",
                   "sacflow.solver.vector_passes", "sacflow.kernels.traction_stencil",
                   "sacflow.kernels.pair_products")
#: ... and last, a module that freezes the garbage collector's view of all that (gc.freeze).
FORK_SERVER_LAST = "sacflow.campaign.gc_freeze"
#: The dask worker resource a case's memory estimate is declared in [bytes]: a worker runs no
#: more cases at once than fit in what it declares (``dask worker --resources memory=64e9``).
MEMORY_RESOURCE = "memory"
#: Transport schemes of a dask scheduler address (``--scheduler``); none means tcp.
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
#: Largest TCP port number.
MAX_PORT = 65535
#: The expected form of ``--scheduler``, printed with every problem.
SCHEDULER_FORM = (
    "expected tcp://host:8786 (the address `dask scheduler` prints; scheme one of "
    + ", ".join(SCHEDULER_SCHEMES) + ", port 1..65535)"
)
_SCHEDULER_ADDRESS = re.compile(
    r"(?:(?:" + "|".join(SCHEDULER_SCHEMES) + r")://)?"
    r"(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+):(?P<port>[0-9]{1,5})"
)
#: The fork server's preload list as last set by :func:`start_fork_server` (empty: not started).
_preload: list[str] = []


def check_scheduler_address(address: str) -> None:
    """Check that ``address`` has the form of a dask scheduler address, before any work.

    Accepted: ``[scheme://]host:port`` with scheme one of :data:`SCHEDULER_SCHEMES` (dask's
    default is tcp) and a port 1..65535, e.g. ``tcp://10.0.0.1:8786`` or ``localhost:8786``.
    Otherwise dask fails with a ``ValueError`` deep inside its address parsing.

    Raises
    ------
    ConfigError
        Naming ``--scheduler``, the value and the expected form.
    """
    match = _SCHEDULER_ADDRESS.fullmatch(address.strip())
    if match is None or not 1 <= int(match["port"]) <= MAX_PORT:
        raise ConfigError(
            f"--scheduler {address!r} is not a dask scheduler address; {SCHEDULER_FORM}"
        )


@contextmanager
def connect(
    scheduler: str | None, workers: int | None, tasks: int, largest_task: int = 0
) -> Iterator[Any]:
    """Yield a dask client: on ``scheduler``, or on a new local cluster closed at the end.

    Without ``workers``, the local cluster has no more single-threaded workers than cases of
    ``largest_task`` bytes fit in :func:`~sacflow.machine.resources.available_memory` (at least
    one): each runs one case at a time, so the machine never runs more cases than fit. Its
    workers declare no :data:`MEMORY_RESOURCE` (dask hands resource-restricted tasks to a worker
    in arrival order, not in the longest-first order of submission); workers of a cluster of
    one's own that declare it get tasks declaring their estimates (:func:`worker_memory`).

    Parameters
    ----------
    scheduler : str or None
        Address of a running scheduler; None starts a local cluster.
    workers : int or None
        Worker processes of the local cluster (default: one per core).
    tasks : int
        Number of tasks to run: the local cluster has no more workers than that.
    largest_task : int
        Estimated memory of the largest task [bytes] (0: not known).

    Raises
    ------
    ConfigError
        ``scheduler`` is not an address dask accepts.
    SacflowError
        No scheduler answers at ``scheduler``.
    """
    if scheduler:
        with _remote_client(scheduler) as client:
            yield client
    else:
        available = available_memory()
        fit = max(1, available // largest_task) if largest_task else tasks
        n = min(workers or min(usable_cores(), fit), tasks)
        with _local_client(n) as client:
            yield client


def worker_memory(client: Any) -> int | None:
    """Smallest :data:`MEMORY_RESOURCE` of ``client``'s workers [bytes]; None if one has none.

    Tasks declare their memory estimate only to clusters whose every worker declares it
    (``dask worker --resources memory=64e9``): elsewhere dask would never run them.
    """
    workers = client.scheduler_info().get("workers", {}).values()
    amounts = [w.get("resources", {}).get(MEMORY_RESOURCE) for w in workers]
    if not amounts or any(a is None for a in amounts):
        return None
    return int(min(amounts))


@contextmanager
def _remote_client(scheduler: str) -> Iterator[Any]:
    from distributed import Client

    try:
        client = Client(scheduler, timeout="10s")
    except ValueError as exc:  # an address check_scheduler_address let through
        raise ConfigError(f"--scheduler {scheduler!r}: {exc}; {SCHEDULER_FORM}") from None
    except (OSError, TimeoutError) as exc:
        raise SacflowError(
            f"cannot connect to the dask scheduler at {scheduler} ({exc}); start one with "
            "`dask scheduler` and workers with `dask worker <address>`"
        ) from None
    with client:
        yield client


@contextmanager
def _local_client(n: int) -> Iterator[Any]:
    """Yield a client of a new local cluster of ``n`` single-threaded workers."""
    method = start_fork_server(plastic=None)  # started already by run_campaign, else now
    import dask
    from distributed import Client, LocalCluster

    config = {
        # dask sets MALLOC_TRIM_THRESHOLD_=65536 in its workers (and in this process, for good),
        # which turns off glibc's adaptive mmap threshold: every large temporary array is then
        # mapped and zero-filled afresh, and the solver runs much slower (docs/campaigns.md,
        # "Memory allocator"). Not set here: the workers get sacflow.machine.malloc's settings from
        # the
        # environment of worker_environ (the fork server's, or this one's for spawn).
        "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
        "distributed.worker.multiprocessing-method": method,
        # The workers' statistical profiler takes the GIL every 10 ms to walk the running
        # task's stack (it feeds the dashboard's profile page), which slows the cases down
        # (docs/campaigns.md, "Running"). Off for sacflow's own cluster.
        "distributed.worker.profile.enabled": False,
    }
    # For the cluster's whole life: a worker that died is started again the same way. Spawned
    # workers inherit this process's environment, forked ones the fork server's.
    spawned = worker_environ() if method == "spawn" else nullcontext()
    # Each nanny writes the thread settings of its worker's environment into this process's
    # os.environ before starting the worker (distributed's "pre-spawn" variables), and leaves
    # them there: a notebook's later subprocesses would run single-threaded BLAS.
    with dask.config.set(config), spawned, saved_environ(WORKER_ENV):
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            silence_logs=logging.ERROR,
            env=dict(WORKER_ENV),
        )
        try:
            _keep_preload(method)
            with Client(cluster) as client:
                yield client
        finally:
            cluster.close()


def start_fork_server(plastic: bool | None = False) -> str:
    """Start multiprocessing's fork server for the local cluster; return the start method.

    The fork server imports :data:`WORKER_PRELOAD` once (and :data:`PLASTIC_PRELOAD` for
    ``plastic`` campaigns; None: as the previous call asked), then freezes the objects it made
    (:data:`FORK_SERVER_LAST`). The workers forked from it start with everything a case needs
    loaded, where a spawned worker would import it all again, and exit at once, where a spawned
    one tears down its interpreter. It is started once per process, in the environment of
    :func:`worker_environ`; a fork server already running (started earlier in this process)
    is used as it is. ``spawn`` where there is no fork server (Windows).
    """
    import multiprocessing
    from multiprocessing import forkserver

    if "forkserver" not in multiprocessing.get_all_start_methods():  # pragma: no cover
        return "spawn"
    if plastic is None:
        plastic = PLASTIC_PRELOAD[-1] in _preload
    _preload[:] = [*WORKER_PRELOAD, *(PLASTIC_PRELOAD if plastic else ()), FORK_SERVER_LAST]
    forkserver.set_forkserver_preload(list(_preload))
    with worker_environ():
        forkserver.ensure_running()  # returns once started; the imports go on in the server
    return "forkserver"


def _keep_preload(method: str) -> None:
    """Set the fork server's preload list back to sacflow's once the workers have started.

    distributed's first nanny replaces it with distributed's own list (importing distributed's
    optional packages, pandas among them, in this process to make it); the running fork server
    does not read it again, but one started again later (after it died) would not load sacflow.
    """
    if method == "forkserver" and _preload:
        from multiprocessing import forkserver

        forkserver.set_forkserver_preload(list(_preload))


@contextmanager
def worker_environ() -> Iterator[None]:
    """Set :data:`WORKER_ENV` and the malloc settings in ``os.environ`` inside the block only.

    The processes started inside (the fork server, or spawned workers) inherit them.
    """
    changes = {**WORKER_ENV, **MALLOC_ENV}
    with saved_environ(changes):
        os.environ.update(changes)
        yield


@contextmanager
def saved_environ(keys: Iterable[str]) -> Iterator[None]:
    """Give ``os.environ``'s ``keys`` back their values of the block's start when it ends."""
    saved = {key: os.environ.get(key) for key in keys}
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def dashboard(client: Any, local: bool) -> str:
    """Return the dashboard link of ``client``'s scheduler, or why there is none."""
    if "dashboard" not in client.scheduler_info().get("services", {}):
        return "not available"
    link = str(client.dashboard_link)
    if local and importlib.util.find_spec("bokeh") is None:
        link += " (install bokeh to see it)"
    return link
