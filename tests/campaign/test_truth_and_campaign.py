"""Truth apart from the filters, scheduled faults, and campaigns on a real Dask cluster."""

import dataclasses
import json
import os
import signal

import numpy as np
import pytest

from postcapture.studies.main_job import run_main_job
from postcapture.studies.montecarlo import run_campaign
from postcapture.studies.sensing import measure_all, resolve_profile
from postcapture.config import scenario_from_dict
from postcapture.core.errors import ScenarioError
from postcapture.core.units import DEG_PER_HOUR
from postcapture.dynamics.simulate import simulate
from postcapture.dynamics.truth import check_priors, draw_truth, nominal_truth, truth_from_scenario

CASES = ("ekf_flexible", "mekf_flexible", "joint")


def _histories(result):
    return {name: (c.result.mass, c.result.mass_sigma, c.result.attitude.q_BN) for name, c in result.cases.items()}


def test_a_truth_identical_to_the_nominal_model_reproduces_run_exactly(envisat):
    plain = run_main_job(envisat, duration=15.0, cases=CASES, workers=1, crlb=False)
    same = run_main_job(envisat, truth=truth_from_scenario(envisat, envisat, "copy"), duration=15.0, cases=CASES,
                        workers=1, crlb=False)
    for name, (m, s, q) in _histories(plain).items():
        m2, s2, q2 = _histories(same)[name]
        np.testing.assert_array_equal(m, m2)
        np.testing.assert_array_equal(s, s2)
        np.testing.assert_array_equal(q, q2)
    assert same.summary()["truth"]["source"] == "scenario copy"


def test_a_different_truth_changes_the_truth_not_the_filters(envisat):
    nominal = run_main_job(envisat, duration=15.0, cases=("ekf_flexible",), workers=1, crlb=False)
    truth = draw_truth(envisat, 5)
    drawn = run_main_job(envisat, truth=truth, duration=15.0, cases=("ekf_flexible",), workers=1, crlb=False)
    # the truth moved ...
    assert np.abs(drawn.truth["accel_B"] - nominal.truth["accel_B"]).max() > 1e-4
    assert drawn.truth.attrs["panel_segments"] == "20,20"
    info = drawn.summary()["truth"]
    assert info["source"] == "draw 5" and info["panel_segments"] == [20, 20]
    assert info["target_mass"] == pytest.approx(truth.describe(envisat)["target_mass"])
    assert abs(info["target_mass"] - envisat.target.mass) > 1.0
    assert drawn.true_mass == info["target_mass"]
    # ... the filters did not: same nominal model, same start
    a, b = nominal.cases["ekf_flexible"].result, drawn.cases["ekf_flexible"].result
    assert a.mass[0] == b.mass[0] == envisat.target.mass + envisat.estimation.initial_mass_error
    assert a.mass_sigma[0] == b.mass_sigma[0]
    assert drawn.nominal_mass == envisat.target.mass


def test_the_nominal_truth_describes_the_published_target(envisat):
    info = nominal_truth(envisat).describe(envisat)
    assert info["target_mass"] == pytest.approx(7827.9, rel=1e-12)
    # T sits 5 m along the grasp frame's x axis (grasp_to_com), the CoM at T's origin
    assert [info[f"target_com_{a}"] for a in "xyz"] == pytest.approx([5.0, 0.0, 0.0], abs=1e-9)
    assert [info["target_I_xx"], info["target_I_yy"], info["target_I_zz"], info["target_I_xy"], info["target_I_xz"],
            info["target_I_yz"]] == pytest.approx([17023.3, 124825.7, 129112.2, 397.1, -2171.4, 344.2], rel=1e-9)


