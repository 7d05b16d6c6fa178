"""Fixtures for the panel tests: the uniform strip and the Envisat wing solved once per session."""

import pytest
from panel_cases import Strip

from postcapture.panels import builtin_panel, solve_modes


@pytest.fixture(scope="session")
def strip():
    return Strip(nu=0.0)


@pytest.fixture(scope="session")
def envisat_modes():
    """The Envisat wing on the reference's 20 x 60 mesh (solved once per session)."""
    geometry, laminate = builtin_panel("envisat")
    return solve_modes(geometry, laminate, n_length=60, n_width=20, n_modes=10)
