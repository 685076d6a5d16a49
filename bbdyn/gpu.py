"""Ensembles on an NVIDIA GPU: the CUDA engine behind ``device="cuda"`` (docs/gpu.md).

``run_cuda(jobs)`` runs the particles of one or many ensembles (``CudaJob``: the kernel's
inputs and outputs of one ensemble, as ``bbdyn.ensemble`` prepares them for the CPU) on
the GPU with ``core.cuda_ensemble``'s kernel, one thread per particle, all points of a
group in one launch; the outputs are written into each job's arrays, as the CPU kernel
writes them.  The engine chooses the launch (``THREADS_PER_BLOCK``), the groups of points
that fit in the device's memory (``MEMORY_FRACTION`` of its free memory, ``state_bytes``
per particle) and the chunks of events per launch (``CHUNK_EVENTS``, through
``bbdyn.runs.run_chunked``: Ctrl-C stops the run between launches and the numbers do not
depend on the chunks).  Fast-forward is not compiled for the device: every event is made.

Needs numba-cuda and an NVIDIA driver (``pip install 'bbdyn[gpu]'``); ``cuda_device``
raises ``NoDeviceError`` with ``NO_DEVICE`` otherwise.  With ``NUMBA_ENABLE_CUDASIM=1``
(set before numba is imported) everything runs in numba's CUDA simulator on the host.
"""

from __future__ import annotations

import functools
import math
import platform
import warnings
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np
from numba.core.errors import NumbaPerformanceWarning

from bbdyn.core.layout import (
    CARRY_WIDTH,
    CNT_WIDTH,
    REC_WIDTH,
    RUNNING,
    EnsembleOut,
    PointTable,
)
from bbdyn.params import KernelParams
from bbdyn.runs import Carry, run_chunked

__all__ = [
    "DEVICES",
    "NO_DEVICE",
    "NoDeviceError",
    "CudaJob",
    "check_device",
    "cuda_device",
    "device_info",
    "run_cuda",
    "state_bytes",
]

#: Where ensembles run.
DEVICES = ("cpu", "cuda")
#: What is said when ``device="cuda"`` finds no GPU (the CLI prints it and exits with 1).
NO_DEVICE = (
    "no CUDA device or driver found: install the gpu extra on a machine with an NVIDIA GPU, "
    "or leave out --device"
)
#: Threads per block: the particle loop is long and register-heavy, so blocks are small.
THREADS_PER_BLOCK = 128
#: Events per launch, summed over its particles (``run_chunked``): a launch of a full scan
#: takes about a second, and returns to Python for progress and Ctrl-C.
CHUNK_EVENTS = 2_000_000_000
#: Share of the device's free memory a group of points may take.
MEMORY_FRACTION = 0.5


class NoDeviceError(RuntimeError):
    """``device="cuda"`` but numba-cuda, the driver or a GPU is missing."""


def check_device(device) -> str:
    """``device`` if it is one of ``DEVICES``; ValueError naming them otherwise."""
    if device not in DEVICES:
        raise ValueError(f"device must be one of {DEVICES}, got {device!r}")
    return device


def _cuda():
    """numba's CUDA module; ``NoDeviceError`` if it or a usable device is missing."""
    try:
        from numba import cuda
    except ImportError:
        raise NoDeviceError(NO_DEVICE) from None
    try:
        usable = cuda.is_available()
    except Exception:  # a broken driver install: numba-cuda raises its own errors
        usable = False
    if not usable:
        raise NoDeviceError(NO_DEVICE)
    return cuda


def simulated() -> bool:
    """Whether numba's CUDA simulator stands in for the device (``NUMBA_ENABLE_CUDASIM=1``)."""
    return bool(numba.config.ENABLE_CUDASIM)


def cuda_device() -> str:
    """The name of the current CUDA device ("CUDA simulator" in numba's simulator);
    ``NoDeviceError`` (message ``NO_DEVICE``) without one."""
    cuda = _cuda()
    if simulated():
        return "CUDA simulator"
    name = cuda.get_current_device().name
    return name.decode() if isinstance(name, bytes) else str(name)


