"""Issue 18: values that passed the schema and failed after the whole run. Every one is now refused when the
scenario is loaded, naming its exact path, and a file with several problems lists them all."""

import copy

import pytest

from postcapture.config import scenario_from_dict
from postcapture.core.errors import ScenarioError


@pytest.mark.parametrize(("change", "path"), [
    (lambda d: d["target"]["panels"][0].update(name="tip_\u00e9"), r"target\.panels\[0\]\.name"),  # combining/accented
    (lambda d: d["target"]["panels"][0].update(name="tip\x00"), r"target\.panels\[0\]\.name"),
    (lambda d: d["target"]["panels"][0].update(name="e\u0301"), r"target\.panels\[0\]\.name"),
    (lambda d: d.update(description="a\x00b"), r"description"),
    (lambda d: d["uncertainty"].update(gyro_bias={"sigma": 1e300}), r"uncertainty\.gyro_bias\.sigma"),
    (lambda d: d["uncertainty"].update(gyro_bias={"sigma": 1.0}), r"uncertainty\.gyro_bias: expected draws within"),
    (lambda d: d["uncertainty"].update(target_com={"sigma": 1e6}), r"uncertainty\.target_com: expected draws within"),
    (lambda d: d["uncertainty"].update(target_inertia_axes={"sigma": 10.0}), r"uncertainty\.target_inertia_axes"),
    (lambda d: d["uncertainty"].update(accelerometer_bias={"kind": "uniform", "low": -1e300, "high": 1.0}),
     r"uncertainty\.accelerometer_bias\.low"),
    (lambda d: d["uncertainty"].update(accelerometer_bias={"sigma": 100.0}), r"uncertainty\.accelerometer_bias"),
    (lambda d: d["uncertainty"].update(target_inertia_moments={"sigma": 0.1, "truncate": 1e-300}),
     r"uncertainty\.target_inertia_moments\.truncate"),
    (lambda d: d.setdefault("faults", []).append({"kind": "gyro_bias_step", "time": 10.0, "step": [1e300, 0, 0]}),
     r"faults\[0\]\.step: expected a bias step of at most 0\.01 rad/s"),
    (lambda d: d.setdefault("faults", []).append({"kind": "accelerometer_bias_step", "time": 1.0, "step": [0, 0, 5.0]}),
     r"faults\[0\]\.step: expected a bias step of at most 1 m/s\^2"),
    (lambda d: d["arm"]["joints"][0]["origin"].update(xyz=[1e300, 0, 0]) if "origin" in d["arm"]["joints"][0]
     else d["arm"]["joints"][0].update(origin={"xyz": [1e300, 0, 0]}), r"arm\.joints\[0\]\.origin\.xyz\[0\]"),
    (lambda d: d["excitation"][0].update(amplitude=1e300), r"excitation\[0\]\.amplitude"),
])
def test_an_unphysical_value_is_refused_with_its_path(envisat_dict, change, path):
    data = copy.deepcopy(envisat_dict)
    change(data)
    with pytest.raises(ScenarioError, match=path):
        scenario_from_dict(data)


def test_typos_get_a_did_you_mean(envisat_dict):
    data = copy.deepcopy(envisat_dict)
    data["target"]["mas"] = data["target"].pop("mass")
    data["target"]["panels"][0]["dampingbeta"] = data["target"]["panels"][0].pop("damping_beta")
    data["excitation"][3]["kind"] = "chrip"
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(data)
    text = str(info.value)
    assert "target.mas: expected a known key" in text and "(did you mean 'mass'?)" in text
    assert "target.panels[0].dampingbeta" in text and "(did you mean 'damping_beta'?)" in text
    assert "excitation[3]: expected kind one of step, sine, chirp, table, found 'chrip' (did you mean 'chirp'?)" in text
    assert "amplitude" not in text.split("excitation[3]")[1].splitlines()[0]  # the tag, not the whole table


def test_every_cross_check_problem_in_one_pass(envisat_dict):
    data = copy.deepcopy(envisat_dict)
    data["faults"] = [{"kind": "joint_stuck", "joint": 9, "start": 1.0},
                      {"kind": "gyro_outage", "start": 290.0, "stop": 400.0}]
    data["excitation"][0]["channel"] = "joint_9"
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(data)
    paths = [p.path for p in info.value.problems]
    assert paths == ["faults[0].joint", "faults[1].stop", "excitation[0].channel"], paths
