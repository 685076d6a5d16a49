"""The numbers of the worked examples on the pages, computed by the pages' own code.

Each example's Python block is read from its page and run as it stands, so that the code a
reader copies and the numbers the page shows cannot part::

    python docs/data/page_examples.py      # writes the two JSON files below

* ``green_kubo_example.json``: docs/green_kubo.md, "Worked example" (a persistent walk):
  ``D_n`` with its bootstrap error beside the exact ``D_0 (1 + 2 (q + ... + q^n))``,
  ``D_inf``, the Einstein D of the same walks, the first symbol probabilities with their
  Markov values, and the symbol combinations that give q and q² (seconds);
* ``threshold_counts.json``: docs/billiard.md, "What the collision rate counts": bbdyn's
  collisions per particle-second against those of a run that sticks at the first impact
  slower than 1e-3 mm/s, per frequency (half a minute).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

DATA = Path(__file__).resolve().parent
DOCS = DATA.parent
#: rows of the D_n table and words of the symbol table docs/green_kubo.md shows
ROWS = (0, 1, 2, 3, 5, 10)
WORDS = ("f", "b", "ff", "fb", "bf", "bb")


def code_block(page: str, heading: str) -> str:
    """The first Python block of ``docs/PAGE`` after the line ``HEADING``."""
    section = (DOCS / page).read_text().split(heading + "\n", 1)[1]
    return re.search(r"```python\n(.*?)```", section, flags=re.S).group(1)


def _run(page: str, code: str) -> dict:
    """Run ``code`` (from ``page``); its namespace, with what it printed under ``printed``."""
    printed: list[tuple] = []
    scope = {"print": lambda *args: printed.append(args)}
    exec(compile(code, str(DOCS / page), "exec"), scope)  # noqa: S102
    scope["printed"] = printed
    return scope


def green_kubo_example() -> dict:
    """docs/green_kubo.md's worked example, run without its last line (tables and plot)."""
    code = code_block("green_kubo.md", "## Worked example: a persistent walk")
    scope = _run("green_kubo.md", "\n".join(code.rstrip().splitlines()[:-1]) + "\n")
    res, p = scope["res"], scope["p"]
    q, d0 = 2 * p - 1, float(res.D_n[0])
    exact = [d0 * (1 + 2 * sum(q**k for k in range(1, n + 1))) for n in range(res.D_n.size)]
    markov = {"f": p, "b": 1 - p, "ff": p * p, "fb": p * (1 - p), "bf": (1 - p) ** 2,
              "bb": (1 - p) * p}  # fmt: skip
    words = {w: dict(zip(("value", "se"), res.p(w), strict=True)) for w in WORDS}
    pw = {w: v["value"] for w, v in words.items()}
    return {
        "command": "python docs/data/page_examples.py",
        "p": p, "q": q, "q2": q * q, "d": scope["d"], "tau": res.tau, "D_0": d0,
        "D_inf": d0 * (1 + q) / (1 - q),
        "rows": [{"n": n, "D_n": {"value": float(res.D_n[n]), "se": float(res.D_n_err[n])},
                  "exact": exact[n]} for n in ROWS],
        "D_einstein": {"value": float(scope["D_E"]), "se": float(scope["D_E_err"])},
        "words": [{"word": w, "p": words[w], "markov": markov[w]} for w in WORDS],
        "q_from_symbols": pw["f"] - pw["b"],
        "q2_from_symbols": pw["ff"] - pw["fb"] + pw["bf"] - pw["bb"],
    }  # fmt: skip


def threshold_counts() -> dict:
    """docs/billiard.md's collision counts with and without a sticking threshold: one row
    per line the page's code prints (f, bbdyn's rate, the threshold run's, the fraction)."""
    code = code_block("billiard.md", "### What the collision rate counts")
    scope = _run("billiard.md", code)
    rows = [{"f": float(f), "bbdyn": float(a), "threshold": float(b), "lower_by": float(c)}
            for f, a, b, c in scope["printed"]]  # fmt: skip
    return {"command": "python docs/data/page_examples.py", "threshold_mm_s": scope["eps"],
            "n": scope["n"], "t": scope["t"], "rows": rows}  # fmt: skip


def main() -> None:
    for name, compute in (("green_kubo_example", green_kubo_example),
                          ("threshold_counts", threshold_counts)):  # fmt: skip
        path = DATA / f"{name}.json"
        path.write_text(json.dumps(compute(), indent=1) + "\n")
        print(f"saved {path}")


if __name__ == "__main__":
    main()
