"""The numbers of docs/green_kubo.md's worked example (a persistent walk), as data.

Runs the example's code block of the page as it stands (so the page's code and its
numbers cannot part) and stores, beside the exact values of the walk::

    python docs/data/green_kubo_example.py     # writes docs/data/green_kubo_example.json

``D_n`` with its bootstrap error and the exact ``D_0 (1 + 2 (q + ... + q^n))`` at the rows
the page shows, ``D_inf``, the Einstein D of the same walks, the first symbol
probabilities with their Markov values, and the two symbol combinations that give q and q².
"""

from __future__ import annotations

import json
import re
from pathlib import Path

PAGE = Path(__file__).resolve().parents[1] / "green_kubo.md"
OUT = Path(__file__).resolve().with_suffix(".json")
#: rows of the D_n table the page shows
ROWS = (0, 1, 2, 3, 5, 10)
WORDS = ("f", "b", "ff", "fb", "bf", "bb")


def example_code() -> str:
    """The Python block of the page's section "Worked example", without its last line
    (printing and plotting)."""
    section = PAGE.read_text().split("## Worked example")[1]
    code = re.search(r"```python\n(.*?)```", section, flags=re.S).group(1)
    return "\n".join(code.rstrip().splitlines()[:-1]) + "\n"


def run() -> dict:
    """Execute the example and collect what the page states."""
    scope: dict = {}
    exec(compile(example_code(), str(PAGE), "exec"), scope)  # noqa: S102
    res, p, d = scope["res"], scope["p"], scope["d"]
    q = 2 * p - 1
    d0 = res.D_n[0]
    exact = [float(d0 * (1 + 2 * sum(q**k for k in range(1, n + 1)))) for n in range(res.D_n.size)]
    markov = {"f": p, "b": 1 - p, "ff": p * p, "fb": p * (1 - p), "bf": (1 - p) ** 2,
              "bb": (1 - p) * p}  # fmt: skip
    words = {w: dict(zip(("value", "se"), res.p(w), strict=True)) for w in WORDS}
    pw = {w: v["value"] for w, v in words.items()}
    return {
        "command": "python docs/data/green_kubo_example.py",
        "p": p, "q": q, "q2": q * q, "d": d, "tau": res.tau, "D_0": float(d0),
        "D_inf": float(d0 * (1 + q) / (1 - q)),
        "rows": [{"n": n, "D_n": {"value": float(res.D_n[n]), "se": float(res.D_n_err[n])},
                  "exact": exact[n]} for n in ROWS],
        "D_einstein": {"value": float(scope["D_E"]), "se": float(scope["D_E_err"])},
        "words": [{"word": w, "p": words[w], "markov": markov[w]} for w in WORDS],
        "q_from_symbols": pw["f"] - pw["b"],
        "q2_from_symbols": pw["ff"] - pw["fb"] + pw["bf"] - pw["bb"],
    }  # fmt: skip


def main() -> None:
    OUT.write_text(json.dumps(run(), indent=1) + "\n")
    print(f"saved {OUT}")


if __name__ == "__main__":
    main()
