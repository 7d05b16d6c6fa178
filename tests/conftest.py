"""Shared fixtures: the default scenario as data, small scenarios built from dicts."""

import os
import sys
import tomllib
from pathlib import Path
from importlib import resources

# Small matrices are faster on one BLAS thread, and timings are steadier.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))  # the Python oracle of the compiled core: tests/lie_oracle.py


@pytest.fixture
def envisat_dict():
    """The embedded Envisat scenario as a plain dict (mutable copy for error tests)."""
    text = (resources.files("postcapture.config") / "scenarios" / "envisat.toml").read_text()
    return tomllib.loads(text)


@pytest.fixture(scope="session")
def envisat():
    from postcapture.config import load_scenario

    return load_scenario("envisat")