@functools.cache
def _cpu_name() -> str:
    """The CPU's model name (Linux: /proc/cpuinfo), else the machine type."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def device_info(device: str) -> dict[str, str]:
    """``{"device", "device_name"}`` of a run on ``device`` (the provenance of its result)."""
    name = cuda_device() if check_device(device) == "cuda" else _cpu_name()
    return {"device": device, "device_name": name}


class CudaJob(NamedTuple):
    """One ensemble's kernel inputs and outputs for ``run_cuda`` (``bbdyn.ensemble``).

    ``kp`` its ``KernelParams``; ``times`` its ``RunTimes`` (one block); ``obs`` its
    ``Observables`` (no record, no fast-forward); ``state`` its loop states (n,
    CARRY_WIDTH), updated in place; ``out`` its ``EnsembleOut`` (no record), filled in
    place.
    """

    kp: tuple
    times: tuple
    obs: tuple
    state: np.ndarray
    out: tuple


def state_bytes(n: int, n_samples: int, jump_capacity: int = 0) -> int:
    """Device memory (bytes) of ``n`` particles with ``n_samples`` displacement samples and
    ``jump_capacity`` stored jumps each: loop state, outputs and point index."""
    per = 8 * (CARRY_WIDTH + n_samples + 2 * 4 + CNT_WIDTH + 2 * jump_capacity + 7 + 1 + 1)
    return int(n) * per


@functools.cache
def _kernel():
    """The compiled-on-first-launch kernel (one per process)."""
    # lazy: imports numba.cuda, which needs numba-cuda and reads NUMBA_ENABLE_CUDASIM once
    from bbdyn.core.cuda_ensemble import make_kernel

    return make_kernel(KernelParams)


def _job_bytes(job: CudaJob) -> int:
    """Device memory of one job's particles (``state_bytes``)."""
    out = job.out
    return state_bytes(job.state.shape[0], out.displacement.shape[1], out.jump_len.shape[1])


def _groups(jobs: list[CudaJob], budget_bytes: float) -> list[list[CudaJob]]:
    """Consecutive jobs packed into groups of at most ``budget_bytes`` of device memory
    (a job larger than that alone)."""
    groups: list[list[CudaJob]] = [[]]
    used = 0
    for job in jobs:
        if groups[-1] and used + _job_bytes(job) > budget_bytes:
            groups.append([])
            used = 0
        groups[-1].append(job)
        used += _job_bytes(job)
    return groups


def run_cuda(jobs: list[CudaJob], *, chunk_events=None, progress=None) -> dict:
    """Run every job's particles on the GPU until each has ended; fill their outputs.

    The jobs must share the observables, the number of sample times and the jump
    capacity.  Returns ``{"launches", "groups", "bytes"}``: kernel launches, groups of
    points and the largest group's device memory (bytes).  ``progress`` (optional) gets
    the fraction of the particles' simulated time done.
    """
    cuda = _cuda()
    shapes = {(j.obs.flags, j.out.displacement.shape[1], j.out.jump_len.shape[1]) for j in jobs}
    if len(shapes) > 1:
        raise ValueError(
            "the ensembles of one GPU run must share observables, sample times and jump "
            f"capacity, got (flags, samples, capacity) {sorted(shapes)}"
        )
    free = math.inf if simulated() else cuda.current_context().get_memory_info()[0]
    total = sum(j.state.shape[0] for j in jobs)
    stats = {"launches": 0, "groups": 0, "bytes": 0}
    done = 0
    for group in _groups(jobs, MEMORY_FRACTION * free):
        n = sum(j.state.shape[0] for j in group)

        def tell(fraction, n=n, done=done):
            if progress is not None:
                progress((done + fraction * n) / total)

        with warnings.catch_warnings():
            # a small run leaves most of the device idle, as docs/gpu.md says: no warning
            warnings.simplefilter("ignore", NumbaPerformanceWarning)
            stats["launches"] += _run_group(cuda, group, chunk_events, tell)
        stats["groups"] += 1
        stats["bytes"] = max(stats["bytes"], sum(_job_bytes(j) for j in group))
        done += n
    return stats


