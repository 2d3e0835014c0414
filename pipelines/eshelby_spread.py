"""How far the near-cavity's GMRES count moves from one process to the next.

    python pipelines/eshelby_spread.py [--processes N] [--ratio R] [--threads K]

Runs the step of ``tests/test_inhomogeneity_solver.py``'s Eshelby sphere (3 cells per radius)
at the modulus ratio E*/E = R (default 0.001, a near cavity) in N fresh processes (default 12),
each with the kernel cache off as the tests run it, and prints their GMRES iteration counts as
JSON, with their minimum, median and maximum. The inputs and the thread count are the same in
every process: a spread is rounding that differs between processes (``docs/inclusions.md``).
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--processes", type=int, default=12)
    parser.add_argument("--ratio", type=float, default=0.001, help="E*/E of the sphere")
    parser.add_argument("--threads", type=int, help="SACFLOW_FFT_THREADS of the processes")
    args = parser.parse_args(argv)
    if args.processes < 1 or args.ratio <= 0.0:
        parser.error("--processes must be >= 1 and --ratio > 0")
    env = dict(os.environ, SACFLOW_CACHE_DIR="off")
    if args.threads is not None:
        env["SACFLOW_FFT_THREADS"] = str(args.threads)
    program = CHILD.format(tests=str(ROOT / "tests"), ratio=args.ratio)
    counts = []
    for _ in range(args.processes):  # one after the other: the spread is not from the load
        done = subprocess.run([sys.executable, "-c", program], env=env, capture_output=True,
                              text=True, check=False)
        if done.returncode != 0 or not done.stdout.split():
            last = (done.stderr.strip().splitlines() or ["no output"])[-1]
            print(f"error: the step's process failed: {last}", file=sys.stderr)
            return 2
        counts.append(int(done.stdout.split()[-1]))
    print(json.dumps({"ratio": args.ratio, "threads": args.threads, "counts": counts,
                      "min": min(counts), "median": statistics.median(counts),
                      "max": max(counts)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
