"""Scenario loading and validation: every bad input gives a typed error listing every problem."""

import math

import numpy as np
import pytest

from postcapture.config import load_scenario, scenario_from_dict
from postcapture.core.errors import ScenarioError


def problems(excinfo):
    return [str(p) for p in excinfo.value.problems]


def test_envisat_loads_with_reference_stiffnesses(envisat):
    # Tables 2 and 3 of the reference thesis.
    wings = {p.name: p for _, p in envisat.panels()}
    assert wings["envisat_wing"].bending_stiffness == (8051.0, 47568.0, 15648.0, 6884.0, 8565.0)
    assert wings["envisat_wing"].torsion_stiffness == 621.6
    assert wings["chaser_wing"].bending_stiffness == (53.6, 99.7, 63.1, 36.4, 15.2)
    assert wings["chaser_wing"].torsion_stiffness == 9.93
    assert envisat.target.mass == 7827.9
    assert envisat.n_arm == 7
    # tumble between the 2013 and 2017 measurements (1.59 - 2.67 deg/s)
    rate = math.degrees(np.linalg.norm(envisat.initial.omega_BN_B))
    assert 1.59 <= rate <= 2.67


def test_scenario_is_immutable(envisat):
    with pytest.raises(Exception):
        envisat.chaser.mass = 1.0


def test_scenario_error_is_a_value_error():
    assert issubclass(ScenarioError, ValueError)


@pytest.mark.parametrize("mass", [-5.0, 0.0])
def test_non_positive_mass(envisat_dict, mass):
    envisat_dict["chaser"]["mass"] = mass
    with pytest.raises(ScenarioError, match=r"chaser\.mass: expected a number > 0"):
        scenario_from_dict(envisat_dict)


def test_inertia_not_symmetric(envisat_dict):
    envisat_dict["target"]["inertia"][0][1] = 999.0
    with pytest.raises(ScenarioError, match=r"target\.inertia: expected a symmetric 3x3 inertia tensor"):
        scenario_from_dict(envisat_dict)


def test_inertia_not_positive_definite(envisat_dict):
    envisat_dict["chaser"]["inertia"] = [[1500.0, 0, 0], [0, -1.0, 0], [0, 0, 1200.0]]
    with pytest.raises(ScenarioError, match=r"chaser\.inertia: expected a positive definite inertia tensor"):
        scenario_from_dict(envisat_dict)


def test_inertia_violates_triangle_inequality(envisat_dict):
    envisat_dict["arm"]["joints"][2]["inertia"] = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 5.0]]
    with pytest.raises(ScenarioError, match=r"arm\.joints\[2\]\.inertia: expected principal moments satisfying the triangle"):
        scenario_from_dict(envisat_dict)


def test_wrong_number_of_stiffnesses(envisat_dict):
    envisat_dict["target"]["panels"][0]["bending_stiffness"] = [1.0, 2.0]
    with pytest.raises(ScenarioError, match=r"target\.panels\[0\]: expected 5 bending stiffnesses .* found 2"):
        scenario_from_dict(envisat_dict)


def test_unknown_key(envisat_dict):
    envisat_dict["chaser"]["colour"] = "blue"
    with pytest.raises(ScenarioError, match=r"chaser\.colour: expected a known key"):
        scenario_from_dict(envisat_dict)


@pytest.mark.parametrize("value", [math.nan, math.inf])
def test_non_finite_number(envisat_dict, value):
    envisat_dict["arm"]["joints"][0]["stiffness"] = value
    with pytest.raises(ScenarioError, match=r"arm\.joints\[0\]\.stiffness: expected a finite number"):
        scenario_from_dict(envisat_dict)


def test_every_problem_is_listed(envisat_dict):
    envisat_dict["chaser"]["mass"] = -1.0
    envisat_dict["target"]["inertia"][0][1] = 999.0
    envisat_dict["extra"] = 1
    envisat_dict["simulation"]["step"] = math.nan
    with pytest.raises(ScenarioError) as excinfo:
        scenario_from_dict(envisat_dict, "broken.toml")
    found = problems(excinfo)
    assert len(found) == 4, found
    assert "4 problems" in str(excinfo.value) and "broken.toml" in str(excinfo.value)


def test_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="no such file"):
        load_scenario(tmp_path / "nothing.toml")


def test_unknown_scenario_name():
    with pytest.raises(ScenarioError, match=r"expected a built-in name \(envisat.*unknown scenario name 'mars'"):
        load_scenario("mars")


def test_invalid_toml(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("name = \n")
    with pytest.raises(ScenarioError, match="expected valid TOML"):
        load_scenario(path)


def test_load_by_path_round_trip(tmp_path, envisat):
    import tomli_w

    path = tmp_path / "copy.toml"
    path.write_bytes(tomli_w.dumps(envisat.model_dump(exclude_none=True)).encode())
    again = load_scenario(path)
    assert again == envisat


def test_excitation_on_missing_joint(envisat_dict):
    envisat_dict["excitation"][0]["channel"] = "joint_9"
    with pytest.raises(ScenarioError, match=r"channel on an existing input .*arm has 7 joints.*joint_9"):
        scenario_from_dict(envisat_dict)


def test_sample_period_multiple_of_step(envisat_dict):
    envisat_dict["simulation"]["sample_period"] = 0.07
    envisat_dict["simulation"]["step"] = 0.05  # an explicit truth step must divide the sample period
    with pytest.raises(ScenarioError, match=r"simulation: expected sample_period a whole multiple of step"):
        scenario_from_dict(envisat_dict)


def test_target_needs_arm(envisat_dict):
    del envisat_dict["arm"]
    del envisat_dict["excitation"]
    with pytest.raises(ScenarioError, match="expected an arm to hold the target"):
        scenario_from_dict(envisat_dict)
