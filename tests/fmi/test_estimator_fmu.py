"""The estimator FMU: one doStep is one filter cycle of the native scheme, bad calls are refused.

The FMU is exported for a short copy of ``envisat`` whose filters need no derivation (model noise given, the
truth's panels the filters'), so that the export takes seconds; it is driven through fmpy's low-level API
on the same recorded sensors as the native case. The cases: the recommended ``joint`` and ``dual`` and the
reference's dual scheme with its EKF or MEKF (``ekf_flexible``, ``mekf_flexible``).
"""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

pytest.importorskip("fmpy")

from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi2 import FMU2Slave  # noqa: E402

from postcapture.config import load_scenario  # noqa: E402
from postcapture.config.estimation import FilterTuning  # noqa: E402

DURATION = 6.0
CASES = ("joint", "dual", "ekf_flexible", "mekf_flexible")


def _scenario():
    sc = load_scenario("envisat")
    unc = sc.uncertainty.model_copy(update={"truth_panel_segments": None})
    given = sc.estimation.tuning.get("reference")
    ref = FilterTuning(model_noise=1.08e-9) if given is None else given.model_copy(update={"model_noise": 1.08e-9})
    tuning = {**sc.estimation.tuning, "reference": ref}
    est = sc.estimation.model_copy(update={"tuning": tuning})
    sim = sc.simulation.model_copy(update={"duration": DURATION})
    return sc.model_copy(update={"uncertainty": unc, "estimation": est, "simulation": sim})


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    from postcapture.studies.estimator_fmu import export_estimator_fmu
    from postcapture.studies.main_job import draw_sensors, simulate_truth
    from postcapture.studies.robust import with_model_noise
    from postcapture.studies.setup import plan_run

    sc = _scenario()
    folder = tmp_path_factory.mktemp("estimator")
    fmus = {case: export_estimator_fmu(sc, folder / f"{case}.fmu", case=case).path for case in CASES}
    plan = with_model_noise(plan_run(sc, profile="reference", cases=("dual", "joint")))
    traj = simulate_truth(plan)
    sensors, dq0 = draw_sensors(plan, traj, plan.seed)
    return sc, plan, sensors, traj["q_BN"][:, 0], dq0, fmus


class Driver:
    """One instance of an estimator FMU through fmpy's FMU2Slave, with named variables."""

    def __init__(self, path, q0=None):
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=extract(str(path)),
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="estimator")
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        if q0 is not None:
            self.set({f"q0_BN_{a}": v for a, v in zip("wxyz", q0)})
        self.fmu.exitInitializationMode()

    def set(self, values: dict) -> None:
        self.fmu.setReal([self.vr[k] for k in values], [float(v) for v in values.values()])

    def get(self, *names) -> np.ndarray:
        return np.array(self.fmu.getReal([self.vr[n] for n in names]))

    def inputs(self, star, gyro, accel, enc) -> None:
        values = {}
        for prefix, names, sample in (("star_q_", "wxyz", star), ("gyro_", "xyz", gyro), ("accel_", "xyz", accel)):
            values.update({prefix + a: v for a, v in zip(names, np.nan_to_num(sample))})
        values.update({f"encoder_{i + 1}": v for i, v in enumerate(np.nan_to_num(enc))})
        values.update(star_valid=np.all(np.isfinite(star)), gyro_valid=np.all(np.isfinite(gyro)),
                      accel_valid=np.all(np.isfinite(accel)), encoders_valid=np.all(np.isfinite(enc)))
        self.set(values)


def _grids(sensors, t_grid):
    from postcapture.estimation.dual import on_grid

    return (on_grid(sensors.star, t_grid), on_grid(sensors.gyro, t_grid), on_grid(sensors.accel, t_grid),
            on_grid(sensors.joints, t_grid))


