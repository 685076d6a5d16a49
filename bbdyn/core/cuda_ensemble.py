"""The ensemble's particle loop as a CUDA kernel: one thread per particle, many points per launch.

``ensemble_kernel`` is compiled by numba's CUDA target (``numba-cuda``) from the same
function as the CPU's ``run_ensemble``: each thread calls ``core.ensemble.particle_loop``,
which numba-cuda compiles as a device function from its Python source (``core.targets``),
so the physics exists once.  The loop is compiled without the fast-forward (``ff`` is
None: ``fast_forward`` allocates, which device code cannot), so a particle on the device
makes every event; its numbers are those of ``fast_forward="off"`` on the CPU.

One launch holds the particles of several points (frequencies of a scan, each with its
own parameters, run times and sample times): ``PointTable`` gives each particle's point
and each point's row of parameters (``KernelParams`` fields in their order) and times;
the thread builds its ``KernelParams`` and ``RunTimes`` from them.  The per-particle
arrays (``bbdyn.runs.Carry``, ``EnsembleOut``) are those of the CPU, stacked over the
points' particles.

In numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``) the kernel runs as Python on the
host and calls ``particle_loop`` as compiled for the CPU (with ``ff`` None, as on the
device): it checks the launch, the tables and the bookkeeping, not the device's arithmetic.
"""

import numpy as np
from numba import cuda, njit

from bbdyn.core.ensemble import particle_loop
from bbdyn.core.layout import (
    RUNNING,
    T_END_P,
    T_END_PH,
    T_L,
    T_P0,
    T_SPLIT,
    Observables,
    RunTimes,
)


def params_builder(kernel_params):
    """A jitted ``build(row) -> kernel_params(row[0], row[1], ...)`` for the NamedTuple class
    ``kernel_params`` (``bbdyn.params.KernelParams``): written from its fields, so the
    device builds the very tuple the CPU gets from ``Params.kernel()``."""
    args = ", ".join(f"row[{k}]" for k in range(len(kernel_params._fields)))
    scope = {"KernelParams": kernel_params}
    exec(f"def build(row):\n    return KernelParams({args})\n", scope)  # noqa: S102
    return njit(scope["build"])


def make_kernel(kernel_params):
    """The CUDA kernel ``kernel(table, flags, carry, budget, out)`` (``cuda.jit``, compiled
    lazily at its first launch) for the parameter tuple class ``kernel_params``.

    Advances each running particle ``i`` (``out.status[i] == RUNNING``) of the launch by at
    most ``budget`` events with ``particle_loop`` at its point's parameters and times;
    ``flags`` are the ``Observables`` flags (no record, no fast-forward).  Launch with at
    least ``out.status.shape[0]`` threads.
    """
    build = params_builder(kernel_params)  # a CPU dispatcher: device code compiles its source

    def kernel(table, flags, carry, budget, out):
        i = cuda.grid(1)
        if i >= out.status.shape[0] or out.status[i] != RUNNING:
            return
        p = table.point[i]
        kp = build(table.params[p])
        tm = table.times[p]
        times = RunTimes(tm[T_END_P], tm[T_END_PH], tm[T_P0], tm[T_L], 1,
                         table.sample_periods[p], table.sample_phase[p])  # fmt: skip
        obs = Observables(flags, table.record, table.record, tm[T_SPLIT])
        out.status[i] = particle_loop(carry, np.int64(i), budget, kp, times, out, obs, None, None)

    return cuda.jit(kernel)
