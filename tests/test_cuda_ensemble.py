"""The CUDA ensemble engine (bbdyn.gpu, core/cuda_ensemble.py): simulator, PTX, no device.

The engine runs in numba's CUDA simulator (``NUMBA_ENABLE_CUDASIM=1``, in a process of its
own: ``tests/cuda_sim_cases.py``): the kernel's launch, point tables, chunks and the
bookkeeping run as on a device, the core functions as the CPU compiles them, so every case
must agree bitwise with the CPU run without fast-forward, in one launch or many, one point
or several.  The device's own arithmetic (FMA contraction) is checked on a GPU by
``benchmarks/gpu_check.py``.  ``test_kernel_compiles_to_ptx`` compiles the kernel for
compute capability 9.0.  Both need numba-cuda (``pip install bbdyn[gpu]``) and skip
with their reason without it; the no-device message is checked where no GPU is present.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bbdyn import Params
from bbdyn.commands import cli
from bbdyn.core import targets
from bbdyn.gpu import NO_DEVICE, CudaJob, launch_arguments, state_bytes

HERE = Path(__file__).parent
MISSING = targets.cuda_missing()


def _numba_cuda_missing():
    try:
        import numba_cuda  # noqa: F401
    except ImportError:
        return "numba-cuda is not installed (pip install bbdyn[gpu])"
    return None


@pytest.fixture(scope="module")
def sim():
    """The cases of tests/cuda_sim_cases.py, run once in the simulator."""
    missing = _numba_cuda_missing()
    if missing:
        pytest.skip(missing)
    env = dict(os.environ, NUMBA_ENABLE_CUDASIM="1", PYTHONPATH=str(HERE.parent))
    run = subprocess.run([sys.executable, str(HERE / "cuda_sim_cases.py")], env=env,
                         capture_output=True, text=True, timeout=600)  # fmt: skip
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


@pytest.mark.parametrize("case", ["trapped_55", "locked_58", "flat_ball", "chaotic_85", "noisy_85",
                                  "tilted_85"])
def test_simulated_device_is_the_cpu_bit_for_bit(sim, case):
    out = sim[case]
    assert out["differ"] == [], f"{case}: arrays differ from the CPU's: {out['differ']}"
    assert out["events"] > 0
    assert out["meta"] == {"device": "cuda", "device_name": "CUDA simulator",
                           "fast_forward": "off"}  # fmt: skip


def test_points_of_one_launch_keep_their_own_parameters_and_times(sim):
    """Four frequencies in one launch, cut into several launches, each as alone on the CPU."""
    assert sim["batch"]["differ"] == [[]] * 6
    assert sim["batch"]["batch"] == [6] * 6


def test_static_floor_chatters_to_rest_at_the_closed_form_time(sim):
    """A = 0: a ball launched at vy from a flat floor stops at 2 vy / (g (1 - alpha))."""
    out = sim["static_floor"]
    assert out["status"] == [out["stuck_forever"]] * 3
    assert max(out["rel_err"]) < 1e-14
    assert out["differ"] == []


def test_failed_particle_is_reported_not_fatal(sim):
    out = sim["failure"]
    assert out["status"] == [0, out["expected"]]
    assert out["n_failed"] == 1
    assert any("1 of 2 particle(s) failed" in w for w in out["warned"])


def test_scan_on_the_device_stores_its_batch(sim):
    """frequency_scan(device="cuda"): the points of diffusion_points, each recording its
    device and batch; their time shares add up to the batch's."""
    out = sim["scan"]
    assert out["equal"] and all(out["equal"])
    assert out["device"] == ["cuda", "cuda"] and out["batch"] == [2, 2]
    assert out["cpu_share"] == pytest.approx(1.0)
    assert "CPU only" in sim["record_refused"]


def _tiny_job(f=58.0, n=3, m=5):
    from bbdyn.core.layout import CARRY_WIDTH, CNT_WIDTH, EnsembleOut, Observables, RunTimes

    out = EnsembleOut(np.zeros((n, m)), np.zeros((n, 2, 4)), np.zeros((n, CNT_WIDTH), np.int64),
                      np.zeros((n, 0), np.int64), np.zeros((n, 0)), np.zeros((0, 0, 7)),
                      np.zeros((n, 7)), np.zeros(n, np.int64))  # fmt: skip
    times = RunTimes(10.0, 0.0, 2.0, 8.0, 1, np.zeros(m), np.zeros(m))
    obs = Observables(3, np.zeros(2), np.zeros(2), 6.0)
    return CudaJob(Params(f=f).kernel(), times, obs, np.zeros((n, CARRY_WIDTH)), out)


@pytest.mark.slow  # 15-20 s: numba-cuda compiles the whole particle loop
def test_kernel_compiles_to_ptx():
    """The ensemble kernel compiles for sm_90; prints its PTX instruction count."""
    if MISSING:
        pytest.skip(MISSING)
    from numba.core.typing import typeof

    from bbdyn.gpu import _kernel

    table, flags, carry, out = launch_arguments([_tiny_job(58.0), _tiny_job(85.2)])
    argtypes = tuple(typeof.typeof(a) for a in (table, flags, carry, np.int64(1), out))
    ptx = targets.cuda_ptx(_kernel(), argtypes, cc=(9, 0), device=False)
    assert ".target sm_90" in ptx and ".entry" in ptx
    n = targets.ptx_instructions(ptx)
    assert n > 1000
    print(f"ensemble kernel: {n} PTX instructions (sm_90, {ptx.count('.func ')} functions)")


def test_launch_arguments_stack_the_points():
    """Each particle points at its own point's row of parameters and times."""
    jobs = [_tiny_job(58.0, n=2), _tiny_job(85.2, n=3)]
    table, flags, carry, out = launch_arguments(jobs)
    assert table.point.tolist() == [0, 0, 1, 1, 1]
    assert np.array_equal(table.params[1], np.array(Params(f=85.2).kernel(), dtype=float))
    assert out.status.tolist() == [-1] * 5 and carry.state.shape == (5, carry.state.shape[1])
    assert flags == 3
    # the estimate counts every array the device holds per particle
    per = sum(a[0].nbytes for a in (carry.state, out.displacement, out.blocks, out.counts,
                                     out.final, out.status, table.point))  # fmt: skip
    assert state_bytes(1, 5) == per


def test_no_device_is_one_line_and_writes_nothing(tmp_path, capsys):
    """Without a GPU: NO_DEVICE on one line, exit status 1, no file."""
    try:
        from numba import cuda
    except ImportError:
        cuda = None
    if cuda is not None and cuda.is_available():
        pytest.skip("a CUDA device is available here")
    for argv in (["simulate", "--f", "85.2", "--n", "4", "--t", "1", "--save",
                  str(tmp_path / "run")],
                 ["scan", "--f-start", "85", "--f-stop", "85.2", "--n", "4", "--t", "1",
                  "--out", str(tmp_path / "scan")],
                 ["scene", "S3", "--out", str(tmp_path)],
                 ["reproduce", "--out", str(tmp_path), "--only", "S3"]):  # fmt: skip
        with pytest.raises(SystemExit) as exit_info:
            cli.main([*argv, "--device", "cuda"])
        assert exit_info.value.code == 1, argv
        captured = capsys.readouterr()
        assert captured.err == NO_DEVICE + "\n", argv
        assert captured.out == ""
        assert list(tmp_path.iterdir()) == [], argv
