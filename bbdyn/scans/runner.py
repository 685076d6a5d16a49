"""Resumable, parallel parameter scans (issue 4, item 3); see docs/scans.md.

``run_scan(values, compute, out_dir=..., seed=...)`` calls
``compute(value, seed_sequence) -> dict`` once per value, in worker processes
(or on a dask cluster), and stores every finished point at once, atomically.
The scan is generic: it knows nothing about the physics in ``compute``.

Layout of ``out_dir``::

    manifest.json                 the scan: name, values, seed, compute (written first)
    points/f_58.000000000.npz     one point's arrays (loaded with allow_pickle=False)
    points/f_58.000000000.json    its metadata and the SHA-256 of its .npz; written last,
                                  so it marks the point done
    scan.lock                     held (flock) by the scan running in the folder; its PID

Trust.  A stored point is used only if its .npz matches the checksum in its .json and
its metadata (name, seed key, seed, compute) match its file name and the manifest;
a resumed scan computes any other point again (with a warning naming the file), and
``load_scan`` refuses it (``DamagedResultError`` naming the file and the remedy).

Seeds.  The point at ``value`` gets ``np.random.SeedSequence(seed, spawn_key=(key,))``
with ``key = round(value * 10**9)``: the value rounded to 1e-9 (Hz for a frequency
scan).  It depends on ``(seed, value)`` only, never on the order of the values,
the worker, the thread count or the machine, so an interrupted and resumed scan,
a scan in another order and a scan on a cluster give identical numbers.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import errno
import functools
import importlib
import json
import math
import multiprocessing
import os
import signal
import socket
import sys
import threading
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from bbdyn import __version__
from bbdyn.gpu import check_device
from bbdyn.gpu import device_info as _device_info
from bbdyn.params import Params
from bbdyn.results import (
    DamagedResultError,
    Result,
    make_meta,
    read_json,
    result_paths,
    write_json_atomic,
)
from bbdyn.scans.progress import Progress, progress_stream
from bbdyn.schema import DIMENSIONS, SE, describe, is_quantity, standard_key, unit, units_of

__all__ = [
    "KEY_SCALE",
    "DamagedPointWarning",
    "SourceChangedWarning",
    "ScanBusyError",
    "ScanStorageError",
    "SchedulerUnreachableError",
    "ScanResult",
    "describe_compute",
    "load_scan",
    "local_workers",
    "point_key",
    "point_seed",
    "run_scan",
]

#: Seed keys are the values rounded to 1 / KEY_SCALE (1e-9 Hz for frequencies).
KEY_SCALE = 10**9
MANIFEST = "manifest.json"
POINTS = "points"
LOCK = "scan.lock"
#: Most points in one GPU batch (``_CudaBackend``; the engine splits a batch that does not
#: fit in the device's memory into several launches).
MAX_BATCH_POINTS = 100_000
#: Seconds to wait for a dask scheduler before giving up.
CONNECT_TIMEOUT_S = 5.0
#: Manifest fields that define a scan; resuming with any of them changed is refused.
_DEFINING = ("name", "values", "keys", "seed", "compute")
_RESUME = "run the same scan again with resume=True (bbdyn scan ... --resume)"


class ScanBusyError(OSError):
    """Another process is running a scan in this folder (it holds the folder's lock)."""


class ScanStorageError(OSError):
    """The scan folder cannot be written (disk full, read-only, no permission)."""


class SchedulerUnreachableError(OSError):
    """No dask scheduler answers at the given address."""


class DamagedPointWarning(UserWarning):
    """A stored point was damaged or did not belong to the scan; it is computed again."""


class SourceChangedWarning(UserWarning):
    """A scan is resumed by other bbdyn source than the one that began it."""


# ---- seeds and file names -------------------------------------------------------------------
def point_key(value: float) -> int:
    """Integer seed key of a scan value: ``round(value * KEY_SCALE)`` (value >= 0)."""
    return int(round(value * KEY_SCALE))


def point_seed(seed: int, value: float) -> np.random.SeedSequence:
    """The seed sequence of the point at ``value``: depends on ``(seed, value)`` only.

    Examples
    --------
    >>> a = point_seed(7, 58.0).generate_state(2)
    >>> b = point_seed(7, 58.0 + 1e-12).generate_state(2)  # same point at 1e-9 resolution
    >>> bool((a == b).all())
    True
    """
    return np.random.SeedSequence(seed, spawn_key=(point_key(value),))


def _point_stem(name: str, key: int) -> str:
    # from the integer key, so the name is exact and the same on every machine
    whole, frac = divmod(key, KEY_SCALE)
    return f"{name}_{whole}.{frac:09d}"


# ---- the compute function and the manifest --------------------------------------------------
def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic | np.ndarray):
        return obj.tolist()
    if callable(getattr(obj, "to_dict", None)):  # e.g. Params
        return {"type": type(obj).__qualname__, **obj.to_dict()}
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def _canonical(obj: Any, what: str) -> Any:
    """``obj`` as it reads back from JSON (so manifests compare like for like)."""
    try:
        return json.loads(json.dumps(obj, default=_json_default))
    except (TypeError, ValueError) as err:
        raise ValueError(f"{what} must be JSON serialisable, got {obj!r} ({err})") from None


