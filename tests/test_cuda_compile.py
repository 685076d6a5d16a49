"""The event step compiles for CUDA from the same numba functions as for the CPU.

``test_event_step_compiles_to_ptx`` compiles the billiard's and the flat ball's event step
(flight search with tiny hops and the Taylor finish, collision with the chattering sum,
stick and release) to PTX for compute capability 9.0 through ``bbdyn.core.targets``; it
needs numba-cuda and NVVM (``pip install bbdyn[gpu]``), not a GPU, and skips with its
reason elsewhere.  Run with ``-s`` to see the instruction counts.
"""

import ast
import math
from pathlib import Path

import pytest
from numba import njit

from bbdyn import Params
from bbdyn.core import billiard, flat, fmath, targets

CORE = Path(billiard.__file__).parent
#: Modules of the event step: every function here may be compiled for CUDA.
EVENT_STEP = ("billiard", "flat", "floor", "plate", "taylor", "fmath", "tolerances")


def test_event_step_uses_no_min_max_builtins():
    """``min``/``max`` lower differently for NaN on CUDA; the event step uses ``fmath``."""
    for name in EVENT_STEP:
        tree = ast.parse((CORE / f"{name}.py").read_text())
        calls = [
            node.lineno
            for node in ast.walk(tree)
            if isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("min", "max")
        ]
        assert not calls, f"core/{name}.py calls min/max at lines {calls}"


@njit
def _builtin_min_max(a, b):
    return min(a, b), max(a, b)


@pytest.mark.parametrize("a", [-1.0, 0.0, -0.0, 2.5, math.inf, -math.inf, math.nan])
@pytest.mark.parametrize("b", [-1.0, 0.0, -0.0, 2.5, math.inf, -math.inf, math.nan])
def test_fmath_is_python_min_max(a, b):
    """``fmin2``/``fmax2`` return the very object Python's ``min``/``max`` return (NaN,
    signed zeros), in Python and compiled."""
    expect = (min(a, b), max(a, b))
    got_py = (fmath.fmin2.py_func(a, b), fmath.fmax2.py_func(a, b))
    got_jit = (fmath.fmin2(a, b), fmath.fmax2(a, b))
    for got in (got_py, got_jit, _builtin_min_max(a, b)):
        for x, y in zip(got, expect, strict=True):
            assert math.copysign(1.0, x) == math.copysign(1.0, y)
            assert x == y or (math.isnan(x) and math.isnan(y))
    # where the two differ (signed zeros, NaN), the first argument wins unless the
    # second compares strictly on the right side
    assert math.copysign(1.0, fmath.fmin2(0.0, -0.0)) == 1.0
    assert math.copysign(1.0, fmath.fmax2(-0.0, 0.0)) == -1.0


def test_event_step_compiles_to_ptx():
    """Both event steps compile to PTX for sm_90; prints the instructions per event step."""
    missing = targets.cuda_missing()
    if missing:
        pytest.skip(missing)
    from numba import types
    from numba.core.typing import typeof

    kpt = typeof.typeof(Params(f=58.0).kernel())
    f64, i64 = types.float64, types.int64
    steps = {
        "billiard_event": (billiard.billiard_event, (f64,) * 6 + (i64, kpt)),
        "flat_event": (flat.flat_event, (f64,) * 3 + (i64, kpt)),
    }
    for name, (func, argtypes) in steps.items():
        ptx = targets.cuda_ptx(func, argtypes, cc=(9, 0))
        assert ".target sm_90" in ptx
        n = targets.ptx_instructions(ptx)
        assert n > 100
        print(f"{name}: {n} PTX instructions (sm_90, {ptx.count('.func ')} functions)")
