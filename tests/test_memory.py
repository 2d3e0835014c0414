"""Memory estimate of a case (sacflow.solver.memory_estimate): scaling with the grid, the check,
the CLI line.

A grid too large for the machine used to pass ``sacflow validate`` and end ``sacflow run`` in
numpy's ``_ArrayMemoryError``; now ``validate`` prints the estimate and refuses such a grid
with one clear ``error:`` message (issue #14).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from sacflow.cli import main
from sacflow.config.solver_inputs import (
    case_body_grid,
    check_case_memory,
    estimate_case_memory,
)
from sacflow.errors import GridTooLargeError
from sacflow.machine.resources import available_memory
from sacflow.storage.case_file import load_case

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
HERTZ = CONFIGS / "hertz-elastic.toml"
NANO = CONFIGS / "nanoindentation-650mN.toml"
ROLLING = CONFIGS / "rolling-smooth.toml"
ABSURD = ["grid.nx=4096", "grid.ny=4096", "grid.nz=512"]
GIB = 2**30


def item(estimate, name: str) -> int:
    return next(i.nbytes for i in estimate.items if i.name == name)


def test_eigenstrain_part_doubles_with_nz():
    shallow = estimate_case_memory(load_case(NANO, ["grid.nz=16"]))
    deep = estimate_case_memory(load_case(NANO, ["grid.nz=32"]))
    ratio = item(deep, "eigenstrain operator") / item(shallow, "eigenstrain operator")
    assert 1.9 < ratio < 2.1, ratio  # N + 1 depth frequencies: 65 / 33
    assert item(deep, "solver state") == 2 * item(shallow, "solver state")
    assert deep.total > 1.5 * shallow.total - 300 * 2**20  # the libraries do not grow


def test_estimate_grows_with_the_surface_grid():
    small = estimate_case_memory(load_case(HERTZ, ["grid.nx=64", "grid.ny=64"]))
    large = estimate_case_memory(load_case(HERTZ, ["grid.nx=128", "grid.ny=128"]))
    assert item(large, "per-step fields") == pytest.approx(4 * item(small, "per-step fields"),
                                                          rel=0.01)
    assert 3.5 < item(large, "pressure-stress operator") / item(
        small, "pressure-stress operator") < 4.5
    assert sum(i.nbytes for i in large.items) == large.total
    assert [i.nbytes for i in large.items] == sorted((i.nbytes for i in large.items),
                                                     reverse=True)


def test_rolling_body_grid_is_the_solver_s(tmp_path):
    from sacflow.config.schema import Elastic
    from sacflow.config.solver_inputs import simulation_for

    case = load_case(ROLLING, ["grid.nx=16", "grid.ny=16", "grid.nz=2", "load_path.1.steps=5"])
    elastic = case.model_copy(update={"body": case.body.model_copy(
        update={"hardening": Elastic()})})
    grid = case_body_grid(elastic)
    assert grid.body == simulation_for(elastic).body_shape
    assert grid.body[0] > grid.window[0] and grid.body[1] == grid.window[1], "swept along x1"


def test_check_memory_refuses_a_grid_larger_than_available():
    case = load_case(NANO, ["grid.nx=32", "grid.ny=32"])
    estimate = check_case_memory(case, available=64 * GIB)
    with pytest.raises(GridTooLargeError) as error:
        check_case_memory(case, available=estimate.total - 1)
    message = str(error.value)
    assert "needs about" in message and "available" in message
    for part in estimate.biggest():
        assert part.name in message
    assert "grid.nx" in message and "grid.nz" in message
    assert len(message.splitlines()) <= 8, "one screen"


def test_available_memory_reads_meminfo_and_the_cgroup_limit(tmp_path, monkeypatch):
    import sacflow.machine.resources as memory

    meminfo = tmp_path / "meminfo"
    meminfo.write_text("MemTotal:       8000000 kB\nMemAvailable:    4000000 kB\n")
    monkeypatch.setattr(memory, "MEMINFO", meminfo)
    monkeypatch.setattr(memory, "CGROUP_LIMIT", tmp_path / "absent")
    assert available_memory() == 4000000 * 1024
    limit, usage = tmp_path / "memory.max", tmp_path / "memory.current"
    limit.write_text(f"{3 * GIB}\n")
    usage.write_text(f"{1 * GIB}\n")
    monkeypatch.setattr(memory, "CGROUP_LIMIT", limit)
    monkeypatch.setattr(memory, "CGROUP_USAGE", usage)
    assert available_memory() == 2 * GIB, "what is left below the cgroup limit"
    limit.write_text("max\n")
    assert available_memory() == 4000000 * 1024, "no limit"


def test_available_memory_falls_back_on_sysconf(tmp_path, monkeypatch):
    import sacflow.machine.resources as memory

    monkeypatch.setattr(memory, "MEMINFO", tmp_path / "no-meminfo")
    monkeypatch.setattr(memory, "CGROUP_LIMIT", tmp_path / "no-cgroup")
    expected = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    assert available_memory() == pytest.approx(expected, rel=0.1)
    assert available_memory() > 0


def test_validate_refuses_an_absurd_grid_without_traceback(capsys):
    assert main(["validate", str(HERTZ), *[f"--set={s}" for s in ABSURD]]) == 1
    captured = capsys.readouterr()
    assert captured.err.startswith("error: hertz-elastic: the run needs about")
    assert "TiB" in captured.err and "grid.nx" in captured.err and "grid.nz" in captured.err
    assert "Traceback" not in captured.err and "OK" not in captured.out


def test_validate_prints_the_estimate_of_a_small_case(capsys):
    assert main(["validate", str(HERTZ), "--set", "grid.nx=32", "--set", "grid.ny=32"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("OK hertz-elastic") and "memory " in out and "MiB" in out


#: Peak resident memory of a run in a fresh process, printed as JSON. VmHWM is the high-water
#: mark of this process's own memory map (getrusage's ru_maxrss also counts the parent's pages
#: at the fork before exec: a large pytest process would inflate it).
_MEASURE = """
import json, re, sys, tempfile
from pathlib import Path
from sacflow.storage.case_file import load_case
from sacflow.config.solver_inputs import estimate_case_memory
from sacflow.runner import run_case
case = load_case(sys.argv[1], sys.argv[2:])
with tempfile.TemporaryDirectory() as out:
    run_case(case, out, progress=False)