def describe_compute(compute: Callable) -> dict[str, Any]:
    """Name and fixed arguments of ``compute`` (a top-level function or a ``functools.partial``)."""
    args: tuple = ()
    kwargs: dict[str, Any] = {}
    func = compute
    if isinstance(compute, functools.partial):
        func, args, kwargs = compute.func, compute.args, compute.keywords
    qualname = getattr(func, "__qualname__", None)
    module = getattr(func, "__module__", None)
    if not callable(func) or qualname is None or module is None or "<" in qualname:
        raise ValueError(
            "compute must be a top-level function (picklable by name) or a functools.partial "
            f"of one, got {compute!r}"
        )
    return {
        "function": f"{module}:{qualname}",
        "args": _canonical(list(args), "compute's fixed arguments"),
        "kwargs": _canonical(kwargs, "compute's fixed keyword arguments"),
    }


def _check_importable(compute: Callable) -> None:
    """Local workers import ``compute`` by name: refuse functions they cannot import."""
    func = compute.func if isinstance(compute, functools.partial) else compute
    main = sys.modules.get("__main__")
    if getattr(func, "__module__", None) == "__main__" and not getattr(main, "__file__", None):
        raise ValueError(
            "compute must be importable by worker processes, got a function defined "
            "interactively (notebook or REPL): move it to a module, or pass scheduler="
        )


def _check_values(values: Sequence[float], name: str) -> tuple[list[float], list[int]]:
    try:
        floats = [float(v) for v in values]
    except (TypeError, ValueError):
        raise ValueError(f"values must be a sequence of real numbers, got {values!r}") from None
    if not floats:
        raise ValueError("values must not be empty")
    for v in floats:
        if not (np.isfinite(v) and v >= 0.0):
            raise ValueError(f"values must be finite and >= 0, got {name}={v}")
    keys = [point_key(v) for v in floats]
    if len(set(keys)) != len(keys):
        dupes = sorted({v for v, k in zip(floats, keys, strict=True) if keys.count(k) > 1})
        raise ValueError(f"values must differ by more than 1e-9, got repeated {name}={dupes}")
    return floats, keys


# ---- the folder: lock, manifest, stored points ----------------------------------------------
_REMEDIES = {
    errno.ENOSPC: "free disk space",
    errno.EDQUOT: "free disk space (the disk quota is exceeded)",
    errno.EACCES: "make it writable",
    errno.EPERM: "make it writable",
    errno.EROFS: "make it writable (it is on a read-only file system)",
}


@contextlib.contextmanager
def _writing(out_dir: Path):
    """Turn a failed write into a ``ScanStorageError`` naming the folder and the remedy."""
    try:
        yield
    except OSError as err:
        remedy = _REMEDIES.get(err.errno, "check the folder")
        raise ScanStorageError(
            f"cannot write to the scan folder {out_dir}: {err.strerror or err}; {remedy} or "
            f"choose another folder (out_dir= / --out), then {_RESUME}: finished points are kept"
        ) from None


@contextlib.contextmanager
def _scan_lock(out_dir: Path):
    """Hold ``out_dir/scan.lock`` (an advisory lock the OS releases when this process dies)."""
    path = out_dir / LOCK
    with _writing(out_dir):
        out_dir.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
    try:
        if not _try_lock(fd):
            holder = os.read(fd, 32).decode(errors="replace").strip() or "unknown"
            raise ScanBusyError(
                f"{out_dir} is in use by another scan (PID {holder}): wait for it to finish "
                f"or stop it, then {_RESUME}; or choose another folder"
            )
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        yield
    finally:
        os.close(fd)  # releases the lock


def _try_lock(fd: int) -> bool:
    """Take an exclusive lock on ``fd`` without waiting; False if another process holds it."""
    try:
        import fcntl
    except ImportError:  # Windows
        import msvcrt

        try:
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
        except OSError:
            return False
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        return False
    return True


