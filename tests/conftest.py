"""Shared fixtures: default parameters at a few frequencies."""

import matplotlib
import pytest

matplotlib.use("Agg")

from bbdyn import Params  # noqa: E402


@pytest.fixture
def params58() -> Params:
    """Defaults of MODEL.md at 58 Hz (inside the 1/1 tongue)."""
    return Params(f=58.0)
