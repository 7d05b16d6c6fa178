"""The short API's surface (issue 18): one progress signature, CampaignResult on a par with RunResult, short
reprs, Trajectory.to_pandas."""

import numpy as np
import pytest

import postcapture as pc


def _recorder():
    calls = []

    def progress(task, fraction):
        assert isinstance(task, str) and isinstance(fraction, float) and 0.0 <= fraction <= 1.0, (task, fraction)
        calls.append((task, fraction))

    return calls, progress


def test_one_progress_signature_everywhere(tmp_path):
    jobs = {
        "simulate": lambda p: pc.simulate("envisat", duration=1.0, progress=p),
        "run": lambda p: pc.run("envisat", duration=2.0, cases=["mekf_flexible"], crlb=False, workers=1, progress=p),
        "campaign": lambda p: pc.campaign("envisat", runs=2, cases=["mekf_flexible"], duration=2.0, workers=0,
                                          crlb=False, progress=p),
        "calibrate_panel": lambda p: pc.calibrate_panel("envisat", weights=[0.1], progress=p),
        "export_fmu": lambda p: pc.export_fmu("envisat", tmp_path / "r.fmu", variant="rigid",
                                              directional_derivatives=False, step_jacobian=False, progress=p),
    }
    for name, job in jobs.items():
        calls, progress = _recorder()
        job(progress)
        assert calls, name
        assert calls[-1][1] == 1.0, (name, calls[-1])  # the last report says the task is done
        per_task = {}
        for task, f in calls:
            assert f >= per_task.get(task, 0.0), (name, task)  # never goes back
            per_task[task] = f


@pytest.fixture(scope="module")
def study():
    return pc.campaign("envisat", runs=3, dispersed=True, cases=["mekf_flexible", "ekf_flexible"], duration=3.0,
                       workers=0, crlb=False)


def test_campaign_result_has_the_run_results_surface(study, tmp_path):
    assert study.table.startswith("campaign 'envisat'") and max(map(len, study.table.splitlines())) <= 80
    frame = study.to_pandas()
    assert list(frame.index) == ["mekf_flexible", "ekf_flexible"]
    errors = np.array(study.summary()["cases"]["mekf_flexible"]["final_errors_kg"])
    assert frame.loc["mekf_flexible", "mass_error_rms_kg"] == pytest.approx(np.sqrt(np.mean(errors ** 2)))
    assert set(study.figures()) == {"campaign_final_errors", "campaign_nees"}
    paths = study.write(tmp_path / "c", fmt="svg")
    assert {p.name for p in paths.values()} >= {"campaign.nc", "summary.json", "table.txt", "report.md",
                                                 "campaign_nees.svg"}
    report = (tmp_path / "c" / "report.md").read_text()
    assert "## Provenance" in report and "mass NEES" in report and "![campaign nees](campaign_nees.svg)" in report


def test_reprs_are_short(study):
    cal = pc.calibrate_panel("envisat", weights=[0.1])
    run = pc.run("envisat", duration=2.0, cases=["mekf_flexible"], crlb=False, workers=1)
    for obj in (study, cal, run, pc.simulate("envisat", duration=1.0), pc.load_scenario("envisat")):
        text = repr(obj)
        assert len(text) < 300 and "\n" not in text, text
    assert "3 runs" in repr(study) and "scenario_json" not in repr(study)


def test_trajectory_to_pandas():
    traj = pc.simulate("envisat", duration=1.0)
    frame = traj.to_pandas()
    assert frame.index.name == "time" and len(frame) == traj.n
    np.testing.assert_array_equal(frame["q_BN[w]"].values, traj["q_BN"][0])
    np.testing.assert_array_equal(frame["torque_z"].values, traj.to_xarray()["torque_z"].values)
    assert frame.shape[1] > 50
