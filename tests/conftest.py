"""Shared test setup: fixed seeds and headless-rendering environment."""

import os
import random

import numpy as np
import pytest

# Mesa (EGL, llvmpipe) would otherwise write a shader cache under the home folder.
os.environ.setdefault("MESA_SHADER_CACHE_DISABLE", "true")


@pytest.fixture(autouse=True)
def _fixed_seeds():
    """Every test starts from the same global random state."""
    random.seed(0)
    np.random.seed(0)
    yield
