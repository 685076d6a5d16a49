"""Runs cut into chunks of events (issue 10): the same numbers, and Ctrl-C stops them.

The kernels carry each particle's whole loop state across chunks (``core.ensemble.Carry``),
so a run cut after any number of events makes the same operations in the same order as
one uncut run: every output must be bitwise equal, whatever the chunk size and the number
of threads.  Between chunks Python runs, so a KeyboardInterrupt (Ctrl-C) stops the run.
"""

import os
import signal
import subprocess
import sys

import numba
import numpy as np
import pytest

import bbdyn.runs
from bbdyn import Params
from bbdyn.classify import trajectory_features
from bbdyn.ensemble import ensemble

ALL = ("displacement", "energy", "jumps", "record")
THREADS = [1, 2] if numba.config.NUMBA_NUM_THREADS >= 2 else [1]


def _equal(a, b):
    assert a.arrays.keys() == b.arrays.keys()
    for name in a.arrays:
        assert np.array_equal(a[name], b[name], equal_nan=True), name


# 85.2 Hz: chaotic, down to one event per call; 58 Hz: stick-release cycles skipped (or not)
@pytest.mark.parametrize(
    ("f", "ff", "t", "chunks"),
    [(85.2, False, 6.0, (1, 100, 1000)), (58.0, True, 20.0, (64, 1000)),
     (58.0, False, 20.0, (64, 1000))],
)  # fmt: skip
def test_chunk_size_and_threads_change_no_number(f, ff, t, chunks):
    kw = {"n": 4, "t": t, "seed": 3, "observables": ALL, "record_particles": 2,
          "jump_capacity": 64, "record_capacity": 500, "fast_forward": ff}  # fmt: skip
    whole = ensemble(Params(f=f), threads=1, chunk_events=10**15, **kw)  # one kernel call
    if ff:
        assert whole["skipped_events"].sum() > 0  # the fast-forward did skip
    for chunk in chunks:
        for threads in THREADS:
            _equal(ensemble(Params(f=f), threads=threads, chunk_events=chunk, **kw), whole)


@pytest.mark.parametrize("chunk", [1, 13])
def test_features_do_not_depend_on_the_chunk_size(monkeypatch, chunk):
    kw = {"t": 3.0, "n": 6, "seed": 4, "blocks": 4}
    whole = trajectory_features(Params(f=85.2), threads=1, **kw)
    monkeypatch.setattr(bbdyn.runs, "CHUNK_EVENTS", chunk)
    for threads in THREADS:
        _equal(trajectory_features(Params(f=85.2), threads=threads, **kw), whole)


def test_progress_grows_to_one():
    seen = []
    ensemble(Params(f=85.2), n=4, t=2.0, seed=1, chunk_events=40, progress=seen.append)
    assert len(seen) > 3
    assert np.all(np.diff(seen) >= 0) and 0 < seen[0] < 1 and seen[-1] == 1.0


def test_keyboard_interrupt_between_chunks_stops_the_run():
    seen = []

    def interrupt(done):
        seen.append(done)
        raise KeyboardInterrupt

    # 1e4 s would take minutes; one chunk of 1000 events covers a few seconds of it
    with pytest.raises(KeyboardInterrupt):
        ensemble(Params(f=85.2), n=4, t=1e4, seed=1, chunk_events=1000, progress=interrupt)
    assert len(seen) == 1 and seen[0] < 1e-3


SCRIPT = """
import signal
import sys
from bbdyn import Params

# Ctrl-C as at a terminal: a process started in the background by a shell (a CI runner's
# job) inherits SIGINT ignored, and Python then keeps it ignored
signal.signal(signal.SIGINT, signal.default_int_handler)
from bbdyn.ensemble import ensemble

def told(done):
    if not told.once:
        print("running", flush=True)
        told.once = True
told.once = False
ensemble(Params(f=85.2), n=4, t=1e6, seed=1, threads=1, progress=told)
print("finished", flush=True)
"""


@pytest.mark.skipif(os.name != "posix", reason="sends SIGINT")
def test_ctrl_c_stops_a_long_run():
    # a real SIGINT while the kernel runs (1e6 s would take hours): KeyboardInterrupt
    # at the next chunk boundary, well within the timeout
    proc = subprocess.Popen(
        [sys.executable, "-c", SCRIPT], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "running"
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode != 0 and "KeyboardInterrupt" in err
