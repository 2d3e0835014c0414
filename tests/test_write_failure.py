"""A run that cannot be written, a file that is not a run: sacflow's own messages (issue #31).

The full disk is simulated with the file size limit (``RLIMIT_FSIZE``, ``ulimit -f``) in a
subprocess, SIGXFSZ ignored: HDF5 then fails exactly as on a full disk (``NetCDF: HDF error``,
the errno lost). An ``OSError`` carrying ENOSPC is described by its errno.
"""

from __future__ import annotations

import errno
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from test_store import assert_step_matches, make_coords, make_state, small_case, write_run

import sacflow
from sacflow.cli import main
from sacflow.storage.run_lock import lock_path
from sacflow.storage.run_reader import RunFileError, RunNotFoundError, run_info
from sacflow.storage.run_writer import RunWriter
from sacflow.storage.write_failure import RunWriteError, describe_write_failure

TESTS = Path(__file__).resolve().parent
#: A part of the small case is 386 kB, its 3-step consolidated file 628 kB.
BETWEEN_PART_AND_RUN, BELOW_PART = 500_000, 100_000

LIMITED_WRITER = """
import resource, signal, sys
sys.path.insert(0, {tests!r})
from test_store import make_coords, make_state, small_case
from sacflow.storage.run_writer import RunWriter
from sacflow.storage.write_failure import RunWriteError

case = small_case()
coords = make_coords(case)
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, resource.RLIM_INFINITY))
try:
    with RunWriter({path!r}, case, coords) as writer:
        for step in range(3):
            writer.append(make_state(step, coords))
except RunWriteError as exc:
    print(exc)
    sys.exit(3)
"""


def write_limited(path: Path, limit: int) -> subprocess.CompletedProcess[str]:
    script = LIMITED_WRITER.format(tests=str(TESTS), path=str(path), limit=limit)
    return subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120, check=False)


def test_full_disk_while_consolidating_keeps_the_steps_and_resumes(tmp_path):
    path = tmp_path / "run.nc"
    result = write_limited(path, BETWEEN_PART_AND_RUN)
    assert result.returncode == 3, result.stderr
    message = result.stdout
    assert f"{path}: writing the consolidated file failed" in message
    assert "file size limit (ulimit -f) is 500000 bytes" in message
    assert "The 3 completed steps are kept" in message and "run the same case again" in message
    info = run_info(path)
    assert not path.exists() and info.steps == 3 and not info.damaged
    assert not lock_path(path).exists()
    assert not list(tmp_path.glob(".run.nc.*.tmp")), "the temporary file is removed"

    case, coords = small_case(), make_coords(small_case())
    RunWriter(path, case, coords, keep_steps=3).close()  # space again: consolidated
    ds = sacflow.open_run(path)
    assert ds.attrs["complete"] == 1
    for index in range(3):
        assert_step_matches(ds, index, make_state(index, coords))


def test_full_disk_at_the_first_step(tmp_path):
    path = tmp_path / "run.nc"
    result = write_limited(path, BELOW_PART)
    assert result.returncode == 3, result.stderr
    assert "writing step 0 failed" in result.stdout and "The 0 completed steps" in result.stdout
    assert run_info(path).steps == 0 and not run_info(path).damaged


def test_errno_names_the_resource(tmp_path):
    no_space = OSError(errno.ENOSPC, "No space left on device")
    assert "the disk is full" in describe_write_failure(no_space, tmp_path)
    assert "input/output error" in describe_write_failure(OSError(errno.EIO, "EIO"), tmp_path)
    assert "failed" in describe_write_failure(RuntimeError("NetCDF: HDF error"), tmp_path)
    with pytest.raises(RunWriteError):
        raise RunWriteError("x")


# --------------------------------------------------------------------------- files not runs
@pytest.fixture(scope="module")
def bad_files(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("bad")
    case = small_case()
    good = folder / "good.nc"
    write_run(good, case, make_coords(case), [True, True])
    data = good.read_bytes()
    files = {
        "truncated": data[: len(data) // 2],
        "header only": data[:3000],
        "garbage": b"garbage" * 100,
        "empty": b"",
        "manifest": b'{"campaign": "x", "cases": []}',
        "toml": b'name = "x"\n[body]\nE = 210e9\n',
    }
    paths = {}
    for kind, content in files.items():
        suffix = {"manifest": ".manifest.json", "toml": ".toml"}.get(kind, ".nc")
        paths[kind] = folder / f"{kind.replace(' ', '-')}{suffix}"
        paths[kind].write_bytes(content)
    paths["netcdf, not a run"] = folder / "other.nc"
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(paths["netcdf, not a run"])
    return paths


EXPECTED = {
    "truncated": "a damaged or truncated netCDF file",
    "header only": "a damaged or truncated netCDF file",
    "garbage": "not a netCDF file",
    "empty": "an empty file",
    "manifest": "open a campaign with sacflow.open_campaign",
    "toml": "a case or campaign file",
    "netcdf, not a run": "a netCDF file, but not a sacflow run",
}


@pytest.mark.parametrize("kind", list(EXPECTED))
@pytest.mark.parametrize("lazy", [False, True])
def test_open_run_names_the_file_and_what_it_is(bad_files, kind, lazy):
    path = bad_files[kind]
    with pytest.raises(RunFileError) as caught:
        sacflow.open_run(path, lazy=lazy)
    assert str(caught.value).startswith(f"{path}: ") and EXPECTED[kind] in str(caught.value)
    assert "IO backends" not in str(caught.value)


def test_open_run_of_nothing_is_a_file_not_found_error(tmp_path):
    with pytest.raises(RunNotFoundError, match="no run at") as caught:
        sacflow.open_run(tmp_path / "absent.nc")
    assert isinstance(caught.value, FileNotFoundError)


STAGE_ARGUMENTS = {
    "hertz-check": [],
    "indentation": [],
    "track": [],
    "residual-map": ["--depth", "1e-6"],
    "fatigue": ["--bending-limit", "4e8", "--torsion-limit", "3e8"],
    "passes": [],
    "melan": [],
    "load-approach": [],
    "campaign-summary": [],
    "case-vs-reference": ["--reference", "ref.csv", "--variable", "pressure"],
}


@pytest.mark.parametrize("stage", list(STAGE_ARGUMENTS))
@pytest.mark.parametrize("kind", ["truncated", "garbage", "manifest", "toml"])
def test_compare_stages_refuse_files_that_are_not_runs(bad_files, stage, kind, tmp_path, capsys):
    path = bad_files[kind]
    code = main(["compare", stage, str(path), *STAGE_ARGUMENTS[stage], "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("error: ") and str(path) in err and "Traceback" not in err
    expected = EXPECTED[kind]
    if (stage, kind) == ("campaign-summary", "manifest"):  # it reads manifests (of no case here)
        expected = "no finished case in the manifest"
    assert "IO backends" not in err and expected in err
