"""Bit-for-bit check of the kernels' outputs against a saved baseline.

Runs a fixed set of small simulations through the public API -- ensembles (n = 32,
t = 10 s, seed 0, every observable, fast-forward on and off) at 50.2, 58, 70.2, 85.2 and
90 Hz, flat-ball trajectories and an ensemble, billiard trajectories -- and either saves
every output array (``save DIR``) or compares them with a saved set (``compare DIR``):
arrays must be equal bit for bit (NaN payloads and signed zeros included).  The kernels
are compiled into a fresh numba cache (numba's cache of a function does not notice a
change in a function of another module it inlines), unless ``--reuse-cache``.

Usage::

    PYTHONPATH=TREE python benchmarks/bitwise_check.py save /tmp/baseline
    PYTHONPATH=TREE python benchmarks/bitwise_check.py compare /tmp/baseline
"""

import argparse
import os
import sys
import tempfile

import numpy as np

FREQUENCIES = (50.2, 58.0, 70.2, 85.2, 90.0)


def runs():
    """Yield (name, dict of arrays) for every run of the check."""
    from bbdyn import Params
    from bbdyn.billiard import simulate
    from bbdyn.ensemble import ensemble
    from bbdyn.flat.flatball import flat_ensemble, simulate_flat

    obs = ("displacement", "energy", "jumps", "record")
    for f in FREQUENCIES:
        for ff in ("converged", "off"):
            res = ensemble(
                Params(f=f),
                n=32,
                t=10.0,
                seed=0,
                threads=1,
                observables=obs,
                record_particles=2,
                fast_forward=ff,
            )
            yield f"ensemble_{f}_{ff}", {k: res[k] for k in res.arrays}
        traj = simulate(Params(f=f), n_events=20000, s0=1.0, vx0=3.0, vy0=20.0)
        yield f"billiard_{f}", {k: traj[k] for k in traj.arrays}
        flat = simulate_flat(Params(f=f), n_events=20000, vrel0=100.0)
        yield f"flat_{f}", {k: flat[k] for k in flat.arrays}
        fens = flat_ensemble(Params(f=f), 8, n_events=2000, seed=0)
        yield f"flat_ensemble_{f}", {k: fens[k] for k in fens.arrays}


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal shape, dtype and bytes."""
    a, b = np.ascontiguousarray(a), np.ascontiguousarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("save", "compare"))
    parser.add_argument("directory")
    parser.add_argument("--reuse-cache", action="store_true", help="keep numba's cache")
    args = parser.parse_args()
    if not args.reuse_cache:
        os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="bitwise_check_")
    os.makedirs(args.directory, exist_ok=True)
    bad = 0
    for name, arrays in runs():
        path = os.path.join(args.directory, name + ".npz")
        arrays = {k: np.asarray(v) for k, v in arrays.items() if np.asarray(v).dtype != object}
        if args.mode == "save":
            np.savez(path, **arrays)
            continue
        with np.load(path) as ref:
            diff = [k for k in ref.files if k not in arrays or not same_bits(ref[k], arrays[k])]
            diff += [k for k in arrays if k not in ref.files]
        print(f"{name}: {'identical' if not diff else 'DIFFERS in ' + ', '.join(diff)}")
        bad += bool(diff)
    if args.mode == "compare":
        print("bitwise check:", "PASS" if not bad else f"FAIL ({bad} runs differ)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