def _read_manifest(out_dir: Path) -> dict[str, Any]:
    """The manifest of ``out_dir``; a ``DamagedResultError`` naming it if it is unusable."""
    path = out_dir / MANIFEST
    remedy = (
        "delete it and run the same scan again with resume=True (bbdyn scan ... --resume): "
        "the points that belong to that scan are kept, the others computed again"
    )
    try:
        manifest = read_json(path)
    except DamagedResultError as err:
        raise DamagedResultError(f"the scan manifest is damaged: {err}; {remedy}") from None
    fields = ("name", "values", "keys", "seed", "compute")
    if (
        not isinstance(manifest, dict)
        or manifest.get("kind") != "scan_manifest"
        or any(k not in manifest for k in fields)
        or not isinstance(manifest["values"], list)
        or not all(isinstance(v, int | float) and v >= 0 for v in manifest["values"])
        or manifest["keys"] != [point_key(v) for v in manifest["values"]]
    ):
        raise DamagedResultError(
            f"{path} is damaged (not a scan manifest with {', '.join(fields)}); {remedy}"
        )
    return manifest


def _prepare_out_dir(out_dir: Path, manifest: dict[str, Any], resume: bool) -> None:
    """Check the manifest of a resumed scan, or write it; the caller holds the lock."""
    path = out_dir / MANIFEST
    if path.exists():
        if not resume:
            raise FileExistsError(
                f"{out_dir} already holds a scan; pass resume=True to finish it, "
                "or choose a new out_dir"
            )
        old = _read_manifest(out_dir)
        differ = [k for k in _DEFINING if old.get(k) != manifest[k]]
        if differ:
            raise ValueError(
                f"{out_dir} holds a different scan (differs in: {', '.join(differ)}); "
                "resume it with the same values, seed and compute, or choose a new out_dir"
            )
        if old.get("bbdyn_source", manifest["bbdyn_source"]) != manifest["bbdyn_source"]:
            warnings.warn(
                f"{out_dir} was begun by other bbdyn source (digest {old['bbdyn_source'][:12]}, "
                f"now {manifest['bbdyn_source'][:12]}): its points mix two versions of the code; "
                "choose a new out_dir for numbers from one",
                SourceChangedWarning,
                stacklevel=4,
            )
        # leftovers of writes cut short by a crash; the point is simply computed again
        with _writing(out_dir):
            for tmp in (out_dir / POINTS).glob("*.tmp"):
                tmp.unlink()
    else:
        with _writing(out_dir):
            write_json_atomic(path, manifest)
    with _writing(out_dir):
        (out_dir / POINTS).mkdir(parents=True, exist_ok=True)


def _stored_point(stem: Path, manifest: dict[str, Any], key: int) -> _ScanPoint | None:
    """The point stored at ``stem``, None if it is not (completely) stored.

    Raises ``DamagedResultError`` naming the file if it is damaged (checksum, JSON) or
    is not the point of this scan its name says (name, key, seed or compute differ).
    """
    npz_path, json_path = result_paths(stem)
    if not json_path.exists():  # the .json is written last: no .json, no point
        return None
    try:
        point = _ScanPoint.load(stem)
    except (ValueError, TypeError, FileNotFoundError) as err:
        raise DamagedResultError(str(err)) from None
    expected = {
        "name": manifest["name"],
        "key": key,
        "seed": manifest["seed"],
        "compute": manifest["compute"],
    }
    differ = [k for k, v in expected.items() if point.meta.get(k) != v]
    if differ:
        raise DamagedResultError(
            f"{json_path} is not the point of this scan its name says (differs in: "
            f"{', '.join(differ)}; it holds {point.meta.get('name')}={point.meta.get('value')})"
        )
    return point


def _point_done(stem: Path, manifest: dict[str, Any], key: int, value: float) -> bool:
    """Whether the point is stored and sound; a damaged point is deleted with a warning."""
    try:
        return _stored_point(stem, manifest, key) is not None
    except DamagedResultError as err:
        warnings.warn(
            f"{err}; computing {manifest['name']}={value} again", DamagedPointWarning, stacklevel=4
        )
    for path in result_paths(stem):
        path.unlink(missing_ok=True)
    return False


# ---- one point, in a worker -----------------------------------------------------------------
def _run_point(compute: Callable, value: float, seed: int) -> tuple[dict, dict]:
    """Run one point (in a worker process): ``compute`` with one numba thread, timed by
    the worker's own clocks: ``cpu_s`` is its process CPU time (``time.process_time``),
    which does not grow when other processes share the core, ``wall_s`` wall-clock time."""
    import numba

    # One thread per point: a point's numbers never depend on the thread count,
    # and the processes (not threads) share the cores.
    numba.set_num_threads(1)
    cpu0, t0 = time.process_time(), time.perf_counter()
    out = compute(value, point_seed(seed, value))
    wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
    info = {"cpu_s": cpu, "wall_s": wall, "host": socket.gethostname(), "pid": os.getpid()}
    info["bbdyn_version"] = __version__
    info.update(_device_info("cpu"))
    return out, info


