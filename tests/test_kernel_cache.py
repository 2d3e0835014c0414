"""The disk cache of kernel spectra (sacflow.machine.kernel_cache): hits equal misses bit for bit,
concurrent writers, damaged entries, the size limit, clearing, where it lives, the command."""

from __future__ import annotations

import errno
import multiprocessing as mp
import os
import time
import warnings

import numpy as np
import pytest

from sacflow.cli import main
from sacflow.errors import EnvironmentVariableError
from sacflow.kernels.eigenstrain import HalfSpaceEigenstrain
from sacflow.machine import kernel_cache

E, NU = 210e9, 0.3


@pytest.fixture
def cache(tmp_path, monkeypatch):
    root = tmp_path / "kernels"
    monkeypatch.setenv("SACFLOW_CACHE_DIR", str(root))
    monkeypatch.delenv("SACFLOW_CACHE_MAX_BYTES", raising=False)
    monkeypatch.setattr(kernel_cache, "MIN_CACHED_BYTES", 0)  # small test grids are stored
    return root


def arrays(seed: int = 0, n: int = 1000) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {"a": rng.standard_normal(n), "b": rng.standard_normal((3, n))}


def test_operator_from_the_cache_equals_the_computed_one_bit_for_bit(cache):
    shape, spacing = (9, 8, 5), (1.0e-6, 1.2e-6, 0.6e-6)
    eps = np.random.default_rng(1).standard_normal((*shape, 6)) * 1e-3
    computed = HalfSpaceEigenstrain(shape, spacing, E, NU)
    assert [e.kind for e in kernel_cache.list_entries(cache)] == ["eigenstrain"]
    loaded = HalfSpaceEigenstrain(shape, spacing, E, NU)
    spectra = loaded.pair_spectra
    assert isinstance(spectra.base, np.memmap) or isinstance(spectra, np.memmap)
    for name in ("pair_spectra", "surface_spectra", "correction_spectra"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(computed, name))
    s1, u1 = computed.residual_stress(eps, with_displacement=True)
    s2, u2 = loaded.residual_stress(eps, with_displacement=True)
    np.testing.assert_array_equal(s1, s2)
    np.testing.assert_array_equal(u1, u2)
    # another Poisson ratio is another entry
    HalfSpaceEigenstrain(shape, spacing, E, 0.25)
    assert len(kernel_cache.list_entries(cache)) == 2


def test_contact_stress_operator_from_the_cache_equals_the_computed_one(cache):
    """The pressure-to-stress kernels are cached too: a second simulation of the same grid
    loads them (memory-mapped) and its stresses are the same bit for bit; another case's
    kernels (friction adds the traction's stress) are another entry."""
    from pathlib import Path

    from sacflow.config.solver_inputs import simulation_for
    from sacflow.storage.case_file import load_case

    config = Path(__file__).resolve().parents[1] / "configs" / "rolling-cycles-shakedown.toml"
    small = ["grid.nx=12", "grid.ny=12", "grid.nz=4", "load_path.1.steps=2"]
    first = simulation_for(load_case(config, small))
    entries = kernel_cache.list_entries(cache)
    assert sorted(e.kind for e in entries) == ["contact_stress", "eigenstrain"]
    listed = {e.kind: e.parameters["shape"] for e in entries}  # what `sacflow cache` shows
    assert listed["contact_stress"] == [*first.body_shape, first.nz] == listed["eigenstrain"]
    second = simulation_for(load_case(config, small))
    spectra = second.operators.pressure_stress_op.spectra
    assert isinstance(spectra, np.memmap) or isinstance(spectra.base, np.memmap)
    np.testing.assert_array_equal(spectra, first.operators.pressure_stress_op.spectra)
    pressure = np.random.default_rng(2).random(first.body_shape)
    np.testing.assert_array_equal(second.operators.body_pressure_stress(pressure),
                                  first.operators.body_pressure_stress(pressure))
    simulation_for(load_case(config, [*small, "friction.coefficient=0.2"]))
    kinds = sorted(e.kind for e in kernel_cache.list_entries(cache))
    assert kinds == ["contact_stress", "contact_stress", "eigenstrain"]


