"""The CUDA engine's cases in numba's CUDA simulator, run as a script by test_cuda_ensemble.py.

``NUMBA_ENABLE_CUDASIM=1`` must be set before numba's CUDA module is first imported, so
the cases run in a process of their own: ``python tests/cuda_sim_cases.py`` (with the
variable set) prints one JSON object, case name -> what the test checks.  Each case runs
the same ensemble on the CPU (``fast_forward="off"``: the device makes every event) and
through the CUDA engine (``device="cuda"``), in the simulator: the kernel's launch, its
point tables and the bookkeeping around it run as on a device, the core functions as the
CPU compiles them.
"""

import json
import math
import os
import sys
import tempfile
import warnings

import numpy as np

from bbdyn import Params
from bbdyn.core.status import ROOT_NOT_CONVERGED, STUCK_FOREVER
from bbdyn.ensemble import ensemble, ensembles
from bbdyn.scans.frequency import diffusion_points, frequency_scan
from bbdyn.scans.runner import point_seed
from bbdyn.schema import standard_key

#: Non-chaotic cases: (name, params, ensemble keywords).  55 Hz: particles trapped in
#: stick-release cycles; 58 Hz: the 1/1 locked orbit; the flat ball: a flat floor (R = 1e9
#: mm) at 85.2 Hz; the static floor: A = 0, every particle chatters to rest in closed form.
#: 85.2 Hz chaotic, for the bookkeeping of the observables (jumps included); 85.2 Hz with
#: random restitution (eta > 0): the counter-based draws keyed on (seed, particle, flight);
#: 85.2 Hz on a floor tilted by 0.5 degrees (parabolic flights along the floor).
SMALL = {"n": 6, "t": 0.5, "seed": 3}
CASES = (
    ("trapped_55", Params(f=55.0), SMALL),
    ("locked_58", Params(f=58.0), SMALL),
    ("flat_ball", Params(f=85.2, R=1e9), SMALL),
    ("chaotic_85", Params(f=85.2), {**SMALL, "observables": ("displacement", "energy", "jumps")}),
    ("noisy_85", Params(f=85.2, eta=0.1), SMALL),
    ("tilted_85", Params(f=85.2, phi=0.5), SMALL),
)
#: The static floor's particles: at the top of the arc of a flat floor, vertical launches.
STATIC = Params(f=58.0, A=0.0, R=1e9)
STATIC_VY = (100.0, 40.0, 7.0)  # mm/s
#: A particle the kernel fails on (tests/test_particle_failures.py).
BAD = [1.0, 0.0, 1e300]


def same(a, b) -> list[str]:
    """Names of the arrays of two results that are not bitwise equal (NaN equal to NaN)."""
    return [k for k in a.arrays if not np.array_equal(a[k], b[k], equal_nan=True)]


def main() -> None:
    assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1", "run with NUMBA_ENABLE_CUDASIM=1"
    report = {}
    for name, params, kw in CASES:
        gpu = ensemble(params, device="cuda", **kw)
        cpu = ensemble(params, fast_forward="off", **kw)
        report[name] = {"differ": same(gpu, cpu), "events": int(gpu["events"].sum()),
                        "meta": {k: gpu.meta[k] for k in ("device", "device_name",
                                                         "fast_forward")}}  # fmt: skip
    # several points in one launch, cut into several launches: each as alone on the CPU
    params = [p for _, p, _ in CASES]
    seeds = [11 + k for k in range(len(params))]
    batch = ensembles(params, seeds, device="cuda", n=4, t=0.3, chunk_events=4000)
    report["batch"] = {
        "differ": [same(b, ensemble(p, seed=s, n=4, t=0.3, fast_forward="off"))
                   for b, p, s in zip(batch, params, seeds, strict=True)],
        "batch": [b.meta["batch"] for b in batch],
    }  # fmt: skip
    # static floor: the chattering sequence ends at 2 vy / (g (1 - alpha)) (closed form)
    ics = [[STATIC.s_max / 2, 0.0, vy] for vy in STATIC_VY]
    static = ensemble(STATIC, initial=ics, t=0.2, device="cuda")
    end = (static["final"][:, 0] + static["final"][:, 1] / (2 * math.pi)) / STATIC.f
    closed = np.array(STATIC_VY) * 2 / (STATIC.g * (1 - STATIC.alpha))
    report["static_floor"] = {
        "status": static["status"].tolist(), "stuck_forever": STUCK_FOREVER,
        "rel_err": (np.abs(end - closed) / closed).tolist(),
        "differ": same(static, ensemble(STATIC, initial=ics, t=0.2, fast_forward="off")),
    }  # fmt: skip
    # a failed particle is reported, the others go on
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mixed = ensemble(Params(f=85.2), initial=[[1.0, 3.0, 20.0], BAD], t=0.5, device="cuda")
    report["failure"] = {
        "status": mixed["status"].tolist(), "expected": ROOT_NOT_CONVERGED,
        "n_failed": mixed.meta["n_failed"], "warned": [str(w.message) for w in caught],
    }  # fmt: skip
    # a scan on the device: one batch, stored and loaded as the CPU's points are
    with tempfile.TemporaryDirectory() as folder:
        freqs = [55.0, 85.2]
        scan = frequency_scan(freqs, out_dir=folder, n=4, t=0.3, device="cuda", progress=False)
        direct = diffusion_points(freqs, [point_seed(0, f) for f in freqs], device="cuda", n=4,
                                  t=0.3)  # fmt: skip
        points = scan.meta["points"]
        report["scan"] = {
            "equal": [bool(np.array_equal(scan[standard_key(k)][i], v, equal_nan=True))
                      for i, out in enumerate(direct) for k, v in out.items()],
            "device": [p["device"] for p in points], "batch": [p["batch_points"] for p in points],
            "cpu_share": sum(p["cpu_s"] for p in points) / points[0]["batch_cpu_s"],
        }  # fmt: skip
    try:
        ensemble(Params(f=85.2), n=2, t=0.1, observables=("record",), device="cuda")
    except ValueError as err:
        report["record_refused"] = str(err)
    json.dump(report, sys.stdout)


if __name__ == "__main__":
    main()
