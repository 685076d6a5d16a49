"""Generic timing for benchmarks: compile first, repeat, report medians and ratios.

Every benchmark in bbdyn times a zero-argument callable with ``measure``: one
call first (numba compilation, caches), then an inner loop long enough to be
measurable, repeated; the median per call is the figure of merit.  Ratios are
formed between medians measured in the same run (``ratios``), never against
numbers from another run or machine.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["Timing", "measure", "ratios", "single_thread"]


@dataclass(frozen=True)
class Timing:
    """Seconds per call of a timed callable.

    Attributes
    ----------
    median_s, min_s : float
        Median and minimum over the repeats of the mean time of one call (s).
    repeats : int
        Number of repeats (each a loop of ``inner`` calls).
    inner : int
        Calls per repeat.
    """

    median_s: float
    min_s: float
    repeats: int
    inner: int

    def per_second(self, work: float) -> float:
        """Throughput: ``work`` units done by one call, per second (median)."""
        return work / self.median_s


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
    >>> t.median_s > 0
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
    per_call = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(inner):
            fn()
        per_call.append((time.perf_counter() - start) / inner)
    return Timing(statistics.median(per_call), min(per_call), repeats, inner)


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

    ``columns`` holds ``(key, header, width, format)``; a missing value prints as
    nan (0 for a column without a format: counts).
    """
    head = f"{'method':<11} {'setting':<{setting_width}}"
    head += "".join(f" {title:>{width}}" for _, title, width, _ in columns)
    lines = [head]
    for r in rows:
        line = f"{r['method']:<11} {r['setting']:<{setting_width}}"
        for key, _, width, spec in columns:
            value = r.get(key, 0 if spec == "" else math.nan)
            line += f" {value:>{width}{spec}}"
        lines.append(line)
    return lines
