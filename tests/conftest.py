"""Shared fixtures: default parameters at a few frequencies."""

import os

import matplotlib
import pytest
from hypothesis import settings

matplotlib.use("Agg")

# Property tests draw the same examples on every run (CI must not depend on luck);
# HYPOTHESIS_PROFILE=explore draws new random examples, to hunt for failures.
settings.register_profile("default", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))

from bbdyn import Params  # noqa: E402


@pytest.fixture
def params58() -> Params:
    """Defaults of MODEL.md at 58 Hz (inside the 1/1 tongue)."""
    return Params(f=58.0)