def _check_output(out: Any, name: str, value: float) -> dict[str, np.ndarray]:
    where = f"compute({name}={value})"
    if not isinstance(out, dict) or not out:
        raise TypeError(f"{where} must return a non-empty dict of numbers/arrays, got {out!r}")
    arrays = {}
    for k, v in out.items():
        if not isinstance(k, str) or not k or k == name or "/" in k:
            raise TypeError(f"{where}: output names must be strings other than {name!r}, got {k!r}")
        a = np.asarray(v)
        if a.dtype.kind not in "biufc":
            raise TypeError(f"{where}: output {k!r} must be numeric, got dtype {a.dtype}")
        arrays[k] = a
    return arrays


class _ScanPoint(Result):
    """One finished point of a scan (stored in ``out_dir/points``)."""

    kind = "scan_point"


# ---- executors ------------------------------------------------------------------------------
def _worker_init() -> None:
    """Make this worker exit when the scan process dies, even by ``kill -9``.

    Linux: the kernel sends SIGTERM when the worker's parent dies (``PR_SET_PDEATHSIG``),
    whatever the worker is doing (even inside a numba kernel).  The parent is the
    forkserver, which exits when the scan process dies once no worker holds its
    "scan alive" pipe, so each worker closes its copy.  Elsewhere a daemon thread waits
    for the scan process (``multiprocessing.parent_process()``) and exits the worker;
    it runs as soon as the worker releases the GIL.

    Processes this worker starts use "spawn".  (numba then guards its thread start-up
    with a plain lock instead of a multiprocessing one, which a worker stopped by a
    signal would leave registered: "leaked semaphore" warnings at exit.)
    """
    multiprocessing.set_start_method("spawn", force=True)
    if sys.platform.startswith("linux"):
        import ctypes
        from multiprocessing import forkserver

        server = forkserver._forkserver
        if getattr(server, "_forkserver_alive_fd", None) is not None:
            os.close(server._forkserver_alive_fd)
            server._forkserver_alive_fd = None
        parent = os.getppid()
        pr_set_pdeathsig = 1
        ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGTERM, 0, 0, 0)
        if os.getppid() != parent:  # the parent died before the signal was armed
            os._exit(1)
        return
    parent = multiprocessing.parent_process()
    if parent is not None:

        def exit_with_parent():
            parent.join()
            os._exit(1)

        threading.Thread(target=exit_with_parent, daemon=True).start()


class _LocalBackend:
    """Worker processes on this machine (``concurrent.futures.ProcessPoolExecutor``)."""

    def __init__(self, workers: int):
        # forkserver: workers are forked from a clean server process, never from this
        # (possibly multi-threaded) one; bbdyn.scans.runner is preloaded so forks start fast.
        if "forkserver" in multiprocessing.get_all_start_methods():
            ctx = multiprocessing.get_context("forkserver")
            ctx.set_forkserver_preload(["bbdyn.scans.runner"])
        else:
            ctx = multiprocessing.get_context("spawn")
        self.pool = cf.ProcessPoolExecutor(
            max_workers=workers, mp_context=ctx, initializer=_worker_init
        )
        self.in_flight = 2 * workers

    def submit(self, compute, value, seed):
        return self.pool.submit(_run_point, compute, value, seed)

    def wait_any(self, futures):
        return cf.wait(futures, return_when=cf.FIRST_COMPLETED).done

    def close(self, interrupted: bool, running) -> None:
        """Stop the workers (at once if ``interrupted``); later calls do nothing."""
        if self.pool is None:
            return
        # shutdown() cannot stop a running point; without terminating the workers
        # the interpreter would wait at exit for every running point to finish.  They are
        # terminated first, so that shutdown(wait=True) returns at once and the pool's
        # manager thread has ended (and released its pipes and semaphores) before we go on.
        if interrupted:
            for proc in list((getattr(self.pool, "_processes", None) or {}).values()):
                proc.terminate()
        self.pool.shutdown(wait=True, cancel_futures=True)
        self.pool = None


class _DaskBackend:
    """The same points on a ``dask.distributed`` cluster (address string or ``Client``)."""

    def __init__(self, scheduler):
        try:
            import distributed
        except ImportError:
            raise ImportError(
                "scheduler= needs dask.distributed: pip install 'bbdyn[dask]'"
            ) from None
        self.distributed = distributed
        if isinstance(scheduler, distributed.Client):
            self.client, self.own_client = scheduler, False
        elif isinstance(scheduler, str):
            self.client, self.own_client = self._connect(distributed, scheduler), True
        else:
            raise ValueError(
                f"scheduler must be an address string or a distributed.Client, got {scheduler!r}"
            )
        # the scheduler balances the whole scan; we only cap memory held by results
        self.in_flight = 10_000

    @staticmethod
    def _connect(distributed, address: str):
        try:
            return distributed.Client(address, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError) as err:
            raise SchedulerUnreachableError(
                f"no dask scheduler answers at {address} within {CONNECT_TIMEOUT_S:g} s ({err}): "
                "start it (dask scheduler) and its workers, check the address, or leave out "
                "scheduler= / --scheduler to run on this machine"
            ) from None

    def submit(self, compute, value, seed):
        return self.client.submit(_run_point, compute, value, seed, pure=False)

    def wait_any(self, futures):
        return self.distributed.wait(list(futures), return_when="FIRST_COMPLETED").done

    def close(self, interrupted: bool, running) -> None:
        """Cancel the running points if ``interrupted``, close our client; then do nothing."""
        if self.client is None:
            return
        if interrupted:
            self.client.cancel(list(running))
        if self.own_client:
            self.client.close()
        self.client = None


