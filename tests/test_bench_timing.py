"""Benchmark timing (bbdyn.reference.timing): wall-clock and CPU time measured side by side.

Independent facts: a call that sleeps takes wall-clock time but (almost) no CPU time; a
single-threaded call that computes cannot use more CPU time than wall-clock time.  The
B2 tables show the CPU-time rate beside the wall-clock one for a run that measured it,
and a run recorded before that (the committed runs of docs/bench) prints as it did.
"""

import math
import time

from bbdyn.reference.timing import measure, rate_columns, rate_key
from bbdyn.scenes import b2_flat

SLEEP_S = 0.02


def test_sleeping_costs_wall_clock_time_and_no_cpu_time():
    t = measure(lambda: time.sleep(SLEEP_S), repeats=3, min_time=0.0)
    assert t.median_s >= SLEEP_S
    assert t.cpu_median_s < 0.25 * SLEEP_S, (t.cpu_median_s, t.median_s)
    rates = t.rates("naps", 1)
    assert rates["naps_per_s"] <= 1 / SLEEP_S < rates["naps_per_cpu_s"]


def test_computing_on_one_thread_uses_at_most_its_wall_clock_time():
    def spin():
        x = 0.0
        for i in range(20_000):
            x += math.sqrt(i)
        return x

    t = measure(spin, repeats=5, min_time=0.01)
    assert 0 < t.cpu_median_s <= t.median_s * 1.05  # clock granularity
    assert t.per_cpu_second(10) == 10 / t.cpu_median_s


def test_rate_columns_of_a_new_and_of_an_old_run():
    new = [{"impacts_per_s": 1.0, "impacts_per_cpu_s": 2.0}]
    old = [{"impacts_per_s": 1.0}]
    assert rate_key(new, "impacts") == ("impacts_per_cpu_s", "CPU time")
    assert rate_key(old, "impacts") == ("impacts_per_s", "wall-clock time")
    assert [c[1] for c in rate_columns(new, "impacts", "impacts", 10)] == [
        "impacts/s wall",
        "impacts/CPU-s",
    ]
    assert [c[1] for c in rate_columns(old, "impacts", "impacts", 10)] == ["impacts/s"]


def test_flat_bench_rows_carry_both_rates_and_the_table_shows_both():
    """A tiny B2-FLAT run: every row has its wall-clock and CPU-time rate; the cost ratio to
    the exact method is one of CPU times."""
    settings = dict(b2_flat.QUICK, n_impacts=3, exact_tols=[], ivp=[], long_run=50)
    settings.update(long_run_fixed=[], continuous_events=100, repeats=1, min_time=0.0)
    res = b2_flat.compute(settings, log=lambda msg: None)
    rows = res.meta["rows"]
    for row in rows:
        assert row["impacts_per_s"] > 0 and row["impacts_per_cpu_s"] > 0, row["setting"]
        ratio = rows[0]["impacts_per_cpu_s"] / row["impacts_per_cpu_s"]
        assert math.isclose(row["cost_ratio_to_exact"], ratio, rel_tol=1e-12)
    head = b2_flat.table(res).splitlines()[0]
    assert "impacts/s wall" in head and "impacts/CPU-s" in head

