"""Hot calls go through preallocated buffers, and predict costs less than the native model's."""


import fmpy  # noqa: F401 - the fmi extra is part of the test install

from postcapture.fmi.timing import hot_call_timing  # noqa: E402


def test_hot_call_timing(envisat_fmu, envisat):
    res = hot_call_timing(envisat_fmu.path, envisat, repeats=20)
    print({k: (round(v, 2) if isinstance(v, float) else v) for k, v in res.items()})
    assert res["getreal_raw_100_us"] < res["getreal_fmpy_100_us"]
    assert res["jacobian_method"] == "outputs"
    # generous bounds on a shared machine: the compiled step is several times faster than the native one
    assert res["fmu_predict_us"] < 2.0 * res["native_predict_us"]
    assert res["fmu_predict_jac_us"] < 2.0 * res["native_predict_jac_us"]
