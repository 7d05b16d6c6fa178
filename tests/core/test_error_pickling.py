"""Errors keep their type, message and attributes across processes (pickling)."""

import errno
import pickle

import pytest

from postcapture.core.errors import (
    FilterDivergenceError,
    FMIError,
    InputError,
    MissingExtraError,
    OutputPathError,
    PanelModelError,
    Problem,
    ResourceLimitError,
    ScenarioError,
    WorkerError,
)

ERRORS = [
    ScenarioError([Problem("chaser.mass", "a number > 0", "-1"), Problem("x", "y", "z")], "s.toml"),
    PanelModelError([Problem("laminate.plies", "one ply or more", "none")], "p.toml"),
    InputError([Problem("--out", "a folder", "a file")], "postcapture run"),
    FilterDivergenceError("ekf", 3.5, "NaN"),
    FMIError("failed", "a.fmu", "fmi2DoStep", "Error"),
    MissingExtraError("pyNastran", "panels"),
    ResourceLimitError("too big", "memory", 1e15, 1e9),
    OutputPathError(errno.ENOSPC, "write failed: No space left on device", "/r/results.nc"),
    WorkerError("_run_case(ekf)", "KeyError", "'x'", "Traceback ..."),
]


@pytest.mark.parametrize("exc", ERRORS, ids=lambda e: type(e).__name__)
def test_round_trip(exc):
    again = pickle.loads(pickle.dumps(exc))
    assert type(again) is type(exc) and str(again) == str(exc)
    assert {k: v for k, v in vars(again).items()} == {k: v for k, v in vars(exc).items()}


def test_scenario_error_keeps_its_problems_not_characters():
    again = pickle.loads(pickle.dumps(ERRORS[0]))
    assert again.problems == ERRORS[0].problems and again.source == "s.toml"
    assert str(again).startswith("invalid scenario 's.toml': 2 problems")


def test_output_path_error_is_an_os_error_with_its_parts():
    again = pickle.loads(pickle.dumps(ERRORS[7]))
    assert isinstance(again, OSError) and again.errno == errno.ENOSPC and again.filename == "/r/results.nc"
    assert str(again) == "/r/results.nc: write failed: No space left on device"