status = Path("/proc/self/status").read_text()
peak = int(re.search(r"VmHWM:\\s+(\\d+) kB", status).group(1)) * 1024
print(json.dumps({"peak": peak, "estimate": estimate_case_memory(case).total,
                  "numba": "numba" in sys.modules}))
"""


def _estimate_over_peak(path, overrides):
    """The estimate over the measured peak of a run in a fresh process, and both numbers."""
    out = subprocess.run([sys.executable, "-c", _MEASURE, str(path), *overrides],
                         capture_output=True, text=True, check=True)
    numbers = json.loads(out.stdout.splitlines()[-1])
    return numbers["estimate"] / numbers["peak"], numbers


@pytest.mark.slow
@pytest.mark.parametrize("path, overrides", [
    (HERTZ, []),
    (NANO, ["grid.nx=32", "grid.ny=32", "load_path.0.increments=1",
            "load_path.1.increments=1"]),
], ids=["elastic-128x128x16", "plastic-32x32x24"])
def test_estimate_is_near_the_measured_peak_or_above(path, overrides):
    ratio, numbers = _estimate_over_peak(path, overrides)
    assert 0.9 < ratio < 1.4, numbers


def test_the_libraries_estimate_holds_for_a_run_of_almost_nothing_else():
    """A 16 × 16 × 2 Hertz run is nearly all interpreter and libraries (``LIBRARY_BYTES``), in
    seconds: a heavier import shows here in the default suite. An elastic run does not load
    numba (about 50 MB): the compiled passes, once imported by every run, went unseen for
    days against an elastic figure that left numba out."""
    ratio, numbers = _estimate_over_peak(HERTZ, ["grid.nx=16", "grid.ny=16", "grid.nz=2"])
    assert not numbers["numba"], "an elastic run imported numba"
    assert 0.9 < ratio < 1.4, numbers


def test_a_large_set_up_is_announced(tmp_path, monkeypatch, capsys):
    """A run whose estimate exceeds SETUP_NOTICE_BYTES says it is setting up (no silent minute)."""
    from sacflow import runner

    monkeypatch.setattr(runner, "SETUP_NOTICE_BYTES", 0)
    case = load_case(HERTZ, ["grid.nx=16", "grid.ny=16", "grid.nz=3"])
    runner.run_case(case, tmp_path, progress=True)
    assert "setting up the operators of 16 × 16 × 3 cells" in capsys.readouterr().out


ADDRESS_SPACE_LIMITED = """
import resource, sys
from sacflow.errors import GridTooLargeError
from sacflow.machine.resources import available_memory, process_limit_left
from sacflow.config.solver_inputs import check_case_memory, estimate_case_memory
from sacflow.storage.case_file import load_case