def _run_against_native(path, plan, sensors, q_true0, dq0, case):
    """The FMU driven on the recorded sensors beside the native case: ``(fmu histories, native result, driver)``."""
    from postcapture.core import rotations as rot
    from postcapture.studies.main_job import run_case

    native = run_case(plan, case, sensors, q_true0, dq0)
    drv = Driver(path, q0=rot.box_plus(q_true0, dq0))
    star, gyro, accel, enc = _grids(sensors, plan.t_grid)
    names = ("target_mass", "target_mass_sigma", "q_BN_w", "q_BN_x", "q_BN_y", "q_BN_z", "attitude_sigma_x",
             "attitude_sigma_y", "attitude_sigma_z")
    hist = [drv.get(*names)]
    dt = plan.t_grid[1] - plan.t_grid[0]
    for k in range(plan.t_grid.size - 1):
        drv.inputs(star[:, k + 1], gyro[:, k], accel[:, k], enc[:, k + 1])
        drv.fmu.doStep(currentCommunicationPoint=plan.t_grid[k], communicationStepSize=dt)
        hist.append(drv.get(*names))
    return np.array(hist).T, native, drv


def _assert_agree(hist, native, rtol=1e-9):
    sigma = np.sqrt(np.einsum("iik->ik", native.attitude.P)[:3])
    for got, want, what in ((hist[0], native.mass, "mass"), (hist[1], native.mass_sigma, "mass sigma"),
                            (hist[2:6], native.attitude.q_BN, "attitude"), (hist[6:9], sigma, "attitude sigma")):
        assert np.max(np.abs(got - want)) <= rtol * np.max(np.abs(want)), what


@pytest.mark.parametrize("case", CASES)
def test_the_estimator_fmu_reproduces_the_native_case(setup, case):
    sc, plan, sensors, q_true0, dq0, fmus = setup
    hist, native, drv = _run_against_native(fmus[case], plan, sensors, q_true0, dq0, case)
    _assert_agree(hist, native)
    # the mass moves by far more than the tolerance: a cycle that differed would show
    assert np.ptp(hist[0]) > 1e3 * 1e-9 * np.max(hist[0]), "the mass did not move: the comparison proves nothing"
    assert drv.get("recoveries", "diverged", "n_missing", "n_outliers").tolist() == [0, 0, 0, 0]


@pytest.mark.slow
@pytest.mark.parametrize("case", ["ekf_flexible", "mekf_flexible"])
def test_the_reference_dual_fmu_reproduces_the_realistic_profile(tmp_path, case):
    from postcapture.studies.estimator_fmu import export_estimator_fmu
    from postcapture.studies.main_job import draw_sensors, simulate_truth
    from postcapture.studies.setup import plan_run

    sc = _scenario()
    path = export_estimator_fmu(sc, tmp_path / f"{case}.fmu", case=case, profile="realistic").path
    plan = plan_run(sc, profile="realistic", cases=(case,))
    traj = simulate_truth(plan)
    sensors, dq0 = draw_sensors(plan, traj, plan.seed)
    hist, native, drv = _run_against_native(path, plan, sensors, traj["q_BN"][:, 0], dq0, case)
    _assert_agree(hist, native)
    assert np.all(np.isfinite(drv.get("accel_bias_x", "accel_bias_y", "accel_bias_z")))


def test_a_reference_dual_fmu_outputs_what_its_filters_estimate(setup):
    names = {case: {v.name for v in read_model_description(str(setup[-1][case])).modelVariables}
             for case in ("ekf_flexible", "mekf_flexible")}
    for case, have in names.items():
        assert {"target_mass", "target_mass_sigma", "nis_star", "nis_accelerations", "diverged"} <= have, case
        assert not any(n.startswith("p.") or n.startswith("p_sigma.") for n in have), case  # the mass alone
        assert "nis_gyro" not in have and "nis_encoders" not in have, case  # accelerations: one measurement
    assert "ekf_Q[1,1]" in names["ekf_flexible"] and "gyro_bias_x" not in names["ekf_flexible"]
    assert "mekf_sigma_v" in names["mekf_flexible"] and "gyro_bias_x" in names["mekf_flexible"]


