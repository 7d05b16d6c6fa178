"""Shared FMUs for the FMI tests: exported once per session into a temporary folder.

``envisat_fmu`` is the default scenario (flexible, directional derivatives and Jacobian outputs), and
``envisat_fmu3`` the same as FMI 3.0; each takes a few seconds to build, once. ``rigid_plain_fmu`` is the rigid variant without
directional derivatives or Jacobian outputs (a few seconds), for the finite-difference fallback.
"""

import fmpy  # noqa: F401 - the fmi extra is part of the test install: fail loudly if it is missing
import pytest


@pytest.fixture(scope="session")
def envisat_fmu(tmp_path_factory, envisat):
    """ExportReport of the default scenario's FMU (flexible)."""
    from postcapture.fmi import export_fmu

    out = tmp_path_factory.mktemp("fmu") / "envisat.fmu"
    return export_fmu(envisat, out)


@pytest.fixture(scope="session")
def envisat_fmu3(tmp_path_factory, envisat):
    """ExportReport of the default scenario's FMU as FMI 3.0 co-simulation (flexible)."""
    from postcapture.fmi import export_fmu

    out = tmp_path_factory.mktemp("fmu3") / "envisat3.fmu"
    return export_fmu(envisat, out, fmi_version=3)


@pytest.fixture(scope="session")
def rigid_plain_fmu(tmp_path_factory, envisat):
    """ExportReport of the rigid variant without directional derivatives nor Jacobian outputs."""
    from postcapture.fmi import export_fmu

    out = tmp_path_factory.mktemp("fmu_plain") / "envisat_rigid.fmu"
    return export_fmu(envisat, out, variant="rigid", directional_derivatives=False, step_jacobian=False)


@pytest.fixture(scope="session")
def tiny_dir(tmp_path_factory):
    """A folder for the small hand-written test FMUs."""
    return tmp_path_factory.mktemp("tiny")
