"""Random restitution: the collision law's coefficients drawn afresh for every flight
(docs/model.md, "Noise").

With noise amplitude ``eta`` in [0, 1] (``KernelParams.eta``), the flight that starts at
a particle's event takes its own normal and tangential restitution coefficients

    c_n = c + eta m(c) (2 u_n - 1),    m(c) = min(c, 1 - c),    c in {alpha, beta},

``u_n`` uniform in [0, 1): ``c_n`` is uniform on ``[c - eta m, c + eta m)``, which lies in
[0, 1] (no clipping), with mean ``c`` and variance ``(eta m)^2 / 3``; for ``c <= 1/2`` it is
``c (1 + eta (2u - 1))``, a relative amplitude eta (alpha = 0.5), and near 1 the loss
``1 - c`` varies by the relative amount eta (beta = 0.99: ``c_n < 1`` always, so chattering
still ends in a stick).  The two uniforms come from one ``philox4x32`` call with the counter
``(n, particle)`` (64 bits each, low word first) and the run's 64-bit key: the flight
index n, the particle's index and the key fix them, whatever the threads, chunks or device.

The event step is untouched: the particle loop hands ``event_search`` a ``KernelParams``
with the drawn coefficients (``noisy_params``), so the impact that ends the flight, any
wedge reflections at it and a chattering sequence that follows (summed in closed form
by the event step) all use this draw.
"""

from numba import njit
from numba.extending import overload

from bbdyn.core.fmath import fmin2
from bbdyn.core.rng import MASK32, SHIFT32, philox4x32, unit_double
from bbdyn.core.tolerances import FMA

__all__ = ["drawn_coefficient", "noisy_params", "with_restitution"]


@njit(cache=True, fastmath=FMA, inline="always")
def drawn_coefficient(c, eta, u):
    """The coefficient ``c`` (in [0, 1]) perturbed by ``eta`` (in [0, 1]) with the uniform
    ``u`` in [0, 1): ``c + eta min(c, 1 - c) (2 u - 1)``, in ``[0, 1]``."""
    return c + eta * fmin2(c, 1.0 - c) * (2.0 * u - 1.0)


def with_restitution(kp, alpha, beta):
    """``kp`` (a ``KernelParams``) with ``alpha`` and ``beta`` replaced; compiled code builds
    the same NamedTuple type field by field (numba has no ``_replace``)."""
    return kp._replace(alpha=alpha, beta=beta)


@overload(with_restitution, jit_options={"fastmath": FMA})
def _with_restitution(kp, alpha, beta):
    # the constructor call for kp's own fields, whatever they are: kp.A, kp.w, ..., alpha,
    # beta, ... (the NamedTuple type fixes them at compile time)
    args = ", ".join(f if f in ("alpha", "beta") else f"kp.{f}" for f in kp.fields)
    scope: dict = {}
    exec(f"def impl(kp, alpha, beta):\n    return cls({args})\n", {"cls": kp.instance_class}, scope)
    return scope["impl"]


@njit(cache=True, fastmath=FMA, inline="always")
def noisy_params(kp, key0, key1, particle, n):
    """``kp`` with the restitution coefficients of flight ``n`` of ``particle`` drawn with
    amplitude ``kp.eta`` (see the module docstring).

    ``key0, key1``: the run's key (32-bit words), ``particle`` and ``n``: 64-bit counts; all
    ``uint64``.  Returns a ``KernelParams``.
    """
    x0, x1, x2, x3 = philox4x32(n & MASK32, n >> SHIFT32, particle & MASK32,
                                particle >> SHIFT32, key0, key1)  # fmt: skip
    alpha = drawn_coefficient(kp.alpha, kp.eta, unit_double(x0, x1))
    beta = drawn_coefficient(kp.beta, kp.eta, unit_double(x2, x3))
    return with_restitution(kp, alpha, beta)