case = load_case({config!r}, ["grid.nx=128", "grid.ny=128", "grid.nz=64"])
need = estimate_case_memory(case).total
before = available_memory()
assert process_limit_left() is None, "no limit yet"
size = next(int(line.split()[1]) * 1024 for line in open("/proc/self/status")
            if line.startswith("VmSize:"))
resource.setrlimit(resource.RLIMIT_AS, (size + need // 2, resource.RLIM_INFINITY))  # ulimit -v
left = available_memory()
try:
    check_case_memory(case)
    refused = False
except GridTooLargeError:
    refused = True
print(need, before, left, refused)
"""


def test_available_memory_honours_the_address_space_limit():
    """``ulimit -v`` below a case's estimate: refused at once (issue #31), not after 108 s."""
    config = str(Path(__file__).resolve().parents[1] / "configs" / "hertz-elastic.toml")
    result = subprocess.run(
        [sys.executable, "-c", ADDRESS_SPACE_LIMITED.format(config=config)],
        capture_output=True, text=True, timeout=120, check=True,
    )
    need, before, left, refused = result.stdout.split()
    need, before, left = int(need), int(before), int(left)
    assert left <= need // 2 and left > need // 2 - 64 * 2**20, "the limit minus VmSize"
    assert left < before
    assert refused == "True"


def test_process_limit_left_is_the_smaller_of_the_limits():
    script = (
        "import resource\n"
        "from sacflow.machine.resources import process_limit_left\n"
        "s = {l.split(':')[0]: int(l.split()[1]) * 1024 for l in open('/proc/self/status')\n"
        "     if l.startswith(('VmData', 'VmSize'))}\n"
        "resource.setrlimit(resource.RLIMIT_DATA, (s['VmData'] + 2**28, resource.RLIM_INFINITY))\n"
        "resource.setrlimit(resource.RLIMIT_AS, (s['VmSize'] + 2**30, resource.RLIM_INFINITY))\n"
        "print(process_limit_left())\n"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                            timeout=60, check=True)
    assert 2**28 - 2**24 < int(result.stdout) <= 2**28, "ulimit -d, the smaller room, counts"


def test_fft_threads_above_the_cores_are_capped_with_a_warning(monkeypatch, capsys):
    """Issue #31: SACFLOW_FFT_THREADS=100000 made the estimate 2 TiB (per-thread set-up
    buffers times 100000) and refused the case. Now capped at the usable cores, with a warning
    naming the variable, the cores and the fix; the estimate is that of that many threads."""
    from sacflow.kernels.eigenstrain_memory import setup_bytes
    from sacflow.kernels.fft import default_threads
    from sacflow.machine import environment, resources

    monkeypatch.setattr(resources, "usable_cores", lambda: 2)
    monkeypatch.setattr(environment, "WARNED_FFT_THREADS", set())
    monkeypatch.setenv("SACFLOW_FFT_THREADS", "100000")
    with pytest.warns(RuntimeWarning, match=r"SACFLOW_FFT_THREADS=100000 is more than the 2 "
                      r"cores.*using 2 threads \(set it to at most 2, or unset it"):
        assert default_threads() == 2
    shape = (64, 64, 24)
    assert setup_bytes(shape) == setup_bytes(shape, threads=2)
    monkeypatch.setenv("SACFLOW_FFT_THREADS", "2")  # at the cores: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert default_threads() == 2
    monkeypatch.setenv("SACFLOW_FFT_THREADS", "100000")
    assert main(["validate", str(CONFIGS / "nanoindentation-650mN.toml")]) == 0
    assert "OK nanoindentation-650mN" in capsys.readouterr().out
