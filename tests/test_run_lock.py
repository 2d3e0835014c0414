"""One process per run file (issue #31): a second writer of the same run refuses, naming the first.

Two real processes: a writer holding the run (the script of ``test_store``, slow steps) and
``sacflow run`` of the same case into the same folder, or a writer in this process.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from test_store import CONFIG, WRITER_SCRIPT, make_coords, make_state, small_case

from sacflow.storage.run_lock import RunBusyError, RunLock, lock_path
from sacflow.storage.run_reader import completed_steps, run_info
from sacflow.storage.run_writer import RunWriter

#: ``sacflow run`` options giving the case of ``small_case()``.
SMALL = ["--set", "grid.nx=16", "--set", "grid.ny=16", "--set", "grid.nz=3"]


@pytest.fixture
def holder(tmp_path):
    """A process writing ``<tmp>/hertz-elastic.nc`` step by step (0.6 s a step), and its path."""
    path = tmp_path / f"{small_case().name}.nc"
    script = WRITER_SCRIPT.format(tests=str(Path(__file__).parent), path=str(path))
    proc = subprocess.Popen([sys.executable, "-c", script])
    try:
        deadline = time.monotonic() + 60
        while completed_steps(path) < 1:
            assert proc.poll() is None, "writer process ended early"
            assert time.monotonic() < deadline, "writer too slow"
            time.sleep(0.05)
        yield proc, path
    finally:
        proc.kill()
        proc.wait()


def test_second_sacflow_run_refuses_naming_the_first(holder):
    proc, path = holder
    result = subprocess.run(
        [sys.executable, "-m", "sacflow.cli", "run", str(CONFIG), *SMALL, "--out",
         str(path.parent), "--no-progress"],
        capture_output=True, text=True, timeout=300, check=False,
    )
    assert proc.poll() is None, "the first writer is still running"
    assert result.returncode == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert f"process {proc.pid} on host {socket.gethostname()}" in result.stderr
    assert "is being written by another sacflow run" in result.stderr
    assert "started 20" in result.stderr  # the holder's start time (ISO date)


def test_writer_in_another_process_refuses_then_takes_over_a_dead_ones_lock(holder):
    proc, path = holder
    case = small_case()
    coords = make_coords(case)
    with pytest.raises(RunBusyError, match=f"process {proc.pid} on host"):
        RunWriter(path, case, coords, keep_steps=1)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert lock_path(path).exists(), "the killed writer left its lock file"
    done = completed_steps(path)
    with RunWriter(path, case, coords, keep_steps=done) as writer:  # taken over
        assert writer.lock.held
        for step in range(done, 5):
            writer.append(make_state(step, coords, volume=step % 2 == 0))
    assert run_info(path).complete and run_info(path).steps == 5
    assert not lock_path(path).exists(), "released at the end"


def test_a_writer_whose_look_is_out_of_date_refuses(tmp_path):
    case = small_case()
    coords = make_coords(case)
    path = tmp_path / "run.nc"
    looked = run_info(path)  # nothing there yet ...
    with RunWriter(path, case, coords) as other:  # ... then another writer stores a step
        other.append(make_state(0, coords))
        other.abort()
    with pytest.raises(RunBusyError, match="written by another process since"):
        RunWriter(path, case, coords, info=looked)
    assert completed_steps(path) == 1, "nothing was changed"
    assert not lock_path(path).exists()


def test_lock_in_one_process_is_exclusive(tmp_path):
    first, second = RunLock(tmp_path / "a.nc"), RunLock(tmp_path / "a.nc")
    with first:
        with pytest.raises(RunBusyError, match=f"process {os.getpid()}"):
            second.acquire()
    with second:  # released
        assert second.held