def test_drawn_truths_are_physical_and_follow_the_priors(envisat):
    masses, scales = [], []
    for seed in range(60):
        info = draw_truth(envisat, seed).describe(envisat)
        I = np.array([[info["target_I_xx"], info["target_I_xy"], info["target_I_xz"]],
                      [info["target_I_xy"], info["target_I_yy"], info["target_I_yz"]],
                      [info["target_I_xz"], info["target_I_yz"], info["target_I_zz"]]])
        a, b, c = np.linalg.eigvalsh(I)
        assert a > 0 and a + b >= c
        masses.append(info["target_mass"])
        scales.append(info["arm.stiffness_scale"])
    assert 0.8 <= min(scales) and max(scales) <= 1.2  # uniform on [0.8, 1.2]
    assert 50.0 < np.std(masses) < 150.0  # sigma 100 kg
    np.testing.assert_array_equal(draw_truth(envisat, 3).vector(envisat), draw_truth(envisat, 3).vector(envisat))


def test_scheduled_outage_and_gyro_bias_step_reach_the_truths_sensor_records(envisat_dict):
    envisat_dict["faults"] = [
        {"kind": "star_tracker_outage", "start": 20.0, "stop": 50.0},
        {"kind": "gyro_bias_step", "time": 30.0, "step": [1.0 * DEG_PER_HOUR, 0.0, 0.0]},
    ]
    sc = scenario_from_dict(envisat_dict)
    traj = simulate(sc, duration=60.0)
    profile = resolve_profile(sc, "realistic")
    clean = measure_all(traj, profile, np.random.default_rng(4))
    faulty = measure_all(traj, profile, np.random.default_rng(4), sc.faults)
    t = faulty.star.t
    out = (t >= 20.0) & (t < 50.0)
    assert not faulty.star.valid[out].any() and faulty.star.valid[~out].all()
    assert np.isnan(faulty.star.values[:, out]).all()
    np.testing.assert_array_equal(faulty.star.values[:, ~out], clean.star.values[:, ~out])  # same noise elsewhere
    step = faulty.gyro.values - clean.gyro.values
    after = faulty.gyro.t >= 30.0
    np.testing.assert_allclose(step[0, after], 1.0 * DEG_PER_HOUR, rtol=1e-9)
    assert np.all(step[:, ~after] == 0.0) and np.all(step[1:, after] == 0.0)
    np.testing.assert_allclose(faulty.gyro.truth["bias_B"][0, after] - clean.gyro.truth["bias_B"][0, after],
                               1.0 * DEG_PER_HOUR, rtol=1e-9)


def test_stuck_and_dropped_joint_sensors(envisat_dict):
    envisat_dict["faults"] = [{"kind": "joint_stuck", "joint": 2, "start": 5.0, "stop": 8.0},
                              {"kind": "joint_dropout", "joint": 4, "start": 6.0}]
    sc = scenario_from_dict(envisat_dict)
    traj = simulate(sc, duration=10.0)
    s = measure_all(traj, resolve_profile(sc, "realistic"), np.random.default_rng(1), sc.faults).joints
    stuck = (s.t >= 5.0) & (s.t < 8.0)
    assert np.all(s.values[1, stuck] == s.values[1, np.nonzero(s.t < 5.0)[0][-1]])
    assert np.isnan(s.values[3, s.t >= 6.0]).all() and np.isfinite(s.values[3, s.t < 6.0]).all()
    assert np.isfinite(s.values[[0, 2, 4, 5, 6]]).all()


# ------------------------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("uncertainty,match", [
    ({"target_mass": {"sigma": -5.0}}, r"uncertainty\.target_mass\.sigma: expected a number > 0"),
    ({"target_com": {"sigma": float("nan")}}, r"uncertainty\.target_com\.sigma: expected a finite number"),
    ({"panel_bending": {"sigma": 0.5}}, r"uncertainty\.panel_bending: expected draws of a factor that stay > 0"),
    ({"arm_damping": {"kind": "loguniform", "low": 0.0, "high": 2.0}}, r"low > 0 for a loguniform prior"),
    ({"arm_stiffness": {"kind": "uniform", "low": 1.2, "high": 0.8}}, r"high > low"),
    ({"target_mass": {"sigma": 3000.0}}, r"uncertainty\.target_mass: expected draws that keep the target heavier than its panels"),
])
def test_bad_priors_are_refused_when_loaded(envisat_dict, uncertainty, match):
    envisat_dict["uncertainty"] = uncertainty
    with pytest.raises(ScenarioError, match=match):
        scenario_from_dict(envisat_dict)


