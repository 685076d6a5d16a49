"""Resumable, parallel parameter scans (issue 4, item 3); see docs/scans.md.

``run_scan(values, compute, out_dir=..., seed=...)`` calls
``compute(value, seed_sequence) -> dict`` once per value, in worker processes
(or on a dask cluster), and stores every finished point at once, atomically.
The scan is generic: it knows nothing about the physics in ``compute``.

Layout of ``out_dir``::

    manifest.json                 the scan: name, values, seed, compute (written first)
    points/f_58.000000000.npz     one point's arrays (loaded with allow_pickle=False)
    points/f_58.000000000.json    its metadata; written last, so it marks the point done

Seeds.  The point at ``value`` gets ``np.random.SeedSequence(seed, spawn_key=(key,))``
with ``key = round(value * 10**9)``: the value rounded to 1e-9 (Hz for a frequency
scan).  It depends on ``(seed, value)`` only, never on the order of the values,
the worker, the thread count or the machine, so an interrupted and resumed scan,
a scan in another order and a scan on a cluster give identical numbers.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import functools
import json
import multiprocessing
import os
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from bbdyn.progress import Progress, progress_stream
from bbdyn.results import Result, make_meta, result_paths, write_json_atomic

__all__ = [
    "KEY_SCALE",
    "ScanResult",
    "describe_compute",
    "load_scan",
    "point_key",
    "point_seed",
    "run_scan",
    "settings_folder",
]

#: Seed keys are the values rounded to 1 / KEY_SCALE (1e-9 Hz for frequencies).
KEY_SCALE = 10**9
MANIFEST = "manifest.json"
POINTS = "points"
#: Manifest fields that define a scan; resuming with any of them changed is refused.
_DEFINING = ("name", "values", "keys", "seed", "compute")


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


def _prepare_out_dir(out_dir: Path, manifest: dict[str, Any], resume: bool) -> None:
    path = out_dir / MANIFEST
    if path.exists():
        if not resume:
            raise FileExistsError(
                f"{out_dir} already holds a scan; pass resume=True to finish it, "
                "or choose a new out_dir"
            )
        with open(path) as fh:
            old = json.load(fh)
        differ = [k for k in _DEFINING if old.get(k) != manifest[k]]
        if differ:
            raise ValueError(
                f"{out_dir} holds a different scan (differs in: {', '.join(differ)}); "
                "resume it with the same values, seed and compute, or choose a new out_dir"
            )
        # leftovers of writes cut short by a crash; the point is simply computed again
        for tmp in (out_dir / POINTS).glob("*.tmp"):
            tmp.unlink()
    else:
        write_json_atomic(path, manifest)
    (out_dir / POINTS).mkdir(parents=True, exist_ok=True)


def _is_done(stem: Path) -> bool:
    return all(p.exists() for p in result_paths(stem))


# ---- one point, in a worker -----------------------------------------------------------------
def _run_point(compute: Callable, value: float, seed: int) -> tuple[dict, dict]:
    """Run one point (in a worker process): ``compute`` with one numba thread, timed."""
    import numba

    from bbdyn import __version__

    # One thread per point: a point's numbers never depend on the thread count,
    # and the processes (not threads) share the cores.
    numba.set_num_threads(1)
    t0 = time.perf_counter()
    out = compute(value, point_seed(seed, value))
    wall = time.perf_counter() - t0
    info = {"wall_s": wall, "host": socket.gethostname(), "pid": os.getpid()}
    info["bbdyn_version"] = __version__
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
class _LocalBackend:
    """Worker processes on this machine (``concurrent.futures.ProcessPoolExecutor``)."""

    def __init__(self, workers: int):
        # forkserver: workers are forked from a clean server process, never from this
        # (possibly multi-threaded) one; bbdyn.scan is preloaded so forks start fast.
        if "forkserver" in multiprocessing.get_all_start_methods():
            ctx = multiprocessing.get_context("forkserver")
            ctx.set_forkserver_preload(["bbdyn.scan"])
        else:
            ctx = multiprocessing.get_context("spawn")
        self.pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
        self.in_flight = 2 * workers

    def submit(self, compute, value, seed):
        return self.pool.submit(_run_point, compute, value, seed)

    def wait_any(self, futures):
        return cf.wait(futures, return_when=cf.FIRST_COMPLETED).done

    def close(self, interrupted: bool, running) -> None:
        # shutdown() cannot stop a running point; without terminating the workers
        # the interpreter would wait at exit for every running point to finish.
        procs = list((getattr(self.pool, "_processes", None) or {}).values())
        self.pool.shutdown(wait=not interrupted, cancel_futures=True)
        if interrupted:
            for proc in procs:
                proc.terminate()


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
            self.client, self.own_client = distributed.Client(scheduler), True
        else:
            raise ValueError(
                f"scheduler must be an address string or a distributed.Client, got {scheduler!r}"
            )
        # the scheduler balances the whole scan; we only cap memory held by results
        self.in_flight = 10_000

    def submit(self, compute, value, seed):
        return self.client.submit(_run_point, compute, value, seed, pure=False)

    def wait_any(self, futures):
        return self.distributed.wait(list(futures), return_when="FIRST_COMPLETED").done

    def close(self, interrupted: bool, running) -> None:
        if interrupted:
            self.client.cancel(list(running))
        if self.own_client:
            self.client.close()


def _available_cores() -> int:
    if hasattr(os, "sched_getaffinity"):  # respects taskset / container CPU limits
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


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
    _prepare_out_dir(out_dir, manifest, resume)

    stems = {v: out_dir / POINTS / _point_stem(name, k) for v, k in zip(floats, keys, strict=True)}
    todo = [v for v in floats if not _is_done(stems[v])]
    bar = Progress(len(floats), done=len(floats) - len(todo), label=name, stream=stream)
    try:
        if todo:
            if scheduler is not None:
                backend = _DaskBackend(scheduler)
            else:
                backend = _LocalBackend(min(workers or _available_cores(), len(todo)))
            with _sigterm_as_interrupt():
                _drive(backend, todo, compute, seed, name, stems, manifest, bar, out_dir)
    finally:
        bar.close()
    return load_scan(out_dir)


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

    def plot(self, ax=None, key: str | None = None):
        """Plot the scalar output ``key`` (default: the first one) against the values.

        Draws error bars when an output ``key + "_err"`` exists.  Returns the axes.
        """
        import matplotlib.pyplot as plt

        scalars = [k for k, a in self.arrays.items() if k != self.name and a.ndim == 1]
        if key is None:
            if not scalars:
                raise ValueError("this scan has no scalar output to plot")
            key = scalars[0]
        if key not in scalars:
            raise ValueError(f"key must be one of the scalar outputs {scalars}, got {key!r}")
        if ax is None:
            _, ax = plt.subplots()
        order = np.argsort(self.values, kind="stable")
        x, y = self.values[order], self.arrays[key][order]
        err = self.arrays.get(key + "_err")
        if err is not None and err.ndim == 1:
            ax.errorbar(x, y, yerr=err[order], fmt="o-", ms=3, capsize=2)
        else:
            ax.plot(x, y, "o-", ms=3)
        ax.set_xlabel(self.name)
        ax.set_ylabel(key)
        return ax


def load_scan(out_dir: str | os.PathLike, *, partial: bool = False) -> ScanResult:
    """Load a scan folder written by ``run_scan`` (without unpickling anything).

    With ``partial=True`` an unfinished scan loads its finished points only;
    otherwise a missing point raises ``FileNotFoundError``.
    """
    out_dir = Path(out_dir)
    with open(out_dir / MANIFEST) as fh:
        manifest = json.load(fh)
    if manifest.get("kind") != "scan_manifest":
        raise ValueError(f"{out_dir / MANIFEST} is not a scan manifest")
    name = manifest["name"]
    done, points = [], []
    for value, key in zip(manifest["values"], manifest["keys"], strict=True):
        stem = out_dir / POINTS / _point_stem(name, key)
        if _is_done(stem):
            done.append(value)
            points.append(_ScanPoint.load(stem))
    missing = len(manifest["values"]) - len(done)
    if missing and not partial:
        raise FileNotFoundError(
            f"{missing} of {len(manifest['values'])} points of {out_dir} are missing: "
            "finish it with run_scan(..., resume=True), or load it with partial=True"
        )
    arrays = {name: np.asarray(done, dtype=float)}
    if points:
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


def settings_folder(prefix: str, settings: dict, keys, seed: int, out_dir=None) -> Path:
    """Folder of the scan behind a scene setting: ``<out_dir>/scans/<prefix>_<digest>``.

    The digest covers ``settings[k]`` for ``k in keys``, the seed and the package
    version, so scenes with the same setting share one scan and a new version never
    reuses old numbers.  ``out_dir`` defaults to ``$BBDYN_CACHE`` or ``~/.cache/bbdyn``;
    ``settings["scan_dir"]`` names a folder explicitly.
    """
    import hashlib
    import os

    from bbdyn import __version__

    if settings.get("scan_dir"):
        return Path(settings["scan_dir"])
    if out_dir is None:
        out_dir = os.environ.get("BBDYN_CACHE", Path.home() / ".cache" / "bbdyn")
    defining = {k: settings.get(k) for k in keys} | {"seed": seed, "version": __version__}
    digest = hashlib.sha256(json.dumps(defining, sort_keys=True).encode()).hexdigest()[:12]
    return Path(out_dir) / "scans" / f"{prefix}_{digest}"
