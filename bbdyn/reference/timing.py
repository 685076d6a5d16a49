"""Generic timing for benchmarks: compile first, repeat, report medians and ratios.

Every benchmark in bbdyn times a zero-argument callable with ``measure``: one
call first (numba compilation, caches), then an inner loop long enough to be
measurable, repeated; the median per call is the figure of merit.  Each repeat is
timed twice: by the wall clock (``time.perf_counter``) and by the CPU time of the
process (``time.process_time``: every thread of it, so a multi-threaded call counts
the CPU seconds of all its threads).  On a shared machine the wall-clock time grows
with the load while the CPU time does not; rates are reported per second of both
(``Timing.rates``).  Ratios are formed between medians measured in the same run
(``ratios``), never against numbers from another run or machine.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["Timing", "measure", "ratios", "single_thread", "rate_key", "rate_columns"]


@dataclass(frozen=True)
class Timing:
    """Seconds per call of a timed callable.

    Attributes
    ----------
    median_s, min_s : float
        Median and minimum over the repeats of the mean wall-clock time of one call (s).
    repeats : int
        Number of repeats (each a loop of ``inner`` calls).
    inner : int
        Calls per repeat.
    cpu_median_s : float
        Median over the repeats of the mean CPU time of one call (s, ``time.process_time``:
        all threads of the process).
    """

    median_s: float
    min_s: float
    repeats: int
    inner: int
    cpu_median_s: float

    def per_second(self, work: float) -> float:
        """Throughput: ``work`` units done by one call, per second of wall-clock time (median)."""
        return work / self.median_s

    def per_cpu_second(self, work: float) -> float:
        """Throughput: ``work`` units done by one call, per second of CPU time (median)."""
        return work / self.cpu_median_s

    def rates(self, name: str, work: float) -> dict[str, float]:
        """``{name}_per_s`` (per wall-clock second) and ``{name}_per_cpu_s`` (per CPU second)
        of ``work`` units done by one call, e.g. ``rates("impacts", n)``."""
        return {
            f"{name}_per_s": self.per_second(work),
            f"{name}_per_cpu_s": self.per_cpu_second(work),
        }


def single_thread() -> None:
    """Restrict numba's thread pool to one thread (benchmarks are single core)."""
    import numba

    numba.set_num_threads(1)


def measure(fn: Callable[[], object], *, repeats: int = 5, min_time: float = 0.05) -> Timing:
    """Time ``fn()`` after a first (compiling, warming) call.

    Parameters
    ----------
    fn : callable
        Takes no arguments; its result is ignored.
    repeats : int
        Number of timed repeats (>= 1); the median is reported.
    min_time : float
        Each repeat loops ``fn`` until it takes at least this long (s), so that
        the clock's resolution is negligible.

    Examples
    --------
    >>> t = measure(lambda: sum(range(100)), repeats=3, min_time=0.001)
    >>> t.median_s > 0 and t.cpu_median_s > 0
    True
    """
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    if not min_time >= 0:
        raise ValueError(f"min_time must be >= 0 s, got {min_time}")
    start = time.perf_counter()
    fn()  # compile and warm up; not timed
    first = time.perf_counter() - start
    # A call slower than min_time (even its first, compiling run) is timed alone.
    inner = 1 if first >= min_time else _calibrate(fn, min_time)
    per_call, cpu_per_call = [], []
    for _ in range(repeats):
        start, cpu_start = time.perf_counter(), time.process_time()
        for _ in range(inner):
            fn()
        cpu_per_call.append((time.process_time() - cpu_start) / inner)
        per_call.append((time.perf_counter() - start) / inner)
    return Timing(
        statistics.median(per_call), min(per_call), repeats, inner, statistics.median(cpu_per_call)
    )


def _calibrate(fn: Callable[[], object], min_time: float) -> int:
    """Smallest power of two of calls that take at least ``min_time``."""
    inner = 1
    while True:
        start = time.perf_counter()
        for _ in range(inner):
            fn()
        if time.perf_counter() - start >= min_time:
            return inner
        inner *= 2


def ratios(values: dict[str, float], reference: str) -> dict[str, float]:
    """Each value divided by ``values[reference]`` (medians from the same run)."""
    ref = values[reference]
    return {key: value / ref for key, value in values.items()}


def rate_key(rows: list[dict], name: str) -> tuple[str, str]:
    """The key of the rate of ``name`` to compare ``rows`` by, and its clock in words:
    ``{name}_per_cpu_s`` ("CPU time") when every row has it, else ``{name}_per_s``
    ("wall-clock time": a run recorded before benchmarks measured CPU time)."""
    cpu = f"{name}_per_cpu_s"
    if rows and all(cpu in r for r in rows):
        return cpu, "CPU time"
    return f"{name}_per_s", "wall-clock time"


def rate_columns(rows: list[dict], name: str, header: str, width: int) -> tuple:
    """Table columns (as ``format_rows`` takes them) of the rate of ``name``: per second of
    wall-clock time (``header/s wall``) and per second of CPU time (``header/CPU-s``).  A
    run recorded before benchmarks measured CPU time has the first alone, headed
    ``header/s`` as it was printed then."""
    wall = (f"{name}_per_s", f"{header}/s", width, ".3g")
    if rate_key(rows, name)[0] == wall[0]:
        return (wall,)
    return (
        (wall[0], f"{header}/s wall", width + 5, ".3g"),
        (f"{name}_per_cpu_s", f"{header}/CPU-s", width + 4, ".3g"),
    )


#: Columns shared by the work-precision tables: (row key, header, width, format).
ERROR_COLUMNS = (
    ("max_time_error_s", "max dt (s)", 10, ".2e"),
    ("max_velocity_error", "max dv (mm/s)", 13, ".2e"),
    ("median_time_error_s", "med dt (s)", 10, ".2e"),
    ("wrong_contacts", "wrong", 5, ""),
    ("cost_ratio_to_exact", "cost/exact", 10, ".3g"),
)


def format_rows(rows: list[dict], columns, setting_width: int) -> list[str]:
    """Benchmark rows as plain-text lines: method, setting, then ``columns``.

    ``columns`` holds ``(key, header, width, format)``; a value the row does not measure
    (missing, or NaN) prints as ``-`` (0 for a column without a format: counts).
    """
    head = f"{'method':<11} {'setting':<{setting_width}}"
    head += "".join(f" {title:>{width}}" for _, title, width, _ in columns)
    lines = [head]
    for r in rows:
        line = f"{r['method']:<11} {r['setting']:<{setting_width}}"
        for key, _, width, spec in columns:
            value = r.get(key, 0 if spec == "" else math.nan)
            text = "-" if spec and math.isnan(value) else f"{value:{spec}}"
            line += f" {text:>{width}}"
        lines.append(line)
    return lines