@pytest.mark.parametrize("n", [0, 1, 511, 1024, 5000])
@pytest.mark.parametrize("route", ["direct", "no O_DIRECT", "refused"])
def test_array_files_are_whole_and_block_aligned(tmp_path, monkeypatch, n, route):
    """The arrays' files, written past the page cache or not: numpy reads them back bit for bit,
    the data starts on a 4096-byte block, nothing follows it; small bounce chunks so that the
    writes cross chunk and block boundaries."""
    monkeypatch.setattr(kernel_cache, "DIRECT_CHUNK_BYTES", 3 * 4096)
    if route == "no O_DIRECT":
        monkeypatch.delattr(os, "O_DIRECT", raising=False)
    elif route == "refused":
        def refuse(*args):
            raise OSError(errno.EINVAL, "O_DIRECT refused")

        monkeypatch.setattr(kernel_cache, "copy_out_direct", refuse)
    rng = np.random.default_rng(n)
    for array in (rng.standard_normal(n), rng.standard_normal((3, n)).astype(np.float32),
                  rng.standard_normal((n, 2)) + 1j):
        path = tmp_path / "a.npy"
        kernel_cache.write_npy(path, np.ascontiguousarray(array))
        with open(path, "rb") as fh:
            assert np.lib.format.read_magic(fh) == (1, 0)
            np.lib.format.read_array_header_1_0(fh)
            assert fh.tell() == 4096
        assert path.stat().st_size == 4096 + array.nbytes
        loaded = np.load(path, mmap_mode="r")
        assert loaded.dtype == array.dtype and loaded.shape == array.shape
        assert np.array_equal(loaded, array)


def test_hit_does_not_compute(cache):
    calls = []

    def compute():
        calls.append(1)
        return arrays()

    first = kernel_cache.cached_arrays("test", {"n": 1}, compute)
    second = kernel_cache.cached_arrays("test", {"n": 1}, compute)
    assert len(calls) == 1
    assert not second["a"].flags.writeable
    np.testing.assert_array_equal(first["b"], second["b"])
    kernel_cache.cached_arrays("test", {"n": 2}, compute)
    assert len(calls) == 2
    with pytest.raises(ValueError, match="lower-case"):
        kernel_cache.cached_arrays("not-listed", {"n": 1}, compute)


@pytest.mark.skipif(not hasattr(os, "posix_fadvise") or not os.path.isdir("/proc/self/fd"),
                    reason="posix_fadvise and /proc are Linux's")
def test_every_array_file_is_read_ahead_before_any_is_hashed(cache, monkeypatch):
    """A load asks for all of an entry's files at once: the disk gets large requests."""
    import xxhash

    kernel_cache.cached_arrays("test", {"n": 1}, arrays)  # stored
    events: list[tuple[str, ...]] = []
    advise, hash_of = os.posix_fadvise, xxhash.xxh3_64

    def recorded_advise(fd: int, offset: int, length: int, advice: int) -> None:
        name = os.path.basename(os.readlink(f"/proc/self/fd/{fd}"))
        events.append(("ahead", name, str(advice == os.POSIX_FADV_WILLNEED)))
        advise(fd, offset, length, advice)

    def recorded_hash(*data):
        events.append(("hash",))
        return hash_of(*data)

    monkeypatch.setattr(os, "posix_fadvise", recorded_advise)
    monkeypatch.setattr(xxhash, "xxh3_64", recorded_hash)
    monkeypatch.setattr(kernel_cache, "VERIFIED_FILES", set())  # verified again, as a new process
    loaded = kernel_cache.cached_arrays("test", {"n": 1}, arrays)
    ahead = [e for e in events if e[0] == "ahead"]
    assert sorted(e[1] for e in ahead) == ["a.npy", "b.npy"]
    assert all(e[2] == "True" for e in ahead)
    assert events.index(("hash",)) > max(events.index(e) for e in ahead)
    np.testing.assert_array_equal(loaded["b"], arrays()["b"])