class _BatchFuture:
    """A point of a ``_CudaBackend`` batch: its value, then its result or error."""

    def __init__(self, value: float, seed: int):
        self.value, self.seed, self.out, self.error = value, seed, None, None

    def result(self):
        if self.error is not None:
            raise self.error
        return self.out


class _CudaBackend:
    """The points on this process's GPU: each wait runs every point submitted since the last
    as one batch of ``compute``'s batch form (``compute.batch``, e.g. ``diffusion_points``),
    whose ensembles share the GPU's launches (``bbdyn.ensemble.ensembles``)."""

    def __init__(self, compute):
        func = compute.func if isinstance(compute, functools.partial) else compute
        self.batch = getattr(func, "batch", None)
        if self.batch is None:
            raise ValueError(
                f"device='cuda' needs a compute function with a batch form (compute.batch, "
                f"as diffusion_point has), got {getattr(func, '__qualname__', func)!r}"
            )
        self.kwargs = dict(compute.keywords) if isinstance(compute, functools.partial) else {}
        self.args = compute.args if isinstance(compute, functools.partial) else ()
        self.queue: list[_BatchFuture] = []
        self.in_flight = MAX_BATCH_POINTS

    def submit(self, compute, value, seed):
        future = _BatchFuture(value, seed)
        self.queue.append(future)
        return future

    def wait_any(self, futures):
        batch, self.queue = self.queue, []
        values = [f.value for f in batch]
        seeds = [point_seed(f.seed, f.value) for f in batch]
        cpu0, t0 = time.process_time(), time.perf_counter()
        try:
            outs = self.batch(values, seeds, *self.args, device="cuda", **self.kwargs)
        except Exception as err:
            for f in batch:
                f.error = err
            return set(batch)
        wall, cpu = time.perf_counter() - t0, time.process_time() - cpu0
        info = {"host": socket.gethostname(), "pid": os.getpid(), "bbdyn_version": __version__}
        info.update(_device_info("cuda"), batch_points=len(batch), batch_wall_s=wall,
                    batch_cpu_s=cpu)  # fmt: skip
        share = _shares([out.get("events") if isinstance(out, dict) else None for out in outs])
        for f, out, w in zip(batch, outs, share, strict=True):
            f.out = (out, {"cpu_s": cpu * w, "wall_s": wall * w, **info})
        return set(batch)

    def close(self, interrupted: bool, running) -> None:
        self.queue = []


def _shares(events: list) -> np.ndarray:
    """Each point's share of a batch's time: by its events where every point counts them,
    else equal."""
    if all(isinstance(e, int | float | np.number) for e in events) and sum(events) > 0:
        return np.asarray(events, dtype=float) / float(sum(events))
    return np.full(len(events), 1.0 / len(events))


def _available_cores() -> int:
    if hasattr(os, "sched_getaffinity"):  # respects taskset / container CPU limits
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def local_workers(workers: int | None, n_points: int) -> int:
    """Worker processes a local scan of ``n_points`` points to compute starts: ``workers``,
    or else one per available core, and never more than points."""
    return max(1, min(workers or _available_cores(), n_points))