def test_a_prior_drawing_mostly_impossible_bodies_is_refused_before_work(envisat_dict):
    envisat_dict["uncertainty"] = {"target_inertia_moments": {"sigma": 0.3}}  # Envisat is 9 % from the triangle limit
    sc = scenario_from_dict(envisat_dict)
    with pytest.raises(ScenarioError, match="target_inertia_moments.*triangle inequality"):
        check_priors(sc)
    with pytest.raises(ScenarioError, match="target_inertia_moments"):
        run_campaign(sc, runs=2, dispersed=True, workers=0, duration=2.0, crlb=False)


@pytest.mark.parametrize("fault,match", [
    ({"kind": "star_tracker_blackout", "start": 1.0}, r"faults\[0\]: expected kind one of star_tracker_outage, .*found 'star_tracker_blackout' \(did you mean "
     r"'star_tracker_outage'\?\)"),
    ({"kind": "gyro_outage", "start": 250.0, "stop": 400.0}, r"faults\[0\]\.stop: expected a fault window ending inside"),
    ({"kind": "joint_stuck", "joint": 9, "start": 1.0}, r"faults\[0\]\.joint: expected a joint among the arm's joints 1\.\.7"),
    ({"kind": "gyro_bias_step", "time": 10.0}, r"faults\[0\]\.step: expected a value"),
])
def test_bad_faults_are_refused_when_loaded(envisat_dict, fault, match):
    envisat_dict["faults"] = [fault]
    with pytest.raises(ScenarioError, match=match):
        scenario_from_dict(envisat_dict)


def test_a_fault_outside_a_shortened_run_is_refused_before_simulating(envisat_dict):
    envisat_dict["faults"] = [{"kind": "star_tracker_outage", "start": 150.0, "stop": 180.0}]
    sc = scenario_from_dict(envisat_dict)
    with pytest.raises(ScenarioError, match=r"faults\[0\]: expected a fault starting inside the run \(before 100 s\)"):
        run_main_job(sc, duration=100.0, workers=1)


def test_a_truth_scenario_of_another_structure_is_refused(envisat_dict, envisat):
    envisat_dict["arm"]["joints"] = envisat_dict["arm"]["joints"][:6]
    other = scenario_from_dict(envisat_dict)
    with pytest.raises(ScenarioError, match=r"arm\.joints: expected 7 joints like the nominal scenario, found 6"):
        truth_from_scenario(envisat, other, "six.toml")


def test_an_unreachable_scheduler_is_a_clear_error_before_any_simulation(envisat, tmp_path):
    with pytest.raises(ScenarioError, match=r"--scheduler: expected the address of a running Dask scheduler"):
        run_campaign(envisat, runs=2, scheduler="tcp://127.0.0.1:9", duration=2.0, out=tmp_path / "c", crlb=False)


# ------------------------------------------------------------------------------------------- campaigns
def _same_runs(a, b):
    assert [r["run"] for r in a.runs] == [r["run"] for r in b.runs]
    for ra, rb in zip(a.runs, b.runs):
        np.testing.assert_array_equal(ra["truth"], rb["truth"])
        for case in a.cases:
            for key in ("mass_error", "mass_sigma", "attitude_error", "attitude_nees"):
                np.testing.assert_array_equal(ra["cases"][case][key], rb["cases"][case][key])


def test_a_killed_worker_loses_no_run(envisat, tmp_path):
    from dask.distributed import Client, LocalCluster

    settings = dict(runs=6, dispersed=True, cases=("mekf_flexible",), duration=6.0, crlb=False)
    killed = []
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        pids = client.run(os.getpid)

        def progress(task, fraction):
            # after the first run both workers hold queued runs (6 runs, 2 workers), so either one is busy; the
            # callback runs on the campaign's own client, so it must not call this test's client (another
            # event loop: asyncio refuses an Event bound to a different loop)
            if fraction > 0 and not killed:
                address, pid = next(iter(pids.items()))
                os.kill(pid, signal.SIGKILL)
                killed.append(address)

        with_kill = run_campaign(envisat, scheduler=cluster.scheduler_address, out=tmp_path / "dask",
                                 progress=progress, **settings)
    assert killed, "no worker was busy to be killed"
    assert len(with_kill.runs) == 6
    single = run_campaign(envisat, workers=0, **settings)
    _same_runs(with_kill, single)


