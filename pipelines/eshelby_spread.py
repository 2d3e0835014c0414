"""How far the near-cavity's GMRES count moves from one process to the next.

    python pipelines/eshelby_spread.py [--processes N] [--ratio R] [--threads K]
                                       [--planner estimate|measure]

Runs the step of ``tests/test_inhomogeneity_solver.py``'s Eshelby sphere (3 cells per radius)
at the modulus ratio E*/E = R (default 0.001, a near cavity) in N fresh processes (default 12),
each with the kernel cache off as the tests run it, and prints their GMRES iteration counts as
JSON, with their minimum, median and maximum. The inputs and the thread count are the same in
every process: a spread is rounding that differs between processes, from FFTW's measured plans
of the eigenstrain operator's depth transforms; with ``--planner estimate`` every process takes
the same plans and the same count (``docs/inclusions.md``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: The child's program: one step of the test's sphere, its count printed.
CHILD = """
import sys
sys.path.insert(0, {tests!r})
import test_inhomogeneity_solver as eshelby
_, states = eshelby.run(eshelby.eshelby_inputs({ratio!r}, 3))
print(states[-1].inclusion_iterations)
"""


class StepFailed(RuntimeError):
    """A child process's step failed; the message is the child's last error line."""


def counts(processes: int, ratio: float = 0.001, threads: int | None = None,
           planner: str | None = None) -> list[int]:
    """GMRES counts of the sphere's step at E*/E = ``ratio`` in ``processes`` fresh processes.

    ``planner`` (``"estimate"`` or ``"measure"``) sets ``SACFLOW_FFTW_PLANNER`` in them; the
    default measured plans of the depth transforms are timed, and may differ from one process
    to the next, estimated ones do not (``docs/inclusions.md``).
    """
    env = dict(os.environ, SACFLOW_CACHE_DIR="off")
    if threads is not None:
        env["SACFLOW_FFT_THREADS"] = str(threads)
    if planner is not None:
        env["SACFLOW_FFTW_PLANNER"] = planner
    program = CHILD.format(tests=str(ROOT / "tests"), ratio=ratio)
    found = []
    for _ in range(processes):  # one after the other: the spread is not from the load
        done = subprocess.run([sys.executable, "-c", program], env=env, capture_output=True,
                              text=True, check=False)
        if done.returncode != 0 or not done.stdout.split():
            raise StepFailed((done.stderr.strip().splitlines() or ["no output"])[-1])
        found.append(int(done.stdout.split()[-1]))
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--processes", type=int, default=12)
    parser.add_argument("--ratio", type=float, default=0.001, help="E*/E of the sphere")
    parser.add_argument("--threads", type=int, help="SACFLOW_FFT_THREADS of the processes")
    parser.add_argument("--planner", choices=("estimate", "measure"),
                        help="SACFLOW_FFTW_PLANNER of the processes (default: the solver's)")
    args = parser.parse_args(argv)
    if args.processes < 1 or args.ratio <= 0.0:
        parser.error("--processes must be >= 1 and --ratio > 0")
    try:
        found = counts(args.processes, args.ratio, args.threads, args.planner)
    except StepFailed as failure:
        print(f"error: the step's process failed: {failure}", file=sys.stderr)
        return 2
    print(json.dumps({"ratio": args.ratio, "threads": args.threads, "planner": args.planner,
                      "counts": found, "min": min(found),
                      "median": statistics.median(found), "max": max(found)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
