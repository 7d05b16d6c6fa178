"""Faults belong to the truth's sensors: a truth scenario file carries its own, never silently ignored."""

import pytest

from postcapture.config import scenario_from_dict
from postcapture.core.errors import ScenarioError
from postcapture.dynamics.truth import truth_from_scenario
from postcapture.studies.setup import plan_run

FAULT = {"kind": "gyro_bias_step", "time": 5.0, "step": [1e-5, 0.0, 0.0]}


def test_a_truth_scenarios_faults_are_the_runs(envisat, envisat_dict):
    envisat_dict["faults"] = [FAULT]
    truth = truth_from_scenario(envisat, scenario_from_dict(envisat_dict), source="t.toml")
    plan = plan_run(envisat, truth=truth, duration=10.0, cases=("joint",))
    assert [f.kind for f in plan.faults] == ["gyro_bias_step"] and not envisat.faults


def test_nominal_faults_beside_a_truth_scenario_without_them_are_refused(envisat, envisat_dict):
    truth = truth_from_scenario(envisat, scenario_from_dict(envisat_dict), source="t.toml")
    envisat_dict["faults"] = [FAULT]
    with pytest.raises(ScenarioError, match="faults: expected faults declared in the truth scenario"):
        plan_run(scenario_from_dict(envisat_dict), truth=truth, duration=10.0, cases=("joint",))


def test_a_truth_scenarios_fault_outside_the_run_is_refused(envisat, envisat_dict):
    envisat_dict["faults"] = [{**FAULT, "time": 50.0}]
    truth = truth_from_scenario(envisat, scenario_from_dict(envisat_dict), source="t.toml")
    with pytest.raises(ScenarioError, match="truth scenario: faults"):
        plan_run(envisat, truth=truth, duration=10.0, cases=("joint",))
