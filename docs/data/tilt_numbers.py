"""The numbers of docs/tilt.md that are not in the figure's own JSON, into docs/data/tilt.json.

Run from the repository root (nice it: about half a minute of CPU):

    python docs/data/tilt_numbers.py

* ``forecast``: CPU seconds of each setting of scene B7 (quick, medium, full), from the
  cost per particle and simulated second measured over every point of the committed figure
  ``docs/figures/B7_medium`` (``bbdyn.scenes.b7_tilt.work``).
* ``search_cost``: the cost of the tilted event search, which does without the Taylor
  shortcuts of the untilted one: CPU seconds and events of the same ensemble (n = 200,
  t = 10 s, seed 0, one thread, fast-forward off) untilted and at phi = 1e-9 degrees (the
  tilted code, the same motion to within 1e-9), after a run that compiles both, and their
  ratios per event.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1]
OUT = DOCS / "data" / "tilt.json"
FIGURE = DOCS / "figures" / "B7_medium.json"
#: Frequencies (Hz) and ensemble of the search-cost measurement.
COST_F = (58.0, 85.2)
COST_RUN = {"n": 200, "t": 10.0, "seed": 0, "threads": 1, "fast_forward": "off"}
#: The tilt (degrees) that takes the tilted code with the untilted motion.
TINY_PHI = 1e-9


def forecasts() -> dict:
    """CPU seconds of each setting at the rate measured in the committed figure."""
    from bbdyn.scenes import b7_tilt

    rate = json.loads(FIGURE.read_text())["meta"]["key_numbers"]["cpu_s_per_particle_second"]
    out = {"rate_s": rate}
    for name in ("QUICK", "MEDIUM", "FULL"):
        out[name.lower()] = b7_tilt.work(getattr(b7_tilt, name), rate)
    return out


def search_cost() -> dict:
    """CPU seconds and events per frequency, untilted and at ``TINY_PHI``."""
    from bbdyn import Params
    from bbdyn.ensemble import ensemble

    for phi in (0.0, TINY_PHI):  # compile both paths first
        ensemble(Params(f=COST_F[0], phi=phi), **{**COST_RUN, "n": 2, "t": 0.5})
    out = {}
    for f in COST_F:
        row = {}
        for name, phi in (("untilted", 0.0), ("tilted", TINY_PHI)):
            cpu = time.process_time()
            res = ensemble(Params(f=f, phi=phi), **COST_RUN)
            row[name] = {"cpu_s": time.process_time() - cpu, "events": int(res["events"].sum())}
        per_event = [row[k]["cpu_s"] / row[k]["events"] for k in ("untilted", "tilted")]
        row["ratio_per_event"] = per_event[1] / per_event[0]
        out[f"{f:g}"] = row
    return out


def main() -> None:
    data = {"forecast": forecasts(), "search_cost": search_cost(), "run": COST_RUN,
            "tiny_phi": TINY_PHI}  # fmt: skip
    OUT.write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