def test_read_ahead_of_a_missing_file_does_nothing(tmp_path):
    kernel_cache.read_ahead(tmp_path / "absent.npy")  # the load reports it, not the advice


def _store_slowly(root: str, barrier, queue) -> None:
    os.environ["SACFLOW_CACHE_DIR"] = root
    kernel_cache.MIN_CACHED_BYTES = 0

    def compute():
        barrier.wait()  # both processes have missed before either stores
        time.sleep(0.2)
        return arrays(seed=3, n=200_000)

    out = kernel_cache.cached_arrays("race", {"n": 7}, compute)
    queue.put(float(out["b"].sum()))


def test_concurrent_writers_leave_one_whole_entry(cache):
    ctx = mp.get_context("spawn")
    barrier, queue = ctx.Barrier(2), ctx.Queue()
    procs = [ctx.Process(target=_store_slowly, args=(str(cache), barrier, queue))
             for _ in range(2)]
    for p in procs:
        p.start()
    sums = [queue.get(timeout=120) for _ in procs]
    for p in procs:
        p.join(timeout=60)
        assert p.exitcode == 0
    assert sums[0] == sums[1]
    entries = kernel_cache.list_entries(cache)
    assert len(entries) == 1
    assert [p.name for p in cache.iterdir()] == [entries[0].path.name]  # no temporary left
    loaded = kernel_cache.cached_arrays("race", {"n": 7}, lambda: pytest.fail("recomputed"))
    np.testing.assert_array_equal(loaded["b"], arrays(seed=3, n=200_000)["b"])


