"""The core's second target: CUDA device code compiled from the same numba functions.

The event step is written once, as ``@njit`` functions.  numba's CUDA target (the
``numba-cuda`` package, ``pip install bbdyn[gpu]``) compiles a CPU dispatcher called from
CUDA code from its ``py_func`` with its own options (``fastmath``, ``inline``), so the
core's functions are the device functions: a GPU kernel calls ``billiard_event`` or
``flat_event`` as they are, and nothing is copied.  What the event step may therefore
use: scalar arithmetic, ``math`` functions, NamedTuples of scalars (``KernelParams``) and
the ``fmath`` helpers; no ``min``/``max`` builtins (their CUDA lowering differs for
NaN), no numpy calls, no allocation, no Python objects.

``cuda_ptx`` compiles a core function to PTX for a given compute capability, also on a
machine without a GPU (numba-cuda otherwise asks the current device for the compute
capability of each called function); ``cuda_missing`` says why it cannot run here.
"""


class _Device:
    """What numba-cuda asks of the current device while compiling: its compute capability."""

    def __init__(self, cc: tuple[int, int]):
        self.compute_capability = cc


def cuda_missing() -> str | None:
    """Why PTX cannot be compiled here (numba-cuda, NVVM or NVRTC missing), or None.

    numba-cuda alone (the ``test`` extra) runs the CUDA simulator; compiling PTX also needs
    libnvvm and libnvrtc, which come with the NVIDIA wheels of the ``gpu`` extra.
    """
    try:
        import numba_cuda  # noqa: F401
    except ImportError:
        return "numba-cuda is not installed (pip install bbdyn[gpu])"
    from numba.cuda.cudadrv import nvrtc, nvvm

    if not nvvm.is_available():
        return "NVVM (libnvvm) was not found (pip install bbdyn[gpu])"
    try:
        nvrtc.get_supported_ccs()  # loads libnvrtc, which PTX compilation asks for the arch
    except Exception as err:  # cuda-bindings raises its own error types when it is absent
        return f"NVRTC (libnvrtc) was not found (pip install bbdyn[gpu]): {type(err).__name__}"
    return None


def cuda_ptx(func, argtypes: tuple, cc: tuple[int, int] = (9, 0), device: bool = True) -> str:
    """PTX of the numba function ``func`` compiled as a CUDA device function for ``cc``
    (``device=False``: as a kernel; ``func`` then a ``cuda.jit`` kernel).

    Without a GPU, the functions it calls are compiled for ``cc`` too (numba-cuda would
    ask the current device).
    """
    from numba import cuda
    from numba.cuda import dispatcher

    current = dispatcher.get_current_device
    if not cuda.is_available():
        dispatcher.get_current_device = lambda: _Device(cc)
    try:
        ptx, _ = cuda.compile_ptx(func.py_func, argtypes, device=device, cc=cc)
    finally:
        dispatcher.get_current_device = current
    return ptx


def ptx_instructions(ptx: str) -> int:
    """Number of instructions in the PTX text ``ptx`` (all its functions): the lines that
    start with an opcode or a predicate (not directives, labels, braces or comments)."""
    lines = (line.strip() for line in ptx.splitlines())
    return sum(1 for s in lines if s[:1].islower() or s[:1] == "@")
