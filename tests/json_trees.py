"""Comparison of JSON trees for the tests that regenerate a committed data file."""

from __future__ import annotations

import math


def json_close(a, b) -> bool:
    """Equal JSON trees (dicts with the same keys, lists of the same length), floats to
    1e-12 relative: the same arithmetic on another machine, or a JSON round trip."""
    if isinstance(a, dict):
        return (
            isinstance(b, dict) and a.keys() == b.keys() and all(json_close(a[k], b[k]) for k in a)
        )
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(map(json_close, a, b))
    if isinstance(a, float) and isinstance(b, float):
        return a == b or math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-300)
    return a == b
