"""Minimum and maximum of two floats with the same bits on the CPU and on CUDA.

Python's ``min`` and ``max`` compiled by numba for the CPU return the first argument
unless the second compares strictly on the right side of it (``b < a`` for ``min``:
``min(a, nan)`` is ``a``, ``min(nan, b)`` is nan, ``min(0.0, -0.0)`` is ``0.0``);
numba's CUDA target lowers them to PTX ``min.f64`` and ``max.f64``, which return the
non-NaN operand.  The event step uses these helpers instead, so both targets compute
the same select of one comparison.
"""

from numba import njit

from bbdyn.core.tolerances import FMA


@njit(cache=True, fastmath=FMA, inline="always")
def fmin2(a, b):
    """``b`` if ``b < a`` else ``a`` (Python's ``min(a, b)``: NaN and signed zeros alike)."""
    return b if b < a else a


@njit(cache=True, fastmath=FMA, inline="always")
def fmax2(a, b):
    """``b`` if ``b > a`` else ``a`` (Python's ``max(a, b)``: NaN and signed zeros alike)."""
    return b if b > a else a


@njit(cache=True, fastmath=FMA, inline="always")
def clamp(x, lo, hi):
    """``fmin2(fmax2(x, lo), hi)``: ``x`` limited to ``[lo, hi]``."""
    return fmin2(fmax2(x, lo), hi)