# ---- the scan -------------------------------------------------------------------------------
def run_scan(
    values: Sequence[float],
    compute: Callable[[float, np.random.SeedSequence], dict],
    *,
    out_dir: str | os.PathLike,
    seed: int,
    resume: bool = True,
    workers: int | None = None,
    scheduler=None,
    progress: bool | TextIO = True,
    name: str = "f",
    device: str = "cpu",
) -> ScanResult:
    """Run ``compute`` at every value, storing each finished point at once; resumable.

    Parameters
    ----------
    values : sequence of float
        Scanned values (e.g. frequencies in Hz), finite, >= 0, distinct at 1e-9.
    compute : callable
        ``compute(value, seed_sequence) -> dict[str, float | ndarray]`` (numeric only); a
        top-level function, or a ``functools.partial`` of one fixing keyword arguments
        (JSON-serialisable: they are recorded in the manifest).
    out_dir : path
        Folder of the scan (see the module docstring for its layout).
    seed : int
        Scan seed (>= 0); the point at ``value`` uses ``point_seed(seed, value)``.
    resume : bool
        If ``out_dir`` holds this scan already, compute only its missing points.  A different
        scan there is refused (ValueError); with ``resume=False`` any scan there is refused.
    workers : int, optional
        Local worker processes (default: the cores available to this process).
    scheduler : str or distributed.Client, optional
        Run the points on this dask cluster instead (``pip install 'bbdyn[dask]'``).
    progress : bool or text stream
        Show points done, rate and time left: True -> on stderr if it is a terminal;
        a stream -> always there; False -> never.
    name : str
        Name of the scanned parameter (array name and file prefix), default ``"f"``.
    device : {"cpu", "cuda"}
        ``"cuda"``: the points run on this process's GPU, together, through ``compute``'s
        batch form ``compute.batch(values, seed_sequences, device="cuda", **kwargs)``
        (``diffusion_point`` has one); not with ``scheduler``.  Each point's metadata
        records ``device`` and ``device_name``, and for a GPU batch its size and times
        (``cpu_s`` and ``wall_s`` are the point's share of the batch, by events).

    Returns
    -------
    ScanResult
        All points, as ``load_scan(out_dir)`` returns them.

    Raises
    ------
    Exception
        The first exception raised by ``compute`` (with a note naming the point), after the
        points still running have finished and been stored.  KeyboardInterrupt stops at once.
        Either way every finished point is kept and ``resume=True`` continues the scan.
    """
    floats, keys = _check_values(values, name)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    seed = int(seed)
    if not (isinstance(name, str) and name.isidentifier()):
        raise ValueError(f"name must be an identifier such as 'f', got {name!r}")
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or workers < 1
    ):
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if check_device(device) == "cuda" and scheduler is not None:
        raise ValueError("device='cuda' runs the scan on this machine's GPU: leave out scheduler")
    if scheduler is None:
        _check_importable(compute)
    stream = progress_stream(progress)
    out_dir = Path(out_dir)
    manifest = {
        "kind": "scan_manifest",
        "name": name,
        "values": floats,
        "keys": keys,
        "seed": seed,
        "key_scale": KEY_SCALE,
        "seed_rule": "np.random.SeedSequence(seed, spawn_key=(round(value * key_scale),))",
        "compute": describe_compute(compute),
    }
    manifest = make_meta(**manifest)
    # a cluster or a GPU is reached before anything is written: a wrong address or a missing
    # GPU leaves no folder
    backend = _DaskBackend(scheduler) if scheduler is not None else None
    if device == "cuda":
        _device_info(device)
        backend = _CudaBackend(compute)
    try:
        with _scan_lock(out_dir):
            _prepare_out_dir(out_dir, manifest, resume)
            pairs = list(zip(floats, keys, strict=True))
            stems = {v: out_dir / POINTS / _point_stem(name, k) for v, k in pairs}
            todo = [v for v, k in pairs if not _point_done(stems[v], manifest, k, v)]
            bar = Progress(len(floats), done=len(floats) - len(todo), label=name, stream=stream)
            try:
                if todo:
                    if backend is None:
                        backend = _LocalBackend(local_workers(workers, len(todo)))
                    with _sigterm_as_interrupt():
                        _drive(backend, todo, compute, seed, name, stems, manifest, bar, out_dir)
            finally:
                bar.close()
            return load_scan(out_dir)
    finally:
        if backend is not None:
            backend.close(interrupted=False, running=())


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """Treat SIGTERM (``kill``, a batch system's stop) like Ctrl-C: finished points are
    kept and the workers are terminated, instead of being left to run orphaned."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _drive(backend, todo, compute, seed, name, stems, manifest, bar, out_dir) -> None:
    """Submit the points, store each as it finishes, stop cleanly on errors."""
    queue = iter(todo)
    running: dict[Any, float] = {}
    error: BaseException | None = None
    interrupted = False
    try:
        while True:
            while error is None and len(running) < backend.in_flight:
                value = next(queue, None)
                if value is None:
                    break
                running[backend.submit(compute, value, seed)] = value
            if not running:
                break
            for fut in backend.wait_any(running):
                value = running.pop(fut)
                try:
                    out, info = fut.result()
                    arrays = _check_output(out, name, value)
                except Exception as err:  # the point failed; keep the first error
                    if error is None:
                        err.add_note(
                            f"while computing {name}={value!r}; finished points are kept in "
                            f"{out_dir}: run the scan again with resume=True"
                        )
                        error = err
                    continue
                meta = make_meta(
                    seed=seed,
                    name=name,
                    value=value,
                    key=point_key(value),
                    compute=manifest["compute"],
                    **info,
                )
                with _writing(out_dir):
                    _ScanPoint(arrays, meta).save(stems[value])
                bar.update()
    except BaseException:
        interrupted = True
        raise
    finally:
        backend.close(interrupted, running)
    if error is not None:
        raise error


# ---- results --------------------------------------------------------------------------------
class ScanResult(Result):
    """A scan: the outputs of every point stacked in the order of the scanned values.

    ``arrays[name]`` holds the values (e.g. ``"f"``, Hz); each output of ``compute``
    is stacked along a first axis of the same length (a float becomes a 1-D array,
    an array of shape ``s`` one of shape ``(n_values, *s)``).  ``meta`` holds the
    manifest and ``meta["points"]``, the metadata of each point (seed key, wall time,
    host, package version).
    """

    kind = "scan"

    @property
    def name(self) -> str:
        """Name of the scanned parameter."""
        return self.meta["name"]

    @property
    def values(self) -> np.ndarray:
        """The scanned values, shape (n_values,)."""
        return self.arrays[self.name]

    def scalars(self) -> list[str]:
        """Names of the outputs with one number per value (1-D arrays)."""
        return [k for k, a in self.arrays.items() if k != self.name and a.ndim == 1]

    def plot(self, ax=None, key: str | None = None):
        """Plot the scalar output ``key`` against the values, with error bars from its
        standard error ``key + "_se"`` when the scan has one.

        Default: ``"D"`` (D(f) of a frequency scan), else the first scalar output.
        Returns the axes.
        """
        import matplotlib.pyplot as plt

        scalars = self.scalars()
        if key is None:
            if not scalars:
                raise ValueError("this scan has no scalar output to plot")
            key = "D" if "D" in scalars else scalars[0]
        if key not in scalars:
            raise ValueError(f"key must be one of the scalar outputs {scalars}, got {key!r}")
        if ax is None:
            _, ax = plt.subplots()
        order = np.argsort(self.values, kind="stable")
        x, y = self.values[order], self.arrays[key][order]
        err = self.arrays.get(key + SE)
        if err is not None and err.ndim == 1:
            ax.errorbar(x, y, yerr=err[order], fmt="o-", ms=3, capsize=2)
        else:
            ax.plot(x, y, "o-", ms=3)
        ax.set_xlabel(_label(self.name))
        ax.set_ylabel(_label(key))
        return ax

    def params(self) -> dict[str, float] | None:
        """The model parameters of a frequency scan (``name == "f"``): the ``Params``
        defaults with the compute function's fixed model arguments; None for other scans."""
        if self.name != "f":
            return None

        defaults = {k: v for k, v in Params(f=1.0).to_dict().items() if k != "f"}
        kwargs = self.meta["compute"]["kwargs"]
        return {k: float(kwargs.get(k, v)) for k, v in defaults.items()}

    def point_times(self) -> dict[str, np.ndarray]:
        """``cpu_s`` and ``wall_s`` of each point (s): the CPU time of the worker process
        that computed it and its wall-clock time (NaN where a point did not record one)."""
        return {
            k: np.array([p.get(k, math.nan) for p in self.meta["points"]], dtype=float)
            for k in ("cpu_s", "wall_s")
        }

    def point_cpu_s(self) -> np.ndarray:
        """CPU time of each point (s); a point computed before bbdyn recorded CPU time
        counts its wall time, an upper bound of it (``point_times`` keeps them apart)."""
        times = self.point_times()
        return np.where(np.isnan(times["cpu_s"]), times["wall_s"], times["cpu_s"])

    def to_xarray(self):
        """The scan as an ``xarray.Dataset``: coordinate ``name`` (e.g. ``f``, Hz), each
        output a variable (``D``, ``D_se``, ``E``, ... and the points' ``cpu_s``,
        ``wall_s``) with its ``units`` and ``long_name`` (docs/schema.md); the
        parameters, seed, compute function and provenance as attributes.

        Needs xarray (``pip install 'bbdyn[io]'``).
        """
        xr = _optional("xarray")
        name = self.name
        arrays = {k: a for k, a in self.arrays.items() if k != name} | self.point_times()
        variables = {}
        for key, values in arrays.items():
            trailing = DIMENSIONS.get(key, ())
            if len(trailing) != values.ndim - 1:
                trailing = tuple(f"{key}_dim{i}" for i in range(1, values.ndim))
            variables[key] = ((name, *trailing), values, _variable_attrs(key))
        coords = {name: (name, self.values, _variable_attrs(name))}
        meta = self.meta
        attrs = {
            "title": f"bbdyn scan over {name}",
            "seed": meta["seed"],
            "compute": json.dumps(meta["compute"]),
            "seed_rule": meta.get("seed_rule", ""),
            "units": json.dumps(units_of({name: 0, **arrays})),
            "bbdyn_version": meta.get("bbdyn_version", ""),
            "bbdyn_source": meta.get("bbdyn_source", ""),
            "created_utc": meta.get("created_utc", ""),
            "python": meta.get("python", ""),
            "machine": meta.get("machine", ""),
            "n_missing": meta.get("n_missing", 0),
            "cpu_s": float(np.nansum(arrays["cpu_s"])),
        }
        params = self.params()
        if params is not None:
            attrs["params"] = json.dumps(params)
        return xr.Dataset(variables, coords=coords, attrs=attrs)

    def to_netcdf(self, path: str | os.PathLike) -> Path:
        """Write ``to_xarray()`` to the netCDF file ``path`` (written to a temporary file
        and renamed, so the file is complete or absent); returns the path.

        Needs xarray (``pip install 'bbdyn[io]'``); the file is netCDF4 when the netCDF4
        or h5netcdf package is installed, else netCDF3 (scipy).
        """
        path = Path(path)
        dataset = self.to_xarray()
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
        try:
            dataset.to_netcdf(tmp)
            os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            raise
        return path

    def to_dataframe(self):
        """The scalar outputs and the points' ``cpu_s``, ``wall_s`` as a ``pandas.DataFrame``
        indexed by the scanned values (column units in ``df.attrs["units"]``).

        Needs pandas (``pip install 'bbdyn[io]'``).
        """
        pd = _optional("pandas")
        columns = {k: self.arrays[k] for k in self.scalars()} | self.point_times()
        frame = pd.DataFrame(columns, index=pd.Index(self.values, name=self.name))
        frame.attrs["units"] = units_of({self.name: 0, **columns})
        return frame


