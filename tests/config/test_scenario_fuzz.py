"""Property: whatever a scenario file holds, `load_scenario` raises nothing but ScenarioError.

The default scenario is mutated (keys deleted, values replaced by other types, extreme and non-finite
numbers, deep nesting, long arrays and strings, other text encodings, corrupted bytes) and written to a
file; loading it must either give a Scenario or raise ScenarioError with at least one problem.
"""

import os
import tempfile

import pytest
from hypothesis import HealthCheck, given, settings
from scenario_mutations import mutated

from postcapture.config import Scenario, load_scenario
from postcapture.core.errors import ScenarioError


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mutated())
def test_only_scenario_errors_escape_load_scenario(raw):
    fd, path = tempfile.mkstemp(suffix=".toml")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
        try:
            scenario = load_scenario(path)
        except ScenarioError as exc:
            assert exc.problems, "a ScenarioError lists at least one problem"
            assert all(p.path and p.expected for p in exc.problems)
        else:
            assert isinstance(scenario, Scenario)
    finally:
        os.unlink(path)


def test_extreme_nesting_and_size_are_refused(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text("name = " + "[" * 100_000 + "]" * 100_000 + "\n")
    with pytest.raises(ScenarioError, match="nesting too deep"):
        load_scenario(path)
    big = tmp_path / "big.toml"
    with open(big, "wb") as fh:
        fh.truncate(17 * 2**20)
    with pytest.raises(ScenarioError, match="under 16 MiB"):
        load_scenario(big)
