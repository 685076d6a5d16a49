"""The flat ball's tables of docs/tongues.md and docs/higher_tongues.md, as data.

Runs the commands the pages cite and stores their output with the relative deviations of
the numeric tongue edges from the closed form::

    python docs/data/flat_tables.py      # writes docs/data/flat_tables.json

(``bbdyn tongues --alpha 0.5 --kmax 3 --json`` and ``bbdyn doublings --alpha 0.5 --kmax 3
--levels 10 --json``; a few seconds after the kernels' compilation).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

OUT = Path(__file__).resolve().with_suffix(".json")
TONGUES = ["tongues", "--alpha", "0.5", "--kmax", "3", "--json"]
DOUBLINGS = ["doublings", "--alpha", "0.5", "--kmax", "3", "--levels", "10", "--json"]


def bbdyn_json(args: list[str]) -> list[dict]:
    """The JSON output of ``bbdyn ARGS`` run with this interpreter."""
    out = subprocess.run([sys.executable, "-m", "bbdyn", *args], capture_output=True,
                         text=True, check=True).stdout  # fmt: skip
    return json.loads(out)


def tables(tongues: list[dict], doublings: list[dict]) -> dict:
    """Each tongue row with the relative deviations of its numeric edges, and the cascades."""
    for row in tongues:
        for edge in ("lo", "hi"):
            closed = row[f"gamma_{edge}"]
            row[f"{edge}_rel_dev"] = (row[f"gamma_{edge}_numeric"] - closed) / closed
    return {"commands": ["bbdyn " + " ".join(TONGUES), "bbdyn " + " ".join(DOUBLINGS)],
            "tongues": tongues, "doublings": doublings}  # fmt: skip


def main() -> None:
    OUT.write_text(json.dumps(tables(bbdyn_json(TONGUES), bbdyn_json(DOUBLINGS)), indent=1) + "\n")
    print(f"saved {OUT}")


if __name__ == "__main__":
    main()
