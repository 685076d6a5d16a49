"""The creep of stuck particles towards the wedges just above Gamma = 1, measured for
docs/diffusion.md ("Convergence evidence"), into ``docs/data/creep.json``.

Run from the repository root (about a minute of one core):

    python docs/data/creep_numbers.py

At 51 and 53 Hz it runs the reference ensemble as ``bbdyn simulate --f F --n 100 --t 100
--seed 0 --threads 1`` does (``bbdyn.ensemble.ensemble``, same seed, same particles) and
stores what simulate prints (D, its four windows, jumps and stuck fraction) and, from the
positions ``x(t) = xi_0 + displacement(t)`` at 20, 80 and 100 s, how the particles move
relative to their nearest wedge (the wedges lie at ``x = d/2 + k d``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "creep.json"
FREQUENCIES = (51.0, 53.0)
N, T, SEED = 100, 100.0, 0
#: A particle "moved" when its position changed by more than this (mm), and "sits on a
#: wedge" when it is closer to one than ON_WEDGE (mm).
MOVED, ON_WEDGE = 1e-6, 1e-3


def wedge_distance(x: np.ndarray, d: float) -> np.ndarray:
    """Distance (mm) from x to the nearest wedge, the wedges at x = d/2 + k d."""
    u = np.mod(x + 0.5 * d, d)
    return np.minimum(u, d - u)


def creep(f: float) -> dict:
    from bbdyn import Params
    from bbdyn.core.floor import xi_from_arc_length
    from bbdyn.diffusion import einstein_D_windows
    from bbdyn.ensemble import ensemble

    params = Params(f=f)
    res = ensemble(params, n=N, t=T, seed=SEED, threads=1)
    summary = res.summary()
    _, D_w, se_w = einstein_D_windows(res["sample_times"], res["displacement"][res.ok])
    kp = params.kernel()
    xi0 = np.array([xi_from_arc_length(s, kp) for s in res["initial"][:, 0]])
    times = res["sample_times"]
    x = {t: xi0 + res["displacement"][:, int(np.argmin(np.abs(times - t)))] for t in (20, 80, 100)}
    dist = {t: wedge_distance(v, params.d) for t, v in x.items()}
    moved = np.abs(x[100] - x[20]) > MOVED
    closer = moved & (dist[100] < dist[20] - MOVED)
    gain = (dist[20] - dist[100])[closer]
    late = np.abs(x[100] - x[80])
    return {
        "command": f"bbdyn simulate --f {f:g} --n {N} --t {T:g} --seed {SEED} --threads 1",
        "D": {"value": summary["D"], "se": summary["D_se"]},
        "D_windows": [{"value": float(v), "se": float(s)} for v, s in zip(D_w, se_w, strict=True)],
        "D_windows_se_range": [float(se_w.min()), float(se_w.max())],
        "jumps_per_particle_per_s": summary["jumps_per_particle_per_s"],
        "stuck_fraction": summary["stuck_fraction"],
        "n": N,
        "moved_20_100": int(moved.sum()),
        "closer_20_100": int(closer.sum()),
        "closer_by_max": float(gain.max()) if gain.size else 0.0,
        "closer_by_median": float(np.median(gain)) if gain.size else 0.0,
        "on_wedge_20": int(np.sum(dist[20] < ON_WEDGE)),
        "on_wedge_100": int(np.sum(dist[100] < ON_WEDGE)),
        "moved_80_100": int(np.sum(late > MOVED)),
        "moved_80_100_max": float(late.max()),
    }


def main() -> None:
    from bbdyn import __version__

    data = {
        "command": "python docs/data/creep_numbers.py",
        "bbdyn_version": __version__,
        "moved_mm": MOVED,
        "on_wedge_mm": ON_WEDGE,
    }
    data |= {f"{f:g}": creep(f) for f in FREQUENCIES}
    OUT.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    print(json.dumps(data, indent=1))


if __name__ == "__main__":
    main()