def _padded(a: np.ndarray) -> np.ndarray:
    """``a``, or zeros with every dimension at least 1 if ``a`` is empty (an observable that
    is off): the device never holds an empty array."""
    return a if a.size else np.zeros(tuple(max(s, 1) for s in a.shape), a.dtype)


def _times_row(job: CudaJob) -> list[float]:
    """The row of ``PointTable.times`` (columns ``T_*``) of a job."""
    t = job.times
    return [t.end_periods, t.end_phase, t.p0, t.L, job.obs.split_periods]


def launch_arguments(jobs: list[CudaJob]) -> tuple:
    """The kernel's host arguments ``(table, flags, carry, out)`` for ``jobs`` stacked: their
    particles one after the other, their status ``RUNNING``; ``carry`` without rings (the
    device never fast-forwards), ``out`` without a record (empty arrays stay empty here)."""
    sizes = [j.state.shape[0] for j in jobs]
    table = PointTable(
        params=np.array([tuple(j.kp) for j in jobs], dtype=float),
        times=np.array([_times_row(j) for j in jobs], dtype=float),
        sample_periods=np.stack([j.times.sample_periods for j in jobs]),
        sample_phase=np.stack([j.times.sample_phase for j in jobs]),
        record=np.zeros(2),
        point=np.repeat(np.arange(len(jobs), dtype=np.int64), sizes),
    )
    out = {name: np.concatenate([getattr(j.out, name) for j in jobs])
           for name in EnsembleOut._fields if name != "record"}  # fmt: skip
    out["status"][:] = RUNNING
    out = EnsembleOut(**out, record=np.zeros((0, 0, REC_WIDTH)))
    carry = Carry(np.concatenate([j.state for j in jobs]),
                  *(np.zeros((0, 0, k)) for k in (5, 4)),
                  np.zeros((0, 0, CNT_WIDTH), np.int64), np.zeros((0, 0, 3)))  # fmt: skip
    return table, jobs[0].obs.flags, carry, out


def _run_group(cuda, group: list[CudaJob], chunk_events, progress) -> int:
    """One group of jobs on the device: stack, upload, launch until done, download, split.
    Returns the number of launches."""
    table, flags, host, out = launch_arguments(group)
    state = host.state
    put = (lambda a: a) if simulated() else cuda.to_device
    d_table = PointTable(*(put(_padded(a)) for a in table))
    d_out = EnsembleOut(*(put(_padded(a)) for a in out))
    d_carry = Carry(*(put(_padded(a)) for a in host))
    kernel = _kernel()
    blocks = (state.shape[0] + THREADS_PER_BLOCK - 1) // THREADS_PER_BLOCK
    launches = 0

    def advance(budget):
        nonlocal launches
        kernel[blocks, THREADS_PER_BLOCK](d_table, flags, d_carry, np.int64(budget), d_out)
        cuda.synchronize()
        launches += 1
        if not simulated():
            d_out.status.copy_to_host(out.status)
            d_carry.state.copy_to_host(state)

    sizes = [j.state.shape[0] for j in group]
    end = np.repeat([j.times.end_periods + j.times.end_phase / (2 * math.pi) for j in group], sizes)
    chunk = CHUNK_EVENTS if chunk_events is None else chunk_events
    run_chunked(advance, host, out.status, end, chunk_events=chunk, progress=progress)
    fields = [name for name in EnsembleOut._fields if name != "record"]
    if not simulated():
        for name in fields:
            if getattr(out, name).size:
                getattr(d_out, name).copy_to_host(getattr(out, name))
    cuts = np.cumsum([0, *sizes])
    for k, job in enumerate(group):
        a, b = cuts[k], cuts[k + 1]
        job.state[:] = state[a:b]
        for name in fields:
            getattr(job.out, name)[:] = getattr(out, name)[a:b]
    return launches
