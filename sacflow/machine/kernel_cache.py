"""Disk cache of kernel spectra: a case's set-up is paid once per grid, not once per run.

The influence coefficients of a grid and their spectra depend only on the grid (shape, cell
sizes), the elastic constants and the code that computes them; a campaign of many loads or
dents on one grid, or a run started again, computes the same arrays every time (a minute at
128 × 128 × 64 cuboids before this cache). They are kept here, keyed by everything that
determines them, and memory-mapped read-only on a hit: processes that share a grid share the
pages.

Where: ``$SACFLOW_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/sacflow/kernels`` (by default
``~/.cache/sacflow/kernels``). ``SACFLOW_CACHE_DIR=off`` disables the cache. Grids whose
arrays are small (:data:`MIN_CACHED_BYTES`) are not stored. Size limit:
``$SACFLOW_CACHE_MAX_BYTES`` (a number of bytes, or with a K, M, G or T suffix; default
:data:`DEFAULT_MAX_BYTES`); the least recently used entries are removed beyond it, and an
entry larger than the limit is not stored. ``sacflow cache info`` lists the entries,
``sacflow cache clear`` removes them (and FFTW's wisdom files, :mod:`sacflow.kernels.fftw_wisdom`).
The arrays' files are written past the page cache where the system allows it
(:func:`write_npy`).

Safe concurrent use (campaign workers share the cache): an entry is written into a private
temporary directory, flushed, and renamed into place in one step; when two processes compute
the same entry the second rename fails and that process keeps its own arrays. An entry is
removed by renaming it away first, so a reader sees a whole entry or none; files already
mapped stay valid after removal (POSIX).

Integrity: the record holds a checksum of every array file (xxHash's XXH3, 64 bits, of the file's
bytes, computed from the arrays while they are written), and an entry is verified against it
the first time a process loads it (every byte is read once; the pages are then in memory for
the solver, which reads them all anyway). A damaged entry (unreadable, truncated, a flipped
bit, arrays not matching its record) is removed and computed again, with a warning. An entry
written before the checksums existed (no checksum in its record) cannot be verified: it is
treated as damaged and computed again (the warning says so), once.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import mmap
import os
import re
import shutil
import tempfile
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xxhash

from sacflow.machine.environment import CACHE_OFF, cache_dir_from_env, cache_max_bytes_from_env

__all__ = [
    "DEFAULT_MAX_BYTES",
    "MIN_CACHED_BYTES",
    "CacheEntry",
    "ClearReport",
    "cache_directory",
    "cached_arrays",
    "clear_cache",
    "list_entries",
    "max_bytes",
]

#: Default size limit of the cache (an entry of a 128 × 128 × 64 box takes about 1.4 GB).
DEFAULT_MAX_BYTES = 16 << 30
#: Arrays smaller than this are not stored: they are computed in well under a second (a
#: 48 × 48 × 24 box), and the cache is kept for the grids whose set-up costs.
MIN_CACHED_BYTES = 32 << 20
_RECORD = "entry.json"
#: Checksum of the array files, named in the record (:func:`file_checksum`).
CHECKSUM_ALGORITHM = "xxh3_64"
#: Bytes read and hashed per call when a file is verified: a buffer that stays in the CPU cache.
_VERIFY_CHUNK_BYTES = 1 << 20
#: Names the cache writes in its directory, and the only ones it ever removes (the directory may
#: be one the user chose, holding other things): entries, their temporaries, removed entries.
_ENTRY = re.compile(r"^[a-z0-9_]+-[0-9a-f]{24}$")
_KIND = re.compile(r"^[a-z0-9_]+$")
#: Alignment of the arrays' files and of the writes that bypass the page cache (``O_DIRECT``:
#: file offsets, lengths and buffers in whole blocks of the device; 4096 covers 512 and 4096).
_DIRECT_ALIGN = 4096
#: Bytes copied into the aligned bounce buffer and written per call (the tests make it small so
#: that writes cross chunk and block boundaries).
DIRECT_CHUNK_BYTES = 8 << 20
#: FFTW's wisdom files (:mod:`sacflow.kernels.fftw_wisdom`) and their temporaries.
_WISDOM = re.compile(r"^\.?fftw-wisdom-[0-9a-f]{16}\.json(?:\..+)?$")
_LEFTOVER = re.compile(r"^\.(?:[a-z0-9_]+-[0-9a-f]{24}\..+|trash-[a-z0-9_]+-[0-9a-f]{24}-\d+)$")


def cache_directory() -> Path | None:
    """Return the cache directory (not created here), or None when the cache is off."""
    explicit = cache_dir_from_env()
    if explicit is not None:
        if explicit.strip().lower() in CACHE_OFF:
            return None
        return Path(explicit).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base).expanduser() / "sacflow" / "kernels"


def max_bytes() -> int:
    """Return the size limit: ``SACFLOW_CACHE_MAX_BYTES`` (``20G``...), else the default."""
    limit = cache_max_bytes_from_env()
    return DEFAULT_MAX_BYTES if limit is None else limit


@dataclass(frozen=True)
class CacheEntry:
    """One cached set of arrays: its directory, what it is for, size and last use."""

    path: Path
    kind: str
    parameters: dict[str, Any]
    nbytes: int
    last_used: float


def _key(kind: str, parameters: Mapping[str, Any]) -> str:
    """Entry name: the kind and a hash of the canonical JSON of its parameters."""
    if not _KIND.match(kind):  # else the listing, eviction and clearing would not see it
        raise ValueError(f"cache kind {kind!r}: lower-case letters, digits and '_' only")
    text = json.dumps({"kind": kind, "parameters": parameters}, sort_keys=True)
    return f"{kind}-{hashlib.sha256(text.encode()).hexdigest()[:24]}"


def _load(path: Path, kind: str, parameters: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """Arrays of the entry at ``path``, memory-mapped read-only; ValueError if it is damaged."""
    record = json.loads((path / _RECORD).read_text())
    if record.get("kind") != kind or record.get("parameters") != json.loads(
            json.dumps(parameters)):
        raise ValueError("its record is for other parameters")
    if record.get("checksum") != CHECKSUM_ALGORITHM:
        raise ValueError("written without a checksum (by an older sacflow), it cannot be "
                         "verified")
    arrays = {}
    for name in record["arrays"]:
        read_ahead(path / f"{name}.npy")
    for name, spec in record["arrays"].items():
        file = path / f"{name}.npy"
        try:
            array = np.load(file, mmap_mode="r")
        except ValueError as exc:  # a truncated file, a damaged header
            raise ValueError(f"damaged ({file.name}: {exc})") from exc
        if list(array.shape) != spec["shape"] or str(array.dtype) != spec["dtype"]:
            raise ValueError(f"damaged (array {name} is not as recorded)")
        _verify(file, array, spec[CHECKSUM_ALGORITHM])
        arrays[name] = array
    with contextlib.suppress(OSError):
        os.utime(path / _RECORD)  # last use, for the eviction order
    return arrays


def read_ahead(file: Path) -> None:
    """Ask the kernel to start reading all of ``file`` into the page cache, and return.

    The cache's files are written past the page cache, so the first process to load them reads
    them from the disk. Hashed through the memory map, that read is a page fault at a time with
    the kernel's small read-ahead window; asked for the whole file first (every file of the
    entry, before any is hashed), the disk gets large requests, and the hash and the solver find
    the pages in memory. Where ``posix_fadvise`` does not exist, or the file cannot be opened
    here, nothing is done (the loading itself reports a missing file).
    """
    advise = getattr(os, "posix_fadvise", None)
    if advise is None:
        return
    with contextlib.suppress(OSError):
        fd = os.open(file, os.O_RDONLY)
        try:
            advise(fd, 0, 0, os.POSIX_FADV_WILLNEED)
        finally:
            os.close(fd)


#: Array files this process has verified, with the identity of the file it read (device,
#: inode, size, modification time): an entry is verified once per process, not at every load.
VERIFIED_FILES: set[tuple[str, int, int, int, int]] = set()


def _verify(file: Path, array: np.ndarray, expected: str) -> None:
    """Check ``file`` against its recorded checksum (once per process); ValueError if it differs.

    The data are hashed through ``array``, the memory map the solver then reads: the pages are
    faulted in once, by the checksum, and the solver's first touch finds them mapped.
    """
    stat = file.stat()
    identity = (str(file), stat.st_dev, stat.st_ino, stat.st_size, stat.st_mtime_ns)
    if identity in VERIFIED_FILES:
        return
    with open(file, "rb") as fh:
        digest = xxhash.xxh3_64(fh.read(stat.st_size - array.nbytes))  # the header
    digest.update(array.reshape(-1).view(np.uint8).data)
    if digest.hexdigest() != expected:
        raise ValueError(f"damaged ({file.name} does not match its checksum)")
    VERIFIED_FILES.add(identity)


def file_checksum(file: Path) -> str:
    """Return the XXH3 64-bit checksum (hex) of the bytes of ``file``, read in chunks."""
    digest = xxhash.xxh3_64()
    buffer = bytearray(_VERIFY_CHUNK_BYTES)
    with memoryview(buffer) as view, open(file, "rb", buffering=0) as fh:
        while count := fh.readinto(buffer):
            digest.update(view[:count])
    return str(digest.hexdigest())


def _npy_header(array: np.ndarray) -> bytes:
    """Return the ``.npy`` header (format 1.0) of ``array``, padded to :data:`_DIRECT_ALIGN` bytes.

    The format allows any header length that keeps the data aligned (a multiple of 64); a whole
    block puts the data on a block boundary, as writes that bypass the page cache need.
    """
    fields = np.lib.format.header_data_from_array_1_0(array)
    text = repr({key: fields[key] for key in sorted(fields)}).encode("latin1")
    prefix = np.lib.format.MAGIC_PREFIX + bytes([1, 0])
    size = _DIRECT_ALIGN * -(-(len(prefix) + 2 + len(text) + 1) // _DIRECT_ALIGN)
    body = text + b" " * (size - len(prefix) - 2 - len(text) - 1) + b"\n"
    return prefix + (size - len(prefix) - 2).to_bytes(2, "little") + body


def write_npy(path: Path, array: np.ndarray) -> str:
    """Write ``array`` (C-contiguous) as a ``.npy`` file, flushed to the disk; return its checksum.

    Written with ``O_DIRECT`` where the system and the file system allow it: the bytes go from
    an aligned bounce buffer to the disk without a second copy in the page cache, which the
    process would fill (and the system then hold) with as many bytes as the entry: hundreds of
    MB at 128 × 128 × 64 cuboids (``docs/performance.md``). Elsewhere (no ``O_DIRECT``, a file
    system that refuses it) a plain buffered write, the same file. The checksum
    (:func:`file_checksum` of the file written) is computed from the bytes in memory, so the
    file is not read back.
    """
    header = _npy_header(array)
    data = array.reshape(-1).view(np.uint8)
    if not _write_direct(path, header, data):
        with open(path, "wb") as fh:
            fh.write(header)
            array.tofile(fh)
            fh.flush()
            os.fsync(fh.fileno())
    digest = xxhash.xxh3_64(header)
    digest.update(data.data)  # the bytes, not a copy
    return str(digest.hexdigest())


def _write_direct(path: Path, header: bytes, data: np.ndarray) -> bool:
    """Write ``header`` then ``data`` (bytes) to ``path`` with ``O_DIRECT``; False if refused."""
    flag = getattr(os, "O_DIRECT", 0)
    if not flag:
        return False
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | flag, 0o644)
    except OSError as exc:
        if exc.errno in (errno.EINVAL, errno.EOPNOTSUPP):
            return False
        raise
    total = len(header) + data.size
    bounce = mmap.mmap(-1, DIRECT_CHUNK_BYTES)  # page-aligned
    try:
        copy_out_direct(fd, bounce, header, data)
        os.ftruncate(fd, total)  # the last block's padding
        os.fsync(fd)
    except OSError as exc:
        if exc.errno in (errno.EINVAL, errno.EOPNOTSUPP):
            return False  # the file system takes O_DIRECT at open but not these writes
        raise
    finally:
        os.close(fd)
        bounce.close()
    return True


def copy_out_direct(fd: int, bounce: mmap.mmap, header: bytes, data: np.ndarray) -> None:
    """Write ``header`` and ``data`` through ``bounce`` in whole aligned blocks (zero-padded).

    Fault-injection seam: the tests replace it with one raising ``EINVAL``, as a file system
    that takes ``O_DIRECT`` at open but refuses the writes does, to check the buffered route.
    """
    chunk = np.frombuffer(bounce, dtype=np.uint8)
    try:
        chunk[:len(header)] = np.frombuffer(header, dtype=np.uint8)
        filled, done = len(header), 0
        while True:
            take = min(DIRECT_CHUNK_BYTES - filled, data.size - done)
            chunk[filled:filled + take] = data[done:done + take]
            filled += take
            done += take
            if filled < DIRECT_CHUNK_BYTES and done < data.size:
                continue
            length = _DIRECT_ALIGN * -(-filled // _DIRECT_ALIGN)  # whole blocks
            chunk[filled:length] = 0
            with memoryview(bounce) as view:
                written = 0
                while written < length:
                    written += os.write(fd, view[written:length])
            if done == data.size:
                return
            filled = 0
    finally:
        del chunk  # the buffer's pointer, before it is closed


def _store(root: Path, name: str, kind: str, parameters: Mapping[str, Any],
           arrays: Mapping[str, np.ndarray]) -> None:
    """Write an entry atomically (temporary directory, flushed, renamed into place)."""
    root.mkdir(parents=True, exist_ok=True)
    temporary = Path(tempfile.mkdtemp(prefix=f".{name}.", dir=root))
    try:
        shapes: dict[str, dict[str, Any]] = {}
        for array_name, array in arrays.items():
            checksum = write_npy(temporary / f"{array_name}.npy", np.ascontiguousarray(array))
            shapes[array_name] = {"shape": list(array.shape), "dtype": str(array.dtype),
                                  CHECKSUM_ALGORITHM: checksum}
        record = {"kind": kind, "parameters": parameters, "checksum": CHECKSUM_ALGORITHM,
                  "arrays": shapes}
        (temporary / _RECORD).write_text(json.dumps(record, indent=1))
        try:
            os.rename(temporary, root / name)
        except OSError:  # another process stored the same entry first: keep theirs
            pass
    finally:
        if temporary.exists():
            shutil.rmtree(temporary, ignore_errors=True)


def _remove(path: Path) -> str | None:
    """Remove an entry: renamed away first (readers see all of it or none), then deleted.

    Returns None when the entry is gone (removed here, or already), else why it is not.
    """
    trash = path.with_name(f".trash-{path.name}-{os.getpid()}")
    try:
        os.rename(path, trash)
    except FileNotFoundError:
        return None  # already gone
    except OSError as exc:
        return exc.strerror or str(exc)
    shutil.rmtree(trash, ignore_errors=True)
    return None


def list_entries(root: Path | None = None) -> list[CacheEntry]:
    """Entries of the cache, least recently used first."""
    root = cache_directory() if root is None else root
    if root is None or not root.is_dir():
        return []
    entries = []
    for path in root.iterdir():
        if not _ENTRY.match(path.name) or not (path / _RECORD).is_file():
            continue
        try:
            record = json.loads((path / _RECORD).read_text())
            size = sum(f.stat().st_size for f in path.iterdir())
            used = (path / _RECORD).stat().st_mtime
        except (OSError, ValueError):
            continue
        entries.append(CacheEntry(path, str(record.get("kind")), record.get("parameters", {}),
                                  size, used))
    return sorted(entries, key=lambda e: e.last_used)


@dataclass(frozen=True)
class ClearReport:
    """What :func:`clear_cache` did: the entries it removed, and those it could not, and why."""

    removed: int
    removed_bytes: int
    not_removed: tuple[tuple[Path, str], ...] = ()


def clear_cache(root: Path | None = None) -> ClearReport:
    """Remove every entry (and leftovers of interrupted writes); report what went and what not.

    Only what the cache itself wrote is removed: a directory set by ``SACFLOW_CACHE_DIR`` that
    holds anything else keeps it. Only the entries actually removed are counted; an entry that
    could not be removed (a read-only cache) is reported with the reason.

    Raises
    ------
    NotADirectoryError
        When ``root`` exists and is not a directory (``SACFLOW_CACHE_DIR`` naming a file).
    """
    root = cache_directory() if root is None else root
    if root is None or not root.exists():
        return ClearReport(0, 0)
    if not root.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, "the kernel cache is not a directory", str(root))
    removed, failed = [], []
    for entry in list_entries(root):
        reason = _remove(entry.path)
        if reason is None:
            removed.append(entry)
        else:
            failed.append((entry.path, reason))
    for leftover in root.iterdir():  # interrupted writes and removals (this cache's names only)
        if _LEFTOVER.match(leftover.name) and leftover.is_dir():
            shutil.rmtree(leftover, ignore_errors=True)
        elif _WISDOM.match(leftover.name) and leftover.is_file():  # FFTW's (kernels.fftw_wisdom)
            with contextlib.suppress(OSError):
                leftover.unlink()
    return ClearReport(len(removed), sum(e.nbytes for e in removed), tuple(failed))


def _evict(root: Path, limit: int) -> None:
    """Remove the least recently used entries until the cache fits in ``limit`` bytes."""
    entries = list_entries(root)
    total = sum(e.nbytes for e in entries)
    for entry in entries:
        if total <= limit:
            break
        if _remove(entry.path) is None:
            total -= entry.nbytes


def cached_arrays(kind: str, parameters: Mapping[str, Any],
                  compute: Callable[[], dict[str, np.ndarray]],
                  min_bytes: int | None = None) -> dict[str, np.ndarray]:
    """Return the arrays ``compute()`` gives for ``parameters``, from the cache if it has them.

    Parameters
    ----------
    kind : str
        What the arrays are (e.g. ``"eigenstrain"``); part of the entry's name.
    parameters : mapping
        Everything that determines the arrays, JSON-serialisable: grid, cell sizes, elastic
        constants and the version of the code that computes them (bump it with the code).
    compute : callable
        Computes the arrays on a miss.
    min_bytes : int, optional
        Arrays smaller than this in total are not stored (:data:`MIN_CACHED_BYTES`).

    Returns
    -------
    dict of ndarray
        Read-only memory maps on a hit; the computed arrays (then stored) on a miss. A cache
        that cannot be written (no space, read-only) warns once per process and is bypassed.
    """
    root = cache_directory()
    if root is None:
        return compute()
    name = _key(kind, parameters)
    path = root / name
    if path.is_dir():
        try:
            return _load(path, kind, parameters)
        except (OSError, ValueError, KeyError) as exc:
            reason = str(exc) if isinstance(exc, ValueError) else f"damaged ({exc!r})"
            warnings.warn(f"kernel cache entry {path} not used: {reason}; computing it again",
                          RuntimeWarning, stacklevel=2)
            _remove(path)
    arrays = compute()
    limit = max_bytes()
    min_bytes = MIN_CACHED_BYTES if min_bytes is None else min_bytes
    if min_bytes <= sum(a.nbytes for a in arrays.values()) <= limit:
        try:
            _store(root, name, kind, dict(parameters), arrays)
            _evict(root, limit)
        except OSError as exc:
            _warn_unwritable(root, exc)
    return arrays


#: Cache directories already warned about as unwritable: one warning each per process.
WARNED_DIRECTORIES: set[str] = set()


def _warn_unwritable(root: Path, exc: OSError) -> None:
    if str(root) not in WARNED_DIRECTORIES:
        WARNED_DIRECTORIES.add(str(root))
        warnings.warn(f"kernel cache {root} cannot be written ({exc}); running without it "
                      "(set SACFLOW_CACHE_DIR to a writable directory, or to 'off')",
                      RuntimeWarning, stacklevel=3)
