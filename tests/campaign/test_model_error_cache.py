"""The derived model error is kept per scenario and code; a damaged or foreign file is derived again."""

import numpy as np

from postcapture.studies import robust
from postcapture.studies.setup import plan_run


def test_a_cached_model_error_is_reused_and_a_damaged_one_replaced(envisat, tmp_path, monkeypatch):
    monkeypatch.setenv("POSTCAPTURE_CACHE", str(tmp_path))
    plan = plan_run(envisat, profile="realistic", cases=("joint",), duration=3.0)
    first = robust.with_model_noise(plan)
    path = robust._derived_path(plan)
    assert path.is_file() and path.parent.parent == tmp_path
    calls = []
    monkeypatch.setattr(robust, "derive_model_noise", lambda p, **k: calls.append(p) or 0.5)
    again = robust.with_model_noise(plan)  # from the file: no derivation
    assert not calls and again.tuning.model_noise == first.tuning.model_noise
    np.testing.assert_array_equal(again.tuning.discretisation_bias, first.tuning.discretisation_bias)
    path.write_bytes(b"not an npz")  # damaged: derived again, and the file replaced
    third = robust.with_model_noise(plan)
    assert len(calls) == 1 and third.tuning.model_noise == 0.5
    assert robust._load_derived(plan)[0] == 0.5


def test_faults_share_the_fault_free_derivation_and_other_settings_do_not(envisat_dict, tmp_path, monkeypatch):
    """The derivation reads fault-free, noise-free sensors, so a scenario's faults do not change what it gives
    (checked by deriving both) and share its file; a changed plant does not."""
    from postcapture.config import scenario_from_dict

    monkeypatch.setenv("POSTCAPTURE_CACHE", str(tmp_path))
    plain = scenario_from_dict(envisat_dict)
    envisat_dict["faults"] = [{"kind": "accelerometer_bias_step", "time": 1.0, "step": [4.9e-4, 0.0, 0.0]}]
    faulty = scenario_from_dict(envisat_dict)
    envisat_dict["faults"] = []
    envisat_dict["target"]["mass"] = 7900.0
    heavier = scenario_from_dict(envisat_dict)
    plans = [plan_run(sc, profile="realistic", cases=("joint",), duration=3.0) for sc in (plain, faulty, heavier)]
    assert robust._derived_path(plans[0]) == robust._derived_path(plans[1])
    assert robust._derived_path(plans[0]) != robust._derived_path(plans[2])
    noise = [robust.derive_model_noise(p) for p in plans[:2]]
    bias = [robust.discretisation_bias(robust.with_model_noise(p)) for p in plans[:2]]
    assert noise[0] == noise[1]
    np.testing.assert_array_equal(bias[0], bias[1])
