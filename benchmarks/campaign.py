"""Campaign throughput: eight small elastic Hertz cases on 2 dask workers vs one after another.

    python benchmarks/campaign.py [--cases 8] [--workers 2] [--nx 128] [--nz 16] [--increments 6]

The default cases take a few seconds each (2.2-2.6 s on the 2-core development machine, like the
cases a campaign is for); ``serial_case_time_mean_fft1`` reports it. Both the serial runs and the
campaign run exactly these cases.

Prints JSON (never asserts): wall times of the serial runs (``run_case`` in this process, one
FFT thread, then all cores; sacflow's modules are imported before the clock starts, malloc set up
as ``sacflow run`` does) and of the
campaign (``run_campaign`` on a new LocalCluster, which includes starting the cluster and the
workers' imports), the speed-up, and the overhead per case:

* ``overhead_per_case``: (workers x campaign wall - serial wall, 1 FFT thread) / cases, the
  worker-seconds a case costs beyond its own work (cluster start, imports, dispatch, tail idle);
* ``task_overhead_per_case``: (sum of the task wall times - serial wall) / cases, the part of it
  spent inside the tasks (worker imports, FFT planning);
* ``dispatch_overhead_per_case``: (workers x campaign wall - sum of the task times) / cases, the
  part outside the tasks (cluster start and stop, scheduling, idle workers at the end);
* ``campaign_wall_warm_cluster`` and ``speedup_warm_cluster``: the same campaign on a cluster
  that is running already and whose workers have run these cases once (``--scheduler`` on a
  cluster kept between campaigns): no start, no first case in a fresh process;
* ``cluster_start``: seconds to start and stop sacflow's local cluster of the same size (fork
  server included) in a fresh process, running one trivial task; ``cluster_start_dask_default``:
  the same for a plain ``LocalCluster`` (spawned workers), in this process;
* ``*_cpu``: CPU seconds (user + system) of the serial runs and of the campaign (this process and
  its worker processes). Unlike wall times they barely change when other programs share the
  machine: ``cpu_overhead_per_case`` = (campaign CPU - serial CPU) / cases, and
  ``speedup_estimate_idle`` = serial CPU / (campaign CPU / workers), what the speed-up would be on
  an idle machine with perfectly balanced workers.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def build_campaign(cases: int, nx: int, nz: int, increments: int):
    """The shipped Hertz case at nx x nx x nz cells, ``cases`` loads from 0.2 N to 0.65 N."""
    from sacflow.config.parsing import apply_overrides
    from sacflow.config.schema import Campaign
    from sacflow.storage.case_file import read_file

    base = apply_overrides(
        read_file(ROOT / "configs" / "hertz-elastic.toml"),
        [f"grid.nx={nx}", f"grid.ny={nx}", f"grid.nz={nz}", f"load_path.0.increments={increments}"],
    )
    loads = [round(0.2 + (0.65 - 0.2) * k / max(cases - 1, 1), 4) for k in range(cases)]
    return Campaign(
        name="bench",
        base=base,
        sweep=[{"mode": "zip", "parameters": {"load_path.0.to": loads}}],
    )


def serial(campaign, out: Path, fft_threads: str | None) -> tuple[float, list[float], list[float]]:
    """Run every case with ``run_case`` in this process: wall time, per-case wall and CPU.

    The process has the malloc settings of ``sacflow run`` and of the campaign workers
    (:func:`sacflow.machine.malloc.tune_malloc`), so that both sides allocate memory the same way.
    """
    import sacflow.solver.simulation  # noqa: F401 - imported before the clock, like sacflow.runner
    from sacflow.campaign import expand_campaign
    from sacflow.machine.malloc import tune_malloc
    from sacflow.runner import run_case

    tune_malloc()

    previous = os.environ.get("SACFLOW_FFT_THREADS")
    if fft_threads is None:
        os.environ.pop("SACFLOW_FFT_THREADS", None)
    else:
        os.environ["SACFLOW_FFT_THREADS"] = fft_threads
    try:
        start, times, cpus = time.perf_counter(), [], []
        for c in expand_campaign(campaign):
            cpu_start = time.process_time()
            times.append(run_case(c.case, out, progress=False, resume=False).wall_time)
            cpus.append(time.process_time() - cpu_start)
        return time.perf_counter() - start, times, cpus
    finally:
        if previous is None:
            os.environ.pop("SACFLOW_FFT_THREADS", None)
        else:
            os.environ["SACFLOW_FFT_THREADS"] = previous


def cpu(who: int = resource.RUSAGE_SELF) -> float:
    """CPU seconds (user + system) of this process, or of its finished children."""
    usage = resource.getrusage(who)
    return usage.ru_utime + usage.ru_stime


def stop_fork_server() -> None:
    """Stop multiprocessing's fork server, which forked the campaign's workers, and wait for it.

    The workers are its children, not this process's: RUSAGE_CHILDREN counts their CPU time only
    once the server, which waited for them, has itself exited and been waited for.
    """
    from multiprocessing import forkserver

    stop = getattr(forkserver._forkserver, "_stop", None)  # the only way to stop it (3.11-3.13)
    if stop is not None:
        stop()


def warm_cluster(campaign, folder: Path, workers: int) -> float:
    """Wall time of the campaign on a running cluster whose workers have run it once already."""
    from sacflow.campaign import run_campaign
    from sacflow.campaign.cluster import connect

    with connect(None, workers, workers) as client:
        address = client.scheduler.address
        run_campaign(campaign, folder / "warm-up", scheduler=address, progress=False)
        start = time.perf_counter()
        run_campaign(campaign, folder / "warm", scheduler=address, progress=False)
        return time.perf_counter() - start


def cluster_start(workers: int) -> float:
    """Start and stop sacflow's local cluster in a fresh process (its fork server is cold)."""
    code = (
        "import time\n"
        "from sacflow.campaign.cluster import connect\n"
        "start = time.perf_counter()\n"
        f"with connect(None, {workers}, {workers}) as client:\n"
        "    client.submit(sum, [1, 2]).result()\n"
        "print(time.perf_counter() - start)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return float(out.stdout.split()[-1])


def cluster_start_dask_default(workers: int) -> float:
    from distributed import Client, LocalCluster

    start = time.perf_counter()
    with (
        LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, silence_logs=logging.ERROR
        ) as cluster,
        Client(cluster) as client,
    ):
        client.submit(sum, [1, 2]).result()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=8)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--nx", type=int, default=128)
    parser.add_argument("--nz", type=int, default=16)
    parser.add_argument("--increments", type=int, default=6)
    args = parser.parse_args()

    from sacflow.campaign import run_campaign

    campaign = build_campaign(args.cases, args.nx, args.nz, args.increments)
    load_before = os.getloadavg()[0]  # other work on the machine skews every number (before/after)
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        cpu_start = cpu()
        serial_1, case_times, case_cpu = serial(campaign, folder / "serial-1", "1")
        serial_cpu = cpu() - cpu_start
        serial_all, _, _ = serial(campaign, folder / "serial-all", None)
        start, cpu_start = time.perf_counter(), cpu() + cpu(resource.RUSAGE_CHILDREN)
        summary = run_campaign(campaign, folder / "campaign", workers=args.workers, progress=False)
        parallel = time.perf_counter() - start
        stop_fork_server()  # after the clock: its workers' CPU counts once it has exited
        campaign_cpu = cpu() + cpu(resource.RUSAGE_CHILDREN) - cpu_start
        warm = warm_cluster(campaign, folder, args.workers)
        task_times = [r.wall_time or 0.0 for r in summary.records]
        task_cpu = [r.cpu_time or 0.0 for r in summary.records]
        failed = [r.name for r in summary.failed]
    n = args.cases
    result = {
        "benchmark": "campaign",
        "cases": n,
        "workers": args.workers,
        "cores": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "grid": [args.nx, args.nx, args.nz],
        "increments": args.increments,
        "serial_wall_fft1": round(serial_1, 3),
        "serial_wall_fft_all_cores": round(serial_all, 3),
        "serial_case_time_mean_fft1": round(sum(case_times) / len(case_times), 3),
        "serial_case_times_fft1": [round(t, 3) for t in case_times],
        "serial_case_cpu_fft1": [round(t, 3) for t in case_cpu],
        "campaign_wall": round(parallel, 3),
        "campaign_task_times": [round(t, 3) for t in task_times],
        "campaign_task_cpu": [round(t, 3) for t in task_cpu],
        "speedup_vs_serial_fft1": round(serial_1 / parallel, 3),
        "speedup_vs_serial_fft_all_cores": round(serial_all / parallel, 3),
        "campaign_wall_warm_cluster": round(warm, 3),
        "speedup_warm_cluster": round(serial_1 / warm, 3),
        "overhead_per_case": round((args.workers * parallel - serial_1) / n, 3),
        "task_overhead_per_case": round((sum(task_times) - serial_1) / n, 3),
        "dispatch_overhead_per_case": round((args.workers * parallel - sum(task_times)) / n, 3),
        "serial_cpu_fft1": round(serial_cpu, 3),
        "campaign_cpu": round(campaign_cpu, 3),
        "cpu_overhead_per_case": round((campaign_cpu - serial_cpu) / n, 3),
        "speedup_estimate_idle": round(serial_cpu / (campaign_cpu / args.workers), 3),
        "cluster_start": round(cluster_start(args.workers), 3),
        "cluster_start_dask_default": round(cluster_start_dask_default(args.workers), 3),
        "failed": failed,
        "targets": {"speedup": 1.8, "overhead_per_case": 0.5},
        "load_average_1min": [round(load_before, 2), round(os.getloadavg()[0], 2)],
        "python": sys.version.split()[0],
    }
    print(json.dumps(result, indent=2))


if __name__ == "__main__":  # the dask workers are spawned processes: keep this guard
    main()