def test_an_interrupted_campaign_resumes_and_merges_to_the_same_results(envisat, tmp_path):
    settings = dict(runs=4, dispersed=True, cases=("mekf_flexible",), duration=6.0, crlb=False, workers=0)

    def interrupt(task, fraction):
        if fraction == 0.5:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_campaign(envisat, out=tmp_path / "c", progress=interrupt, **settings)
    reports = []
    resumed = run_campaign(envisat, out=tmp_path / "c", progress=lambda task, f: reports.append((task, f)), **settings)
    assert resumed.resumed == 2 and reports == [("runs", 0.5), ("runs", 0.75), ("runs", 1.0)]
    _same_runs(resumed, run_campaign(envisat, **settings))
    with pytest.raises(ScenarioError, match=r"--out: expected a new folder, or this campaign's own .*runs"):
        run_campaign(envisat, out=tmp_path / "c", **{**settings, "runs": 5})


def test_campaign_summary_and_files(envisat, tmp_path):
    from postcapture.studies.results import write_campaign

    res = run_campaign(envisat, runs=3, cases=("mekf_flexible", "ekf_flexible"), duration=5.0, workers=0, crlb=False)
    s = res.summary()
    assert s["runs"] == 3
    for c in s["cases"].values():
        assert set(c) >= {"mass_error_rms_kg", "mass_error_mean_kg", "inside_3sigma_fraction", "nees_mean", "nees_band",
                          "diverged_runs", "crlb_kg"}
        errs = np.array(c["final_errors_kg"])
        assert c["mass_error_rms_kg"] == pytest.approx(np.sqrt(np.mean(errs**2)))
    paths = write_campaign(res, tmp_path)
    import xarray as xr

    ds = xr.open_dataset(paths["results"])
    assert ds["mass_error"].shape == (3, 2, 51) and ds["truth_target_mass"].shape == (3,)
    assert json.loads(ds.attrs["summary_json"])["runs"] == 3
    ds.close()
    from postcapture.report.campaign import campaign_figures

    for fig in campaign_figures(xr.open_dataset(paths["results"]).load(), s).values():
        title = fig._suptitle.get_text()
        assert "envisat" in title and "realistic profile" in title and f"seeds ({envisat.estimation.seed}, r)" in title, title


def test_target_sigmas_match_a_sampled_covariance(envisat):
    """The campaign's CoM and inertia 1-sigma (the filter's covariance of the ten inertial parameters carried
    to first order) against sampling that covariance through the exact map; errors against the truth."""
    from types import SimpleNamespace

    from postcapture.dynamics.truth import target_properties, truth_vector_names
    from postcapture.studies.montecarlo import _target_errors
    from postcapture.studies.setup import plan_run

    plan = plan_run(envisat, cases=("joint",), duration=1.0)
    truth_vec = plan.truth.vector(envisat)
    names = truth_vector_names(envisat)
    pi = plan.truth.build().parameters()[:10]
    rng = np.random.default_rng(3)
    A = rng.normal(size=(10, 10))
    scale = 1e-3 * np.maximum(np.abs(pi), 1.0)
    C = (A @ A.T / 10) * np.outer(scale, scale)
    res = SimpleNamespace(params=np.column_stack([pi, pi]), params_cov=C)
    out = _target_errors(plan, res, truth_vec, names)
    assert np.allclose(out["com_error"], 0.0, atol=1e-9) and np.allclose(out["inertia_error"], 0.0, atol=1e-6)
    draws = rng.multivariate_normal(pi, C, size=4000)
    ys = []
    for d in draws:
        w = target_properties(envisat, d)
        ys.append(np.r_[w.com, w.inertia[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]])
    sampled = np.std(ys, axis=0, ddof=1)
    assert np.allclose(np.r_[out["com_sigma"], out["inertia_sigma"]], sampled, rtol=0.06)
