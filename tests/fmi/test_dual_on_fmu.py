"""Every estimator around an FMU plant: on the exported FMU the cases give the native run's estimates; an
FMU that lacks what a case needs leaves that case out with one message naming what is missing."""

from pathlib import Path

import numpy as np
import pytest

from tiny_fmu import build_tiny_fmu  # noqa: E402

from postcapture.report.table import results_table  # noqa: E402
from postcapture.studies.main_job import run_main_job  # noqa: E402


def _compare(a, b, tol):
    assert np.abs(a.mass - b.mass).max() / np.abs(a.mass).max() <= tol
    assert np.abs(a.mass_sigma - b.mass_sigma).max() / np.abs(a.mass_sigma).max() <= tol
    assert np.abs(a.attitude.q_BN - b.attitude.q_BN).max() <= tol


def _every_step(scenario):
    """An FMU plant's Jacobian is its communication step's own: the native filters then chain each step's too."""
    return scenario.model_copy(update={"estimation": scenario.estimation.model_copy(update={"jacobian": "every_step"})})


def test_dual_ekf_on_fmu_matches_native(envisat, envisat_fmu):
    envisat = _every_step(envisat)
    runs = {
        plant: run_main_job(envisat, profile="reference", cases=("ekf_flexible",), crlb=False, workers=1,
                            plant=plant, duration=60.0)
        for plant in ("native", f"fmu:{envisat_fmu.path}")
    }
    a = runs["native"].cases["ekf_flexible"].result
    b = runs[f"fmu:{envisat_fmu.path}"].cases["ekf_flexible"].result
    _compare(a, b, 1e-6)  # (their cost is the bench's business: a wall-clock ratio here failed on a loaded machine)


def _recommended(scenario, plant, duration):
    run = run_main_job(scenario, profile="realistic", cases=("dual", "joint"), crlb=False, workers=1, plant=plant,
                       duration=duration)
    return {c: run.cases[c].result for c in ("dual", "joint")}


@pytest.fixture
def quick(envisat_dict):
    """The default scenario with its model noise given and the filters' own panels as the truth's: the same
    filters on the same plant, without the minutes of deriving the noise from two 300 s simulations."""
    from postcapture.config import scenario_from_dict

    envisat_dict["estimation"]["tuning"] = {"realistic": {"model_noise": 1e-11}}
    envisat_dict["estimation"]["jacobian"] = "every_step"  # what an FMU plant gives: each step's own
    del envisat_dict["uncertainty"]["truth_panel_segments"]
    return scenario_from_dict(envisat_dict)


def test_recommended_schemes_on_fmu_match_native(quick, envisat_fmu):
    """``dual`` and ``joint`` on the FMU plant: its exact G from the Jacobian outputs, the parameter vector
    through its inputs; masses, their sigmas and the attitude as the native run's over 20 s (the whole run:
    test_recommended_schemes_whole_run)."""
    native = _recommended(quick, "native", 20.0)
    fmu = _recommended(quick, f"fmu:{envisat_fmu.path}", 20.0)
    for case in ("dual", "joint"):
        assert fmu[case].attitude.success, fmu[case].attitude.message
        _compare(native[case], fmu[case], 1e-6)


def test_an_fmu_that_lacks_what_a_case_needs(quick, tiny_dir):
    """Another tool's FMU (a rigid body, quaternion state, no parameter inputs): neither a recommended case
    nor the reference's dual scheme can run; each says what is missing and the table shows it."""
    path = build_tiny_fmu(Path(tiny_dir), "ok")
    run = run_main_job(quick, profile="realistic", cases=("joint", "ekf_flexible"), crlb=False, workers=1, plant=f"fmu:{path}",
                       duration=1.0)
    joint = run.cases["joint"].result.attitude
    ekf = run.cases["ekf_flexible"].result.attitude
    assert not joint.success and joint.message.startswith("not run: the FMU plant lacks")
    for need in ("[state] velocity", "[measurement] accelerometer_position", "[state] arm",
                 "[parameters] inputs: inputs holding target.m"):
        assert need in joint.message
    assert not ekf.success and "[parameters] mass" in ekf.message and "[state] arm" not in ekf.message
    table = " ".join(results_table(run.summary()).split())
    assert "joint: not run: the FMU plant lacks [state] velocity" in table
    assert "ekf_flexible: not run:" in table
    assert np.isnan(run.cases["joint"].result.mass).all()


@pytest.mark.slow
@pytest.mark.parametrize("which", ["fmi2", "fmi3"])
def test_recommended_schemes_whole_run(envisat, envisat_fmu, envisat_fmu3, which):
    """The acceptance figure: the realistic profile's 300 s, final masses to 1e-6 of the native run's."""
    report = envisat_fmu3 if which == "fmi3" else envisat_fmu
    envisat = _every_step(envisat)
    native = _recommended(envisat, "native", None)
    fmu = _recommended(envisat, f"fmu:{report.path}", None)
    for case in ("dual", "joint"):
        assert abs(fmu[case].mass[-1] - native[case].mass[-1]) <= 1e-6 * abs(native[case].mass[-1])
        _compare(native[case], fmu[case], 1e-6)