def missing_and_outliers(drv, plan, sensors) -> None:
    """The first two filter cycles with bad measurements, through a driver of either FMI version: a NaN gyro
    and an infinite accelerometer component are missing and counted, never propagated; a star-tracker
    quaternion of norm 1.1 is an outlier."""
    star, gyro, accel, enc = _grids(sensors, plan.t_grid)
    dt = plan.t_grid[1] - plan.t_grid[0]
    drv.inputs(star[:, 1], gyro[:, 0], accel[:, 0], enc[:, 1])
    drv.set({"gyro_y": np.nan, "accel_x": np.inf})
    drv.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=dt)
    assert drv.get("n_missing")[0] == 2
    drv.inputs(1.1 * star[:, 2], gyro[:, 1], accel[:, 1], enc[:, 2])
    drv.fmu.doStep(currentCommunicationPoint=dt, communicationStepSize=dt)
    assert drv.get("n_outliers")[0] == 1
    out = drv.get("target_mass", "q_BN_w", "q_BN_x", "attitude_sigma_x", "nis_star")
    assert np.all(np.isfinite(out[:4])) and out[4] == -1.0  # no star-tracker update: no NIS


def bad_states(raw: bytes) -> list[bytes]:
    """A serialised estimator state with its data zero (quaternions and covariance), doubled (non-unit
    quaternions) and NaN, its header kept (magic, size, mode, last good time: 24 bytes)."""
    header = 24
    data = np.frombuffer(raw[header:], dtype=np.float64)
    return [raw[:header] + bad.tobytes() for bad in (np.zeros_like(data), 2.0 * data, np.full_like(data, np.nan))]


@pytest.mark.parametrize("case", ["joint", "ekf_flexible", "mekf_flexible"])
def test_bad_calls_are_refused_or_counted(setup, case):
    sc, plan, sensors, q_true0, dq0, fmus = setup
    drv = Driver(fmus[case])
    dt = plan.t_grid[1] - plan.t_grid[0]
    with pytest.raises(FMICallException):  # a step other than the filter's period
        drv.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.5 * dt)
    missing_and_outliers(drv, plan, sensors)
    # states with a zero, non-unit or NaN quaternion and covariance are refused
    state = drv.fmu.getFMUstate()
    raw = bytes(drv.fmu.serializeFMUstate(state))
    for bad in bad_states(raw):
        with pytest.raises(FMICallException):
            drv.fmu.deSerializeFMUstate(bad)
    good = drv.fmu.deSerializeFMUstate(raw)
    drv.fmu.setFMUstate(good)
    drv.fmu.freeFMUstate(state)


def test_the_estimator_fmu_validates(setup):
    from fmpy.validation import validate_fmu

    for path in setup[-1].values():
        assert validate_fmu(str(path)) == []


@pytest.mark.skipif(shutil.which("fmuCheck") is None and not shutil.os.path.exists("/work/tools/bin/fmuCheck"),
                    reason="the FMI Compliance Checker is not installed (it is built from source, not on CI)")
@pytest.mark.parametrize("case", ["joint", "ekf_flexible", "mekf_flexible"])
def test_the_compliance_checker_finds_no_error(setup, tmp_path, case):
    exe = shutil.which("fmuCheck") or "/work/tools/bin/fmuCheck"
    proc = subprocess.run([exe, "-h", "0.1", "-s", str(DURATION), "-l", "3", "-o", str(tmp_path / "out.csv"),
                           "-e", str(tmp_path / "log.txt"), "-t", str(tmp_path), str(setup[-1][case])],
                          capture_output=True, text=True, timeout=300)
    log = (tmp_path / "log.txt").read_text()
    assert proc.returncode == 0, log[-2000:]
    assert re.search(r"Checker reported:\s*\d+ Warning\(s\)\s*0 Error\(s\)", log), log[-2000:]
    assert re.search(r"FMU reported:\s*0 warning\(s\) and error\(s\)", log), log[-2000:]