#: What to install for the exports of ``ScanResult``.
IO_EXTRA = "install the io extra: pip install 'bbdyn[io]'"


def _optional(module: str):
    """Import the optional dependency ``module``; ImportError naming the extra if absent."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise ImportError(f"this needs {module}, which is not installed: {IO_EXTRA}") from None


def _label(key: str) -> str:
    """Axis label ``key (unit)``, or ``key`` for a dimensionless key or one outside the schema."""
    u = unit(key) if is_quantity(key) else ""
    return f"{key} ({u})" if u else key


def _variable_attrs(key: str) -> dict[str, str]:
    """``units`` (CF: "1" if dimensionless) and ``long_name`` of a variable from the schema;
    none for a key outside it."""
    return {"units": unit(key) or "1", "long_name": describe(key)} if is_quantity(key) else {}


def load_scan(out_dir: str | os.PathLike, *, partial: bool = False) -> ScanResult:
    """Load a scan folder written by ``run_scan`` (without unpickling anything).

    The outputs of bbdyn's own compute functions (``diffusion_point``, ``gk_point``, ...)
    get the keys of the result schema (``bbdyn.schema.standard_key``: standard errors
    ``X_se``, ``collision_rate``; docs/schema.md); other compute functions keep their keys.

    With ``partial=True`` an unfinished scan loads its finished points only (a damaged
    point is left out with a ``DamagedPointWarning``); otherwise a missing point raises
    ``FileNotFoundError`` and a damaged one ``DamagedResultError`` (a ValueError) naming
    the file.
    """
    out_dir = Path(out_dir)
    if not (out_dir / MANIFEST).exists():
        raise FileNotFoundError(f"{out_dir / MANIFEST} does not exist: {out_dir} holds no scan")
    manifest = _read_manifest(out_dir)
    name = manifest["name"]
    done, points = [], []
    for value, key in zip(manifest["values"], manifest["keys"], strict=True):
        try:
            point = _stored_point(out_dir / POINTS / _point_stem(name, key), manifest, key)
        except DamagedResultError as err:
            if not partial:
                raise DamagedResultError(
                    f"{err}: {_RESUME} to compute {name}={value} again, "
                    "or load the other points with partial=True"
                ) from None
            warnings.warn(f"{err}; {name}={value} is left out", DamagedPointWarning, stacklevel=2)
            continue
        if point is not None:
            done.append(value)
            points.append(point)
    missing = len(manifest["values"]) - len(done)
    if missing and not partial:
        raise FileNotFoundError(
            f"{missing} of {len(manifest['values'])} points of {out_dir} are missing: "
            "finish it with run_scan(..., resume=True), or load it with partial=True"
        )
    arrays = {name: np.asarray(done, dtype=float)}
    if points:
        if manifest["compute"]["function"].startswith("bbdyn."):  # bbdyn's: the schema's keys
            for point in points:
                point.arrays = {standard_key(k): a for k, a in point.arrays.items()}
        names = list(points[0].arrays)
        for value, point in zip(done, points, strict=True):
            if list(point.arrays) != names:
                raise ValueError(
                    f"{name}={value} has outputs {list(point.arrays)}, other points {names}"
                )
        for k in names:
            shapes = {p.arrays[k].shape for p in points}
            if len(shapes) > 1:
                raise ValueError(f"output {k!r} has different shapes across points: {shapes}")
            arrays[k] = np.stack([p.arrays[k] for p in points])
    meta = {k: v for k, v in manifest.items() if k != "kind"}
    meta.update(n_missing=missing, points=[p.meta for p in points])
    return ScanResult(arrays, meta)