def test_damaged_entry_is_computed_again_with_a_warning(cache):
    kernel_cache.cached_arrays("test", {"n": 1}, arrays)
    (entry,) = kernel_cache.list_entries(cache)
    with open(entry.path / "b.npy", "r+b") as fh:
        fh.truncate(100)
    with pytest.warns(RuntimeWarning, match="damaged"):
        out = kernel_cache.cached_arrays("test", {"n": 1}, arrays)
    np.testing.assert_array_equal(out["b"], arrays()["b"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # stored again, whole
        np.testing.assert_array_equal(
            kernel_cache.cached_arrays("test", {"n": 1}, arrays)["b"], arrays()["b"])


def _flip_high_order_bytes(path, count: int = 8) -> None:
    """Flip the exponent byte of ``count`` float64 values in the data of a ``.npy`` file."""
    data_start = os.path.getsize(path) - np.load(path, mmap_mode="r").nbytes
    with open(path, "r+b") as fh:
        for k in range(count):
            fh.seek(data_start + 8 * (3 * k + 1) + 7)  # little-endian: byte 7 holds the exponent
            byte = fh.read(1)[0]
            fh.seek(-1, os.SEEK_CUR)
            fh.write(bytes([byte ^ 0x7C]))


def test_flipped_bits_in_an_entry_are_found_and_the_operator_computed_again(cache, monkeypatch):
    """Issue #31: flipping exponent bytes in a cached spectrum gave stresses of 1e299 and a
    finished run. The checksum finds it; the operator is computed again, with a warning, and
    its stresses are those of an operator computed without the cache, bit for bit."""
    shape, spacing = (9, 8, 5), (1.0e-6, 1.2e-6, 0.6e-6)
    eps = np.random.default_rng(1).standard_normal((*shape, 6)) * 1e-3
    HalfSpaceEigenstrain(shape, spacing, E, NU)  # computed and stored
    (entry,) = kernel_cache.list_entries(cache)
    damaged = sorted(entry.path.glob("*.npy"))[0]
    _flip_high_order_bytes(damaged)
    with pytest.warns(RuntimeWarning, match=r"does not match its checksum\); computing it again"):
        recomputed = HalfSpaceEigenstrain(shape, spacing, E, NU)
    monkeypatch.setenv("SACFLOW_CACHE_DIR", "off")
    uncached = HalfSpaceEigenstrain(shape, spacing, E, NU)
    s1, u1 = recomputed.residual_stress(eps, with_displacement=True)
    s2, u2 = uncached.residual_stress(eps, with_displacement=True)
    np.testing.assert_array_equal(s1, s2)
    np.testing.assert_array_equal(u1, u2)
    monkeypatch.setenv("SACFLOW_CACHE_DIR", str(cache))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # stored again, whole, and verified on this load
        loaded = HalfSpaceEigenstrain(shape, spacing, E, NU)
    np.testing.assert_array_equal(loaded.residual_stress(eps), s2)


def test_entry_without_a_checksum_is_computed_again_with_a_warning(cache):
    """An entry written before the checksums cannot be verified: computed again, once."""
    import json

    kernel_cache.cached_arrays("test", {"n": 1}, arrays)
    (entry,) = kernel_cache.list_entries(cache)
    record = json.loads((entry.path / "entry.json").read_text())
    del record["checksum"]
    for spec in record["arrays"].values():
        del spec[kernel_cache.CHECKSUM_ALGORITHM]
    (entry.path / "entry.json").write_text(json.dumps(record))
    with pytest.warns(RuntimeWarning, match="without a checksum"):
        kernel_cache.cached_arrays("test", {"n": 1}, arrays)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = kernel_cache.cached_arrays("test", {"n": 1}, lambda: pytest.fail("recomputed"))
    np.testing.assert_array_equal(out["b"], arrays()["b"])


def test_checksum_is_that_of_the_file_written(cache, tmp_path):
    array = np.random.default_rng(2).standard_normal((5, 7, 3))
    path = tmp_path / "x.npy"
    assert kernel_cache.write_npy(path, array) == kernel_cache.file_checksum(path)


def test_record_of_other_parameters_is_not_used(cache):
    kernel_cache.cached_arrays("test", {"n": 1}, arrays)
    (entry,) = kernel_cache.list_entries(cache)
    record = (entry.path / "entry.json").read_text().replace('"n": 1', '"n": 5')
    (entry.path / "entry.json").write_text(record)
    with pytest.warns(RuntimeWarning, match="other parameters"):
        kernel_cache.cached_arrays("test", {"n": 1}, arrays)


def test_least_recently_used_entries_go_beyond_the_limit(cache, monkeypatch):
    kernel_cache.cached_arrays("test", {"n": 0}, arrays)
    (entry,) = kernel_cache.list_entries(cache)
    size = entry.nbytes  # on disk: the arrays, their headers and the record
    monkeypatch.setenv("SACFLOW_CACHE_MAX_BYTES", str(int(2.5 * size)))
    time.sleep(0.01)
    for n in range(1, 3):
        kernel_cache.cached_arrays("test", {"n": n}, arrays)
        time.sleep(0.01)
    kernel_cache.cached_arrays("test", {"n": 0}, arrays)  # a hit: now the most recent
    time.sleep(0.01)
    kernel_cache.cached_arrays("test", {"n": 3}, arrays)
    kept = sorted(e.parameters["n"] for e in kernel_cache.list_entries(cache))
    assert kept == [0, 3]
    monkeypatch.setenv("SACFLOW_CACHE_MAX_BYTES", str(size // 2))  # larger than the limit
    kernel_cache.cached_arrays("test", {"n": 9}, arrays)
    assert 9 not in [e.parameters["n"] for e in kernel_cache.list_entries(cache)]


def test_small_arrays_are_not_stored(cache, monkeypatch):
    monkeypatch.setattr(kernel_cache, "MIN_CACHED_BYTES", 10**9)
    kernel_cache.cached_arrays("test", {"n": 1}, arrays)
    assert kernel_cache.list_entries(cache) == []


def test_clear_removes_entries_and_leftovers(cache):
    for n in range(2):
        kernel_cache.cached_arrays("test", {"n": n}, arrays)
    (cache / f".test-{'a' * 24}.x1y2").mkdir()  # an interrupted write (tempfile.mkdtemp)
    (cache / f".trash-test-{'b' * 24}-123").mkdir()  # an interrupted removal
    report = kernel_cache.clear_cache(cache)
    assert report.removed == 2 and report.removed_bytes > 0 and report.not_removed == ()
    assert list(cache.iterdir()) == []


def test_clear_of_a_read_only_cache_says_what_it_could_not_remove(cache, monkeypatch, capsys):
    """Issue #31: on a read-only cache, clear said 'removed 1 entries, 48.4 MiB' (rc 0)."""
    kernel_cache.cached_arrays("test", {"n": 1}, arrays)
    (entry,) = kernel_cache.list_entries(cache)

    def read_only(src, dst):
        raise OSError(errno.EROFS, "Read-only file system", str(src))

    monkeypatch.setattr(kernel_cache.os, "rename", read_only)
    report = kernel_cache.clear_cache(cache)
    assert (report.removed, report.removed_bytes) == (0, 0)
    assert report.not_removed == ((entry.path, "Read-only file system"),)
    assert main(["cache", "clear"]) == 1
    captured = capsys.readouterr()
    assert "removed 0 entries, 0 B" in captured.out
    assert f"could not remove {entry.path}: Read-only file system" in captured.err
    assert kernel_cache.list_entries(cache) == [entry]


def test_cache_directory_that_is_a_file_is_a_clear_error(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("SACFLOW_CACHE_DIR", str(blocker))
    with pytest.raises(NotADirectoryError, match="not a directory"):
        kernel_cache.clear_cache(blocker)
    for action in (["cache"], ["cache", "clear"]):
        assert main(action) == 2
        assert f"the kernel cache {blocker} is a file, not a directory" in capsys.readouterr().err
    assert blocker.read_text() == "not a directory"


def test_clear_keeps_what_the_cache_did_not_write(cache):
    """SACFLOW_CACHE_DIR may point at a folder of the user's: only cache entries go."""
    kernel_cache.cached_arrays("test", {"n": 1}, arrays)
    mine = [cache / ".git", cache / "results", cache / "notes-2026"]
    for folder in mine:
        folder.mkdir()
        (folder / "entry.json").write_text("{}")  # even with a file named like the record
    (cache / "data.npy").write_bytes(b"x")
    assert kernel_cache.clear_cache(cache).removed == 1
    assert sorted(p.name for p in cache.iterdir()) == sorted(
        [*(p.name for p in mine), "data.npy"])


def test_location_xdg_and_off(tmp_path, monkeypatch):
    monkeypatch.delenv("SACFLOW_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert kernel_cache.cache_directory() == tmp_path / "xdg" / "sacflow" / "kernels"
    monkeypatch.setenv("SACFLOW_CACHE_DIR", "off")
    assert kernel_cache.cache_directory() is None
    monkeypatch.setenv("SACFLOW_CACHE_DIR", str(tmp_path / "mine"))
    assert kernel_cache.cache_directory() == tmp_path / "mine"


def test_unwritable_cache_warns_and_computes(tmp_path, monkeypatch):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("SACFLOW_CACHE_DIR", str(blocker / "kernels"))
    monkeypatch.setattr(kernel_cache, "MIN_CACHED_BYTES", 0)
    monkeypatch.setattr(kernel_cache, "WARNED_DIRECTORIES", set())
    with pytest.warns(RuntimeWarning, match="cannot be written"):
        out = kernel_cache.cached_arrays("test", {"n": 1}, arrays)
    np.testing.assert_array_equal(out["a"], arrays()["a"])


@pytest.mark.parametrize(("text", "nbytes"), [("1048576", 1 << 20), ("20G", 20 << 30),
                                               ("1.5k", 1536), ("500MB", 500 << 20),
                                               ("2 GiB", 2 << 30)])
def test_size_limit_from_the_environment(monkeypatch, text, nbytes):
    monkeypatch.setenv("SACFLOW_CACHE_MAX_BYTES", text)
    assert kernel_cache.max_bytes() == nbytes


@pytest.mark.parametrize("text", ["lots", "-3G", "12X", "G"])
def test_bad_size_limit_is_refused_with_the_fix(monkeypatch, text):
    monkeypatch.setenv("SACFLOW_CACHE_MAX_BYTES", text)
    with pytest.raises(EnvironmentVariableError, match="SACFLOW_CACHE_MAX_BYTES.*e.g. 20G"):
        kernel_cache.max_bytes()


def test_cache_command_lists_and_clears(cache, capsys):
    kernel_cache.cached_arrays("eigenstrain", {"shape": [4, 5, 6]}, arrays)
    assert main(["cache"]) == 0
    out = capsys.readouterr().out
    assert f"kernel cache {cache}: 1 entries" in out and "4 × 5 × 6 cuboids" in out
    assert main(["cache", "clear"]) == 0
    assert "removed 1 entries" in capsys.readouterr().out
    assert kernel_cache.list_entries(cache) == []


_PLAN_AND_EXIT = """
import json, sys
from sacflow.kernels import fftw_wisdom
from sacflow.kernels.fft import RealFFT, pyfftw
fftw_wisdom.load_wisdom()
before = pyfftw.export_wisdom()
RealFFT((512, 512), 2)  # 2^18 points: a measured plan
print(json.dumps({"imported": any(len(w) > 200 for w in before)}))
"""


def _plan_in_a_process(cache_dir: str) -> dict:
    import json
    import subprocess
    import sys

    env = {**os.environ, "SACFLOW_CACHE_DIR": cache_dir}
    out = subprocess.run([sys.executable, "-c", _PLAN_AND_EXIT], env=env, check=True,
                         capture_output=True, text=True).stdout
    return json.loads(out)


def test_fftw_wisdom_is_kept_for_the_next_process(tmp_path):
    from sacflow.kernels import fftw_wisdom

    root = tmp_path / "kernels"
    assert _plan_in_a_process(str(root)) == {"imported": False}  # nothing stored yet
    (path,) = root.glob("fftw-wisdom-*.json")
    assert path == fftw_wisdom.wisdom_path(root)
    assert _plan_in_a_process(str(root)) == {"imported": True}
    # a damaged file is ignored and replaced
    path.write_text("not wisdom")
    assert _plan_in_a_process(str(root)) == {"imported": False}
    assert _plan_in_a_process(str(root)) == {"imported": True}
    assert kernel_cache.clear_cache(root) == kernel_cache.ClearReport(0, 0)
    assert list(root.iterdir()) == []


def test_no_fftw_wisdom_with_the_cache_off(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert _plan_in_a_process("off") == {"imported": False}
    assert list(tmp_path.rglob("fftw-wisdom-*")) == []


def test_run_with_a_flipped_cached_spectrum_equals_a_run_without_the_cache(cache, tmp_path,
                                                                           monkeypatch):
    """Issue #31 end to end: high-order bytes flipped in a stored pressure-to-stress spectrum
    ('spectra.npy') gave a finished run with stresses of 1e299. The damaged entry is computed
    again, with a warning, and the run's results are those of a run without the cache."""
    from pathlib import Path

    import sacflow

    config = Path(__file__).resolve().parents[1] / "configs" / "nanoindentation-650mN.toml"
    small = ["grid.nx=16", "grid.ny=16", "grid.nz=4", "load_path.0.increments=2",
             "load_path.1.increments=1"]
    case = sacflow.load_case(config, small)
    sacflow.run(case, tmp_path / "first", progress=False).close()  # stores the entries
    (spectra,) = cache.glob("contact_stress-*/spectra.npy")
    _flip_high_order_bytes(spectra, count=64)
    with pytest.warns(RuntimeWarning, match=r"does not match its checksum\); computing it"):
        cached = sacflow.run(case, tmp_path / "damaged", progress=False)
    monkeypatch.setenv("SACFLOW_CACHE_DIR", "off")
    uncached = sacflow.run(case, tmp_path / "uncached", progress=False)
    with cached, uncached:
        assert np.isfinite(cached["stress"].values).all()
        for name in ("stress", "pressure", "plastic_strain"):
            np.testing.assert_array_equal(cached[name].values, uncached[name].values,
                                          err_msg=name)
